"""When a robot contact first falls: 200 validation episodes (seed 1,000,000,007) per policy, the share of episodes
with a robot contact, the step of the first one (binned), whether it involves the leader, whether the leader
entered or left the obstacle area (the formation switching) in the 10 steps before it, and whether the leader was
inside the area then.

    python docs/results/probe_start_price_2m/first_contact.py CKPT [CKPT ...]     # run dirs or policy files
"""
import sys

import torch

from formation_rl import load_policy
from formation_rl.evaluation.evaluate import evaluate_policy
from formation_rl.training.config import TrainConfig

BINS = ((1, 6), (7, 15), (16, 30), (31, 60), (61, 100), (101, 150))


def first_contacts(cfg):
    threshold = 2 * cfg.robot_radius + cfg.robot_collision_margin

    def metrics(rollout, goal_radius):
        p = rollout["next", "state", "positions"]  # [B, T, N, 2]
        d = (p[..., :, None, :] - p[..., None, :, :]).norm(dim=-1) + torch.eye(cfg.num_robots) * 1e3  # no self
        hit = d < threshold  # [B, T, N, N]
        robot = hit.flatten(-2).any(-1)  # [B, T]
        area = rollout["next", "in_obstacle_area"].reshape(rollout.shape)
        switch = torch.zeros_like(area)
        switch[:, 1:] = area[:, 1:] != area[:, :-1]
        touched = robot.any(1)
        first = robot.float().argmax(1)  # 0-based step index of the first contact (0 where none: masked below)
        rows = torch.arange(len(first))
        window = torch.stack([switch[rows, (first - k).clamp_min(0)] for k in range(11)], 1).any(1)
        return {"touched": touched, "first": torch.where(touched, first + 1, 0), "leader": hit[rows, first, 0].any(-1),
                "switch": window, "in_area": area[rows, first]}

    return metrics


torch.set_num_threads(2)
print("| policy | episodes with a robot contact | first contact in steps " + " | ".join(f"{a}-{b}" for a, b in BINS)
      + " | first contact involves the leader | formation switch in the 10 steps before | leader in the area |")
print("|---" * (5 + len(BINS)) + "|")
for ckpt in sys.argv[1:]:
    policy = load_policy(ckpt)
    m = evaluate_policy(policy, policy.env_config, 200, seed=TrainConfig.eval_seed, progress=False,
                        metrics=first_contacts(policy.env_config))
    t, f = m["touched"], m["first"]
    share = " | ".join(f"{((f >= a) & (f <= b)).float().mean():.0%}" for a, b in BINS)
    print(f"| {ckpt} | {t.float().mean():.0%} | {share} | {m['leader'][t].float().mean():.0%} | "
          f"{m['switch'][t].float().mean():.0%} | {m['in_area'][t].float().mean():.0%} |")

"""Where the team loses its formation: the leader's route, when it reaches the goal, the formation error by phase,
the followers' speed and their share of steps inside the obstacle area by phase, on 200 validation episodes
(seed 1,000,000,007), for each policy given (a run directory, a policy file or a pretrained one); then success and
RFSE split by the leader's route (through the area: the leader inside it in at least 10% of the steps).

    python docs/results/probe_velocity_2m/late_phase.py CKPT [CKPT ...]
"""
import functools
import sys

import torch

from formation_rl import load_policy
from formation_rl.envs.metrics import episode_metrics
from formation_rl.evaluation.evaluate import evaluate_policy
from formation_rl.training.config import TrainConfig

PHASES = ((0, 50), (50, 90), (90, 120), (120, 150))


def per_episode(rollout, goal_radius, area):
    pos = rollout["next", "state", "positions"]  # [B, T, N, 2]
    goal = rollout["next", "state", "goal"]  # [B, T, 2]
    x, y = pos[..., 0], pos[..., 1]
    (x0, x1), (y0, y1) = area
    in_area = ((x > x0) & (x < x1) & (y > y0) & (y < y1)).float()  # strictly inside, as the env's leader flag
    speed = rollout["next", "state", "velocities"].norm(dim=-1)  # [B, T, N]
    error = rollout["next", "formation_error"][..., 0]  # [B, T]
    near = (pos[:, :, 0] - goal).norm(dim=-1) < 0.3  # the leader within 0.3 m of the goal
    out = {"leader within 0.3 m of the goal, first step": torch.where(near.any(1), near.float().argmax(1), 150).float(),
           "leader below the area (y <= -2)": ((y[..., 0] <= y0) & (x[..., 0] > x0) & (x[..., 0] < x1)).float().mean(1),
           "leader right of the area (x >= 3)": (x[..., 0] >= x1).float().mean(1),
           "leader in the area": rollout["next", "in_obstacle_area"][..., 0].float().mean(1)}
    for a, b in PHASES:
        out[f"formation error (m), steps {a}-{b - 1}"] = error[:, a:b].mean(1)
        out[f"followers' speed (m/s), steps {a}-{b - 1}"] = speed[:, a:b, 1:].mean((1, 2))
        out[f"followers in the area, steps {a}-{b - 1}"] = in_area[:, a:b, 1:].mean((1, 2))
    return out | {"success": episode_metrics(rollout, goal_radius)["success"], "RFSE": error.mean(1)}


if len(sys.argv) < 2:
    sys.exit("usage: python docs/results/probe_velocity_2m/late_phase.py CKPT [CKPT ...]")
torch.set_num_threads(1)
rows = {}
for ckpt in sys.argv[1:]:
    policy = load_policy(ckpt)
    area = (policy.env_config.obstacle_area_x, policy.env_config.obstacle_area_y)
    rows[ckpt] = evaluate_policy(policy, policy.env_config, 200, seed=TrainConfig.eval_seed, progress=False,
                                 metrics=functools.partial(per_episode, area=area))
names = [k for k in next(iter(rows.values())) if k not in ("success", "RFSE")]
print("| quantity (200 validation episodes; means, the first row a median) | " + " | ".join(rows) + " |")
print("|---|" + "---|" * len(rows))
for name in names:
    cells = [(v[name].median() if name.startswith("leader within") else v[name].mean()).item() for v in rows.values()]
    print(f"| {name} | " + " | ".join(f"{c:.2f}" for c in cells) + " |")
print("\n| route | " + " | ".join(rows) + " |")
print("|---|" + "---|" * len(rows))
for route in ("through the area", "around it"):
    cells = []
    for v in rows.values():
        through = v["leader in the area"] >= 0.1
        pick = through if route == "through the area" else ~through
        cells.append(f"{pick.float().mean():.0%} of the episodes: success {v['success'][pick].float().mean():.1%}, "
                     f"RFSE {v['RFSE'][pick].mean():.2f} m" if pick.any() else "none")
    print(f"| {route} | " + " | ".join(cells) + " |")

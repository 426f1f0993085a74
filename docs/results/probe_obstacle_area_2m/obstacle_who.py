"""Who touches obstacles, and where: the share of episodes in which the leader / a follower has an obstacle contact,
on 200 validation episodes (seed 1,000,000,007), and whether the leader was in the obstacle area then.

    python docs/results/probe_obstacle_area_2m/obstacle_who.py CKPT [CKPT ...]
"""
import sys

import torch

from formation_rl import load_policy
from formation_rl.evaluation.evaluate import evaluate_policy
from formation_rl.training.config import TrainConfig


def obstacle_hits(cfg):
    """Per robot and step, an obstacle contact (the env reports only whether any robot has one)."""
    def metrics(rollout, goal_radius):
        pos = rollout["next", "state", "positions"]  # [B,T,N,2]
        c = rollout["state", "obstacle_centers"]  # [B,T,M,2]
        rad = rollout["state", "obstacle_radii"]  # [B,T,M]
        gap = (pos[:, :, :, None] - c[:, :, None]).norm(dim=-1) - rad[:, :, None] - cfg.robot_radius  # [B,T,N,M]
        hit = (gap < cfg.obstacle_collision_margin).any(-1)  # [B,T,N]
        return {"hit": hit.float(), "area": rollout["next", "in_obstacle_area"].float().reshape(hit.shape[:2])}

    return metrics


torch.set_num_threads(1)
for ckpt in sys.argv[1:]:
    policy = load_policy(ckpt)
    out = evaluate_policy(policy, policy.env_config, 200, seed=TrainConfig.eval_seed, progress=False,
                          metrics=obstacle_hits(policy.env_config))
    hit, area = out["hit"] > 0, out["area"] > 0
    lead, fol = hit[..., 0].any(1), hit[..., 1:].any(-1).any(1)
    fol_steps = hit[..., 1:].any(-1)
    print(f"{ckpt}: episodes with an obstacle contact: any {(lead | fol).float().mean():.2f}, "
          f"leader {lead.float().mean():.2f}, a follower {fol.float().mean():.2f}, "
          f"followers only {(fol & ~lead).float().mean():.2f}; follower contact steps with the leader in the area "
          f"{(fol_steps & area).sum() / fol_steps.sum().clamp(min=1):.2f}; "
          f"per robot {[round(x, 2) for x in hit.any(1).float().mean(0).tolist()]}")

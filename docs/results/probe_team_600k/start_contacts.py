"""Who touches the leader in steps 1-5, by where each follower started relative to it (200 validation episodes,
the draw `make diagnose` uses).

`python docs/results/probe_team_600k/start_contacts.py RUN/checkpoints/policy.pt`
"""

import sys

import torch

from formation_rl import load_policy
from formation_rl.evaluation.evaluate import evaluate_policy

policy = load_policy(sys.argv[1])
cfg = policy.env_config


def start_contacts(rollout, goal_radius):
    p0, goal = rollout["state", "positions"][:, 0], rollout["state", "goal"][:, 0]  # [B, N, 2], [B, 2]
    pos = rollout["next", "state", "positions"][:, :5]  # steps 1-5
    n = pos.shape[-2]
    dist = (pos[:, :, :, None] - pos[:, :, None]).norm(dim=-1) + torch.eye(n) * 9
    hit = dist < 2 * cfg.robot_radius + cfg.robot_collision_margin  # the world's robot contact
    heading = (goal - p0[:, 0]) / (goal - p0[:, 0]).norm(dim=-1, keepdim=True)
    rel = p0[:, 1:] - p0[:, :1]  # the followers' start offsets from the leader
    close, ahead = rel.norm(dim=-1) < 0.5, (rel * heading[:, None]).sum(-1) > 0
    rammed = hit[:, :, 0, 1:].any(1)  # [B, N-1]: follower i touched the leader in steps 1-5
    return {"ahead": (close & ahead).sum(1), "ahead_rammed": (close & ahead & rammed).sum(1),
            "behind": (close & ~ahead).sum(1), "behind_rammed": (close & ~ahead & rammed).sum(1),
            "follower_pair": hit[:, :, 1:, 1:].any((1, 2, 3)).float()}


out = evaluate_policy(policy, cfg, 200, seed=1000000007, progress=False, metrics=start_contacts)
print(f"followers starting within 0.5 m ahead of the leader: {out['ahead'].sum()}, of them touched by it: "
      f"{out['ahead_rammed'].sum()}; within 0.5 m behind it: {out['behind'].sum()}, "
      f"touched: {out['behind_rammed'].sum()}")
print(f"episodes with a follower-follower contact in steps 1-5: {out['follower_pair'].mean():.1%}")

"""Who touches the leader in steps 1-5, by where each follower started relative to it (200 validation episodes).

`python docs/results/probe_team_600k/start_contacts.py RUN/checkpoints/policy.pt`
"""

import sys

import torch
from torchrl.envs.utils import ExplorationType, set_exploration_type

from formation_rl import load_policy
from formation_rl.envs import FormationEnv

policy = load_policy(sys.argv[1])
cfg = policy.env_config
env = FormationEnv(200, config=cfg, seed=1000000007)
env.set_seed(1000000007)
with torch.no_grad(), set_exploration_type(ExplorationType.DETERMINISTIC):
    start = env.reset()
    p0, goal = start["state", "positions"].clone(), start["state", "goal"]
    rollout = env.rollout(5, policy, break_when_any_done=False, auto_reset=False, tensordict=start)
pos = rollout["next", "state", "positions"]  # [B, 5, N, 2]
dist = (pos[:, :, :, None] - pos[:, :, None]).norm(dim=-1) + torch.eye(cfg.num_robots) * 9
hit = dist < 2 * cfg.robot_radius + cfg.robot_collision_margin  # [B, 5, N, N]
rammed = hit[:, :, 0, 1:].any(1)  # [B, N-1]: follower i touched the leader in steps 1-5
heading = (goal - p0[:, 0]) / (goal - p0[:, 0]).norm(dim=-1, keepdim=True)
rel = p0[:, 1:] - p0[:, :1]  # followers' start offsets from the leader
ahead = (rel * heading[:, None]).sum(-1) > 0
close = rel.norm(dim=-1) < 0.5
print(f"followers starting within 0.5 m ahead of the leader: {(close & ahead).sum()}, of them touched by it: "
      f"{(close & ahead & rammed).sum()}")
behind = close & ~ahead
print(f"followers starting within 0.5 m behind it: {behind.sum()}, touched: {(behind & rammed).sum()}")
print(f"episodes with a follower-follower contact in steps 1-5: {hit[:, :, 1:, 1:].any((1, 2, 3)).float().mean():.1%}")

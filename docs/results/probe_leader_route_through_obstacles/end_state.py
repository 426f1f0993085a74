"""Where the leader is over the episode: its distance to the goal and speed at a few steps (200 validation episodes).

`python docs/results/probe_leader_route_through_obstacles/end_state.py RUN/checkpoints/policy.pt`
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
    rollout = env.rollout(cfg.max_steps, policy, break_when_any_done=False)
dist = rollout["next", "goal_distance"][..., 0]  # [B, T]
speed = rollout["next", "state", "velocities"][:, :, 0].norm(dim=-1)
q = torch.tensor([0.1, 0.5, 0.9])
for t in (60, 90, 110, 130, 149):
    d = ", ".join(f"{v:.2f}" for v in dist[:, t].quantile(q).tolist())
    print(f"step {t + 1}: the leader's goal distance (10/50/90%) {d} m, median speed {speed[:, t].median():.2f} m/s")
arrived = (dist <= cfg.goal_radius).any(1)
first = (dist <= cfg.goal_radius).float().argmax(1)[arrived].float()
print(f"within goal_radius at some step: {arrived.float().mean():.1%}; first such step (median): "
      f"{first.median().item() + 1 if arrived.any() else None}")

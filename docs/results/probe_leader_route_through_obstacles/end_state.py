"""Where the leader is over the episode: its distance to the goal and speed at a few steps (200 validation episodes,
the draw `make diagnose` uses).

`python docs/results/probe_leader_route_through_obstacles/end_state.py RUN/checkpoints/policy.pt`
"""

import sys

import torch

from formation_rl import load_policy
from formation_rl.evaluation.evaluate import evaluate_policy

STEPS = (61, 91, 111, 131, 150)


def end_state(rollout, goal_radius):
    dist = rollout["next", "goal_distance"][..., 0]  # [B, T]
    speed = rollout["next", "state", "velocities"][:, :, 0].norm(dim=-1)
    arrived = dist <= goal_radius
    first = torch.where(arrived.any(1), arrived.float().argmax(1) + 1.0, torch.nan)
    return {"first": first, **{f"d{t}": dist[:, t - 1] for t in STEPS}, **{f"v{t}": speed[:, t - 1] for t in STEPS}}


policy = load_policy(sys.argv[1])
out = evaluate_policy(policy, policy.env_config, 200, seed=1000000007, progress=False, metrics=end_state)
for t in STEPS:
    d = ", ".join(f"{v:.2f}" for v in out[f"d{t}"].quantile(torch.tensor([0.1, 0.5, 0.9])).tolist())
    print(f"step {t}: the leader's goal distance (10/50/90%) {d} m, median speed {out[f'v{t}'].median():.2f} m/s")
first = out["first"][~out["first"].isnan()]
print(f"within goal_radius at some step: {first.numel() / 200:.1%}; first such step (median): "
      f"{first.median().item() if first.numel() else None}")

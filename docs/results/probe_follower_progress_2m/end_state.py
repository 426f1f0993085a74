"""Where the followers are at the last step: their distance to the leader, how many are far (> 1.5 m), how close
those are to an obstacle or a wall (centre within 0.15 m of it), their speed and median position relative to the
leader; 200 validation episodes (seed 1,000,000,007).

    python docs/results/probe_follower_progress_2m/end_state.py CKPT
"""
import sys

import torch

from formation_rl import load_policy
from formation_rl.evaluation.evaluate import evaluate_policy
from formation_rl.training.config import TrainConfig

FAR, NEAR_WALL = 1.5, 0.15  # m

if len(sys.argv) != 2:
    sys.exit("usage: python docs/results/probe_follower_progress_2m/end_state.py CKPT")
torch.set_num_threads(1)
policy = load_policy(sys.argv[1])
cfg = policy.env_config


def last_step(rollout, goal_radius):
    """Per follower at the last step, ``[B, 4]`` each (evaluate_policy's ``metrics``)."""
    p = rollout["next", "state", "positions"][:, -1]  # [B, N, 2]
    centers = rollout["next", "state", "obstacle_centers"][:, -1]  # [B, M, 2]
    radii = rollout["next", "state", "obstacle_radii"][:, -1]  # [B, M]
    return {"offset": p[:, 1:] - p[:, :1],  # [B, 4, 2] from the leader
            "gap": ((p[:, 1:, None] - centers[:, None]).norm(dim=-1) - radii[:, None] - cfg.robot_radius).amin(-1),
            "edge": p[:, 1:].abs().amax(-1),
            "speed": rollout["next", "state", "velocities"][:, -1, 1:].norm(dim=-1)}


end = evaluate_policy(policy, cfg, 200, seed=TrainConfig.eval_seed, progress=False, metrics=last_step)
d = end["offset"].norm(dim=-1)
far = d > FAR
print("follower dist to leader at end: quartiles", d.flatten().quantile(torch.tensor([.25, .5, .75, .9])).tolist())
print(f"share far (>{FAR} m)", far.float().mean().item())
print("far followers: obstacle gap median", end["gap"][far].median().item(),
      "share gap<0.3", (end["gap"][far] < 0.3).float().mean().item(),
      "share at wall", (end["edge"][far] > cfg.arena_half_size - NEAR_WALL).float().mean().item())
print("far followers speed at end", end["speed"][far].median().item())
print("far rel x,y median", end["offset"][far].median(0).values.tolist())

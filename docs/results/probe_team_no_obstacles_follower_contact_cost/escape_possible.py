# Can a follower always escape a leader that flies full force toward its goal from the first step? 2,000 start
# layouts of the default world (seed 5), stepped by the world's own dynamics (walls included); each follower flees
# in the best of 24 fixed directions, other followers ignored.
# python docs/results/probe_team_no_obstacles_follower_contact_cost/escape_possible.py
import math

import torch

from formation_rl.envs import EnvConfig, world

cfg = EnvConfig()
contact = 2 * cfg.robot_radius + cfg.robot_collision_margin  # centre distance below which two robots touch
sc = world.sample_scenarios(2000, cfg, torch.Generator().manual_seed(5), "cpu")
pos, goal = sc["positions"], sc["goal"]  # [B, N, 2], [B, 2]
B, N = pos.shape[:2]


def closest_to_leader(follower_action: torch.Tensor, steps: int = 12) -> torch.Tensor:
    """Each follower's closest centre distance to the leader over ``steps`` steps, ``[B, N-1]``; followers hold
    ``follower_action`` ``[B, N, 2]`` (row 0 ignored), the leader pushes full force toward its goal."""
    p, v = pos.permute(2, 1, 0).clone(), torch.zeros(2, N, B)  # batch-last, as world.integrate takes them
    closest = torch.full((B, N - 1), math.inf)
    for _ in range(steps):
        to_goal = goal - p[:, 0].T  # [B, 2]
        a = follower_action.clone()
        a[:, 0] = to_goal / to_goal.abs().amax(-1, keepdim=True)  # the action box's corner toward the goal
        p, v = world.integrate(p, v, a.permute(2, 1, 0), cfg)
        closest = torch.minimum(closest, (p[:, 1:] - p[:, :1]).norm(dim=0).T)
    return closest


best = torch.zeros(B, N - 1)
for deg in range(0, 360, 15):  # each follower flees in one fixed direction; keep its best
    d = torch.tensor([math.cos(math.radians(deg)), math.sin(math.radians(deg))])
    best = torch.maximum(best, closest_to_leader((d / d.abs().max()).expand(B, N, 2)))
print("episodes with a follower that no fixed escape saves from the leader:",
      (best < contact).any(1).float().mean().item())
still = closest_to_leader(torch.zeros(B, N, 2))
print("episodes where a still follower is rammed:", (still < contact).any(1).float().mean().item())

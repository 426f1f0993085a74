"""How often the straight line from the leader's start to its goal crosses an obstacle's contact zone
(centre distance to the segment < obstacle radius + robot radius + rho_o), on 2,000 validation scenarios.

    python docs/results/probe_leader_route_through_obstacles/straight_line.py
"""

import torch

from formation_rl.envs import EnvConfig, FormationEnv

torch.set_num_threads(1)
cfg = EnvConfig()
state = FormationEnv(2000, config=cfg, seed=1_000_000_007).reset()["state"]
p0, goal = state["positions"][:, 0], state["goal"]
centers, radii = state["obstacle_centers"], state["obstacle_radii"]
d = goal - p0
t = (((centers - p0[:, None]) * d[:, None]).sum(-1) / (d * d).sum(-1, keepdim=True)).clamp(0, 1)
gap = (centers - (p0[:, None] + t[..., None] * d[:, None])).norm(dim=-1) - radii
clear = (gap > cfg.robot_radius + cfg.obstacle_collision_margin).all(-1)
length = d.norm(dim=-1).median()
print(f"the straight line clears every obstacle in {clear.float().mean():.1%} of the scenarios; "
      f"its median length is {length:.2f} m ({length / (cfg.max_speed * cfg.dt):.0f} steps at v_max)")

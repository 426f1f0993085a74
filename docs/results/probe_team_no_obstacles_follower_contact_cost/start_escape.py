# Followers that start in the leader's path: how many it rams in steps 1-6, and what their first action is.
# python docs/results/probe_team_no_obstacles_follower_contact_cost/start_escape.py RUN/checkpoints/policy.pt
# (200 validation scenarios, seed 1,000,000,007, deterministic actors)
import sys

import torch
from torchrl.envs.utils import ExplorationType, set_exploration_type

from formation_rl import load_policy
from formation_rl.envs import FormationEnv

pol = load_policy(sys.argv[1])
cfg = pol.env_config
env = FormationEnv(200, config=cfg, seed=1000000007)
env.set_seed(1000000007)
with torch.no_grad(), set_exploration_type(ExplorationType.DETERMINISTIC):
    ro = env.rollout(6, pol, break_when_any_done=False)
pos = torch.cat([ro["state", "positions"][:, :1], ro["next", "state", "positions"]], 1)  # [B, 7, N, 2]
act = ro["agents", "action"]  # [B, 6, N, 2]
goal = ro["state", "goal"][:, 0]
d = (pos[:, :, 1:] - pos[:, :, :1]).norm(dim=-1)  # follower-leader distance [B, 7, N-1]
contact = 2 * cfg.robot_radius + cfg.robot_collision_margin  # centre distance below which two robots touch
hit = (d[:, 1:] < contact).any(1)  # [B, N-1] rammed by the leader in steps 1-6
dirg = goal - pos[:, 0, 0]
dirg = dirg / dirg.norm(dim=-1, keepdim=True)
rel = pos[:, 0, 1:] - pos[:, 0, :1]  # follower relative to leader at start [B, N-1, 2]
ahead = (rel * dirg[:, None]).sum(-1)  # along the goal direction
side = rel[..., 0] * dirg[:, None, 1] - rel[..., 1] * dirg[:, None, 0]
a1 = act[:, 0, 1:]  # followers' first action
away = (a1 * rel / rel.norm(dim=-1, keepdim=True)).sum(-1)  # component of the first action away from the leader
lat = (a1[..., 0] * dirg[:, None, 1] - a1[..., 1] * dirg[:, None, 0]) * torch.sign(side)  # sideways, off the path
fwd = (a1 * dirg[:, None]).sum(-1)
m = (ahead > 0) & (ahead < 0.5) & (side.abs() < 0.3)
print("followers in the leader's path (ahead < 0.5 m, |side| < 0.3 m):", int(m.sum()), " rammed:", int((hit & m).sum()))
for name, sel in (("rammed", hit & m), ("escaped", ~hit & m)):
    print(f"{name}: first action away from leader {away[sel].mean():.2f}, "
          f"sideways off the path {lat[sel].mean():.2f}, along goal dir {fwd[sel].mean():.2f}")
print("leader first action along goal dir", (act[:, 0, 0] * dirg).sum(-1).mean().item(),
      " |a|", act[:, 0, 0].norm(dim=-1).mean().item())

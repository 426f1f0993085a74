"""Who touches whom in steps 1-5: the share of episodes with a robot contact there, by the kind of pair
(leader-follower, follower-follower) and by the pair's centre distance at the start, for a policy file or the
classical controller (`apf`), on N validation scenarios (seed 1,000,000,007; default 500).

    python docs/results/probe_leader_senses_robots_2m/start_pairs.py POLICY_OR_apf [N]
"""

import sys

import torch

import formation_rl
from formation_rl.envs.config import EnvConfig
from formation_rl.envs.formation_env import FormationEnv
from formation_rl.evaluation.policy import classical_policy

path, n = sys.argv[1], int(sys.argv[2]) if len(sys.argv) > 2 else 500
pol = classical_policy(EnvConfig()) if path == "apf" else formation_rl.load_policy(path)
env = FormationEnv(n, config=pol.env_config, seed=1000000007)
cfg = pol.env_config
robots, contact = cfg.num_robots, 2 * cfg.robot_radius + cfg.robot_collision_margin  # 0.3 m, the SPEC's contact
td = env.reset()
positions = [td["state", "positions"].clone()]
with torch.no_grad():
    for _ in range(10):
        td = env.step(pol(td))["next"]
        positions.append(td["state", "positions"].clone())
pos = torch.stack(positions, 1)  # [B, 11, N, 2]
dist = torch.cdist(pos.flatten(0, 1), pos.flatten(0, 1)).view(n, 11, robots, robots)
i, j = torch.triu_indices(robots, robots, 1)
touched = (dist[:, 1:6, i, j] < contact).any(1)  # [B, pairs]: a contact in steps 1-5
leader_pair = touched[:, i == 0].any(1)
follower_pair = touched[:, i > 0].any(1)
print(path)
def pct(flags: torch.Tensor) -> str:
    return f"{100 * flags.float().mean():.1f}%"


print(f"episodes with a contact in steps 1-5: {pct(touched.any(1))}")
print(f"  leader-follower pair involved: {pct(leader_pair)}, follower-follower: {pct(follower_pair)}, "
      f"only ff: {pct(follower_pair & ~leader_pair)}")
start = dist[:, 0, i, j]
for lo, hi in ((0.3, 0.35), (0.35, 0.45), (0.45, 9.0)):
    band = (start >= lo) & (start < hi)
    print(f"  pairs starting {lo:.2f}-{hi:.2f} m apart: {int(band.sum())}, touching in steps 1-5: {pct(touched[band])}")
speed = (pos[:, 1:4] - pos[:, 0:3]).norm(dim=-1) / cfg.dt  # m/s in steps 1-3
print("  speed steps 1-3 leader", speed[:, :, 0].mean(0).tolist(), "followers", speed[:, :, 1:].mean((0, 2)).tolist())

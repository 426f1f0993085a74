"""Who touches whom while the team assembles: the share of 200 validation episodes (seed 1,000,000,007) with a
leader-follower and with a follower-follower contact (centre distance below 2r + rho_r) in steps 1-6.

    python docs/results/probe_assembly_2m/start_contacts.py CKPT [CKPT ...]     # run dirs, policy files or apf
"""
import sys

import torch

from formation_rl import load_policy
from formation_rl.envs import FormationEnv
from formation_rl.training.config import TrainConfig

EPISODES, STEPS = 200, 6
if len(sys.argv) < 2:
    sys.exit("usage: python docs/results/probe_assembly_2m/start_contacts.py CKPT [CKPT ...]")
torch.set_num_threads(1)
print("| policy | leader-follower contact, steps 1-6 | follower-follower contact, steps 1-6 |\n|---|---|---|")
for ckpt in sys.argv[1:]:
    policy = load_policy(ckpt)
    cfg = policy.env_config
    env = FormationEnv(EPISODES, config=cfg, seed=TrainConfig.eval_seed)
    td = env.reset()
    lead = torch.zeros(EPISODES, dtype=torch.bool)
    follow = torch.zeros(EPISODES, dtype=torch.bool)
    threshold = 2 * cfg.robot_radius + cfg.robot_collision_margin
    with torch.no_grad():
        for _ in range(STEPS):
            td = env.step(policy(td))["next"]
            p = td["state", "positions"]
            d = (p[:, :, None] - p[:, None]).norm(dim=-1) + torch.eye(cfg.num_robots) * 1e3  # no self-contact
            hit = d < threshold
            lead |= hit[:, 0, 1:].any(-1)
            follow |= hit[:, 1:, 1:].flatten(1).any(-1)
    print(f"| {ckpt} | {100 * lead.float().mean():.1f}% | {100 * follow.float().mean():.1f}% |")

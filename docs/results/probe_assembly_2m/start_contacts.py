"""Who touches whom while the team assembles: the share of 200 validation episodes (seed 1,000,000,007) with a
leader-follower and with a follower-follower contact (centre distance below 2r + rho_r) in steps 1-6, and the
followers' mean reward in those steps when no sparse event replaced their guided term (what a contact's R5 stands in for).

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
print("| policy | leader-follower contact, steps 1-6 | follower-follower contact, steps 1-6 | followers' guided "
      "reward, steps 1-6 |\n|---|---|---|---|")
for ckpt in sys.argv[1:]:
    policy = load_policy(ckpt)
    cfg = policy.env_config
    env = FormationEnv(EPISODES, config=cfg, seed=TrainConfig.eval_seed)
    td = env.reset()
    lead = torch.zeros(EPISODES, dtype=torch.bool)
    follow = torch.zeros(EPISODES, dtype=torch.bool)
    threshold = 2 * cfg.robot_radius + cfg.robot_collision_margin
    guided, rw = [], cfg.reward
    # every sum of a follower's sparse terms (R2 or R3, R4, R5), scaled as the reward is
    terms = (rw.formation_open, rw.obstacle_collision, rw.robot_collision)
    events = torch.tensor([sum(t for t, on in zip(terms, mask) if on) * rw.scale
                           for mask in ((1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 0), (1, 0, 1), (0, 1, 1), (1, 1, 1))])
    with torch.no_grad():
        for _ in range(STEPS):
            td = env.step(policy(td))["next"]
            r = td["agents", "reward"].squeeze(-1)[:, 1:]
            sparse = (r[..., None] - events).abs().amin(-1) < 1e-4  # a sum of sparse terms replaced the guided one
            guided.append(r[~sparse])
            p = td["state", "positions"]
            d = (p[:, :, None] - p[:, None]).norm(dim=-1) + torch.eye(cfg.num_robots) * 1e3  # no self-contact
            hit = d < threshold
            lead |= hit[:, 0, 1:].any(-1)
            follow |= hit[:, 1:, 1:].flatten(1).any(-1)
    print(f"| {ckpt} | {100 * lead.float().mean():.1f}% | {100 * follow.float().mean():.1f}% | "
          f"{torch.cat(guided).mean():.2f} |")

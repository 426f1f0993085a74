"""Who falls behind, and when: the leader's and the followers' median speed, the formation error (RFSE's per-step
sum over the constrained pairs) and the followers' mean distance to the leader at chosen steps, on 200 validation
episodes (seed 1,000,000,007), for each policy given (a run directory, a policy file or a pretrained one).

    python docs/results/probe_follower_progress_2m/speed_profile.py CKPT [CKPT ...]
"""
import sys

import torch

from formation_rl import load_policy
from formation_rl.envs.config import EnvConfig
from formation_rl.envs.formation_env import FormationEnv
from formation_rl.evaluation.policy import policy_path

STEPS = (5, 10, 20, 40, 60, 80, 100, 120, 140, 149)
torch.set_num_threads(1)
for ckpt in sys.argv[1:]:
    policy = load_policy(ckpt)
    cfg = EnvConfig.from_dict(torch.load(policy_path(ckpt), weights_only=False)["env"])
    env = FormationEnv(200, config=cfg, seed=1_000_000_007)
    with torch.no_grad():
        ro = env.rollout(cfg.max_steps, policy, break_when_any_done=False)
    pos = ro["next", "state", "positions"]  # [B, T, N, 2]
    speed = ro["next", "state", "velocities"].norm(dim=-1)  # [B, T, N]
    error = ro["next", "formation_error"][..., 0]  # [B, T]
    behind = (pos[:, :, 1:] - pos[:, :, :1]).norm(dim=-1).mean(-1)  # [B, T]
    print(f"\n{ckpt} (RFSE {error.mean():.2f} m)\n| step | " + " | ".join(map(str, STEPS)) + " |")
    print("|---|" + "---|" * len(STEPS))
    rows = (("leader speed (m/s)", speed[..., 0]), ("follower speed (m/s)", speed[..., 1:].flatten(2)),
            ("formation error (m)", error), ("followers' distance to the leader (m)", behind))
    for name, x in rows:
        cells = [f"{x[:, t].median():.2f}" for t in STEPS]
        print(f"| {name} | " + " | ".join(cells) + " |")

"""Who falls behind, and when: the leader's and the followers' median speed, the formation error (RFSE's per-step
sum over the constrained pairs) and the followers' mean distance to the leader at chosen steps, on 200 validation
episodes (seed 1,000,000,007), for each policy given (a run directory, a policy file or a pretrained one).

    python docs/results/probe_follower_progress_2m/speed_profile.py CKPT [CKPT ...]
"""
import sys

import torch

from formation_rl import load_policy
from formation_rl.evaluation.evaluate import evaluate_policy
from formation_rl.training.config import TrainConfig

STEPS = (5, 10, 20, 40, 60, 80, 100, 120, 140, 149)


def per_step(rollout, goal_radius):
    """``[B, T]`` (followers: ``[B, T, 4]``) curves of one round's rollout (evaluate_policy's ``metrics``)."""
    pos = rollout["next", "state", "positions"]  # [B, T, N, 2]
    speed = rollout["next", "state", "velocities"].norm(dim=-1)  # [B, T, N]
    return {"leader speed (m/s)": speed[..., 0],
            "follower speed (m/s)": speed[..., 1:],  # [B, T, 4]: the four followers pooled per step
            "formation error (m)": rollout["next", "formation_error"][..., 0],
            "followers' distance to the leader (m)": (pos[:, :, 1:] - pos[:, :, :1]).norm(dim=-1).mean(-1)}


if len(sys.argv) < 2:
    sys.exit("usage: python docs/results/probe_follower_progress_2m/speed_profile.py CKPT [CKPT ...]")
torch.set_num_threads(1)
for ckpt in sys.argv[1:]:
    policy = load_policy(ckpt)
    curves = evaluate_policy(policy, policy.env_config, 200, seed=TrainConfig.eval_seed, progress=False,
                             metrics=per_step)
    print(f"\n{ckpt} (RFSE {curves['formation error (m)'].mean():.2f} m)")
    print("| step | " + " | ".join(map(str, STEPS)) + " |")
    print("|---|" + "---|" * len(STEPS))
    for name, x in curves.items():
        print(f"| {name} | " + " | ".join(f"{x[:, t].median():.2f}" for t in STEPS) + " |")

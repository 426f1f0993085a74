"""The open-space formation error split into its leader-follower pairs (the followers' lag behind the leader) and its
follower-follower pairs (the followers' own shape), with the followers' mean velocity gap to the leader |v_i - v_lea|,
by phase, on 100 validation episodes (seed 1,000,000,007) for each policy given (a run directory, a policy file,
a pretrained one or `apf`). Always the V's pairs (the formation RFSE counts outside the obstacle area).

    python docs/results/probe_velocity_weight_batch_2m/formation_split.py CKPT [CKPT ...]
"""
import functools
import sys

import torch

from formation_rl import load_policy
from formation_rl.envs import formations
from formation_rl.evaluation.evaluate import evaluate_policy
from formation_rl.training.config import TrainConfig

PHASES = ((0, 10), (10, 50), (50, 90), (90, 120), (120, 150))


def per_episode(rollout, goal_radius, cfg):
    pos = rollout["next", "state", "positions"]  # [B, T, N, 2]
    dist = (pos[:, :, :, None] - pos[:, :, None]).norm(dim=-1)  # [B, T, N, N]
    err = (dist - formations.desired_distances(cfg.formation, cfg.num_robots).float()).abs()
    leader_pairs = err[..., 0, 1:].sum(-1)  # [B, T]
    follower_pairs = torch.triu(err[..., 1:, 1:], 1).sum((-1, -2))
    vel = rollout["next", "state", "velocities"]
    gap = (vel[:, :, 1:] - vel[:, :, :1]).norm(dim=-1).mean(-1)
    out = {}
    for a, b in PHASES:
        out[f"leader-follower pairs (m), steps {a}-{b - 1}"] = leader_pairs[:, a:b].mean(1)
        out[f"follower-follower pairs (m), steps {a}-{b - 1}"] = follower_pairs[:, a:b].mean(1)
        out[f"|v_i - v_lea| (m/s), steps {a}-{b - 1}"] = gap[:, a:b].mean(1)
    return out


if len(sys.argv) < 2:
    sys.exit("usage: python docs/results/probe_velocity_weight_batch_2m/formation_split.py CKPT [CKPT ...]")
torch.set_num_threads(1)
rows = {}
for ckpt in sys.argv[1:]:
    policy = load_policy(ckpt)
    rows[ckpt] = evaluate_policy(policy, policy.env_config, 100, seed=TrainConfig.eval_seed, progress=False,
                                 metrics=functools.partial(per_episode, cfg=policy.env_config))
print("| quantity (100 validation episodes, means) | " + " | ".join(rows) + " |")
print("|---|" + "---|" * len(rows))
for name in next(iter(rows.values())):
    print(f"| {name} | " + " | ".join(f"{v[name].mean().item():.2f}" for v in rows.values()) + " |")

"""Robot contacts in the first 6 steps of 200 validation episodes (seed 1,000,000,007): with the leader or between
followers, and how far apart the pair started.

    python docs/results/probe_obstacle_area_2m/start_pairs.py CKPT [CKPT ...]
"""
import sys

import torch

from formation_rl import load_policy
from formation_rl.evaluation.evaluate import evaluate_policy
from formation_rl.training.config import TrainConfig


def per_step(rollout, goal_radius):
    p0 = rollout["state", "positions"][:, :1]  # [B,1,N,2] initial
    pos = torch.cat([p0, rollout["next", "state", "positions"]], 1)  # [B,T+1,N,2]
    return {"pos": pos}

torch.set_num_threads(1)
for ckpt in sys.argv[1:]:
    policy = load_policy(ckpt)
    out = evaluate_policy(policy, policy.env_config, 200, seed=TrainConfig.eval_seed, progress=False, metrics=per_step)
    pos = out["pos"]  # [B,T+1,N,2]
    B, T1, N, _ = pos.shape
    d = (pos[:, :, :, None] - pos[:, :, None]).norm(dim=-1)  # [B,T+1,N,N]
    iu = torch.triu_indices(N, N, 1)
    dp = d[:, :, iu[0], iu[1]]  # [B,T+1,P]
    cfg = policy.env_config
    contact = dp[:, 1:] < 2 * cfg.robot_radius + cfg.robot_collision_margin  # steps 1..T
    first = torch.where(contact.any(-1).any(-1), contact.any(-1).float().argmax(-1), torch.full((B,), -1))
    early = (first >= 0) & (first < 6)
    print(f"\n{ckpt}: episodes with a contact {(first >= 0).float().mean():.2f}, "
          f"first in steps 1-6 {early.float().mean():.2f}")
    lead = fol = 0
    d0 = []
    for b in torch.nonzero(early).flatten():
        for k in torch.nonzero(contact[b, first[b]]).flatten():  # the pairs in contact at the first contact step
            lead += iu[0][k].item() == 0
            fol += iu[0][k].item() != 0
            d0.append(dp[b, 0, k].item())
    d0 = torch.tensor(d0)
    print(f"  early contact pairs: with leader {lead}, follower-follower {fol}; their start distance median "
          f"{d0.median():.3f}, <0.35: {(d0 < 0.35).float().mean():.2f}, <0.45: {(d0 < 0.45).float().mean():.2f}")
    allp = dp[:, 0].flatten()
    print(f"  all start pairs: <0.35: {(allp < 0.35).float().mean():.2f}, <0.45 {(allp < 0.45).float().mean():.2f}; "
          f"episodes with a pair <0.35: {(dp[:, 0] < 0.35).any(-1).float().mean():.2f}")

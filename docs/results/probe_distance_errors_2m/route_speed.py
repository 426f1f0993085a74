"""Share of steps in the obstacle area and mean speed, followers (F) and leader (L), by phase, on 200 validation
episodes (seed 1,000,000,007) for each policy file given.

    python docs/results/probe_distance_errors_2m/route_speed.py RUN/checkpoints/policy.pt [...]
"""
import sys

import torch

from formation_rl import load_policy
from formation_rl.evaluation.evaluate import evaluate_policy
from formation_rl.training.config import TrainConfig


def per_ep(ro, gr):
    pos = ro["next", "state", "positions"]  # B,T,N,2
    x, y = pos[..., 0], pos[..., 1]
    inarea = ((x.abs() < 3) & (y.abs() < 2)).float()
    spd = ro["next", "state", "velocities"].norm(dim=-1)
    out = {}
    for a, b in ((0, 50), (50, 90), (90, 120), (120, 150)):
        out[f"inarea_f_{a}"] = inarea[:, a:b, 1:].mean((1, 2))
        out[f"inarea_l_{a}"] = inarea[:, a:b, 0].mean(1)
        out[f"spd_f_{a}"] = spd[:, a:b, 1:].mean((1, 2))
        out[f"spd_l_{a}"] = spd[:, a:b, 0].mean(1)
    return out
torch.set_num_threads(1)
for ckpt in sys.argv[1:]:
    pol = load_policy(ckpt)
    c = evaluate_policy(pol, pol.env_config, 200, seed=TrainConfig.eval_seed, progress=False, metrics=per_ep)
    print(ckpt)
    for a in (0, 50, 90, 120):
        print(f"  steps {a}+: followers in area {c[f'inarea_f_{a}'].mean():.2f} leader {c[f'inarea_l_{a}'].mean():.2f}"
              f"  speed F {c[f'spd_f_{a}'].mean():.2f} L {c[f'spd_l_{a}'].mean():.2f}")

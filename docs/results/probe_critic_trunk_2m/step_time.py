"""The PER-MATD3 gradient step (N=5, batch 1024, fp32, one thread) with the recipe's per-robot critics (the leader's
layer-normalised) or a shared trunk: ``python docs/results/probe_critic_trunk_2m/step_time.py MODE [WIDTH]`` at commit
2aacd5c (where SharedTrunkCritic exists), MODE per_robot | followers (leader's own MLP) | all (one trunk for five).
Prints the median ms of ``benchmarks/train_throughput.py``'s ``grad_step`` on random transitions."""

import sys
from pathlib import Path

import torch
from torchrl.modules import ValueOperator

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "benchmarks"))
import train_throughput as tt  # noqa: E402

from formation_rl.models import networks  # noqa: E402

torch.set_num_threads(1)
mode = sys.argv[1]
width = int(sys.argv[2]) if len(sys.argv) > 2 else 128
per_robot = tt.make_critic


def make(n, d, hidden, *args, **kwargs):
    if mode == "per_robot":
        return per_robot(n, d, hidden, layer_norm=(0,))
    own = (0,) if mode == "followers" else ()
    return ValueOperator(networks.SharedTrunkCritic(n, d, 2, (width, width), "relu", own, (0,)),
                         in_keys=[("agents", "observation"), ("agents", "action")],
                         out_keys=[("agents", "state_action_value")])


tt.make_critic = make
r = tt.grad_step("per_matd3", steps=40)
print(mode, width, f"{r['ms']:.1f} ms", {k: round(v, 1) for k, v in r["parts_ms"].items()})

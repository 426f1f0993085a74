"""The levers tried on the gradient step, each against the shipped path in the same process.

    python benchmarks/levers.py [--rounds 4]

Prints the median ms per PER-MATD3 gradient step (N=5, M=4, batch 1024) of the shipped path and
of each alternative, alternating the two `--rounds` times so that drift hits both alike.
"""

from __future__ import annotations

import argparse
import logging
import statistics
import sys
from pathlib import Path
from unittest import mock

import torch
from torch import nn
from torchrl.objectives import TD3Loss

sys.path.insert(0, str(Path(__file__).parent))
import train_throughput as tt  # noqa: E402

import formation_rl.algorithms.base as base  # noqa: E402
import formation_rl.algorithms.matd3 as matd3  # noqa: E402
import formation_rl.models.networks as networks  # noqa: E402


class _LoopTD3Loss(TD3Loss):
    def __init__(self, *args, **kwargs):
        super().__init__(*args, deactivate_vmap=True, **kwargs)


def _torchrl_actor_loss(self, batch):
    return self.loss.actor_loss(batch.exclude(base.WEIGHT_KEY, base.PRIORITY_KEY))[0].mean(), {}


class _FusedAdam(torch.optim.Adam):
    def __init__(self, params, **kwargs):
        super().__init__(params, fused=True, **kwargs)


def _inplace_relu(inplace=False):
    return nn.ReLU(inplace=True)


LEVERS = {
    # label: (where it is patched, the attribute or key, the alternative)
    "TorchRL's actor_loss (both twins evaluated) instead of Q1 only": (base.Algorithm, "_actor_loss",
                                                                     _torchrl_actor_loss),
    "twin critics in a Python loop (deactivate_vmap) instead of vmap": (matd3, "TD3Loss", _LoopTD3Loss),
    "fused Adam instead of foreach Adam": (base.torch.optim, "Adam", _FusedAdam),
    "in-place ReLU": (networks.ACTIVATIONS, "relu", _inplace_relu),
}


def _patched(target, name, value):
    if isinstance(target, dict):
        return mock.patch.dict(target, {name: value})
    return mock.patch.object(target, name, value)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=4)
    args = parser.parse_args()
    logging.getLogger("torchrl").setLevel(logging.WARNING)
    print(f"# levers, PER-MATD3 gradient step, torch {torch.__version__}, {torch.get_num_threads()} threads\n")
    print("| alternative | shipped ms | alternative ms | alternative / shipped |")
    print("|---|---:|---:|---:|")
    for label, (target, name, value) in LEVERS.items():
        shipped, alt = [], []
        for _ in range(args.rounds):
            shipped.append(tt.grad_step("per_matd3", steps=15)["ms"])
            with _patched(target, name, value):
                alt.append(tt.grad_step("per_matd3", steps=15)["ms"])
        s, a = statistics.median(shipped), statistics.median(alt)
        print(f"| {label} | {s:.1f} | {a:.1f} | {a / s:.2f} |", flush=True)


if __name__ == "__main__":
    main()

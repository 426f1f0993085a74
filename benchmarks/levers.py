"""The levers tried on the gradient step, each against the shipped path in the same process.

    python benchmarks/levers.py [--rounds 4] [--threads 1] [--precision fp32|bf16|bf16_targets] [--precision-only]
                                [--critic-layer-norm none|leader] [--only TEXT]

Prints the median ms per PER-MATD3 gradient step (N=5, M=4, batch 1024) of the shipped path and
of each alternative at `--precision` (default fp32; levers of the hand-written layers act in the bf16
paths only), alternating the two `--rounds` times so that drift hits both alike; then the
step in fp32 and bf16, with the hand-written ReLU layers (shipped) and with autograd + autocast
(before), all four alternated, each against the fp32 step before. Besides wall time it reports
the process's CPU time per step, which a machine shared with other jobs inflates less (with one
thread it is the step's own compute time).
"""

from __future__ import annotations

import argparse
import functools
import logging
import random
import statistics
import sys
import time
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


class _ForeachAdam(torch.optim.Adam):
    def __init__(self, params, **kwargs):
        super().__init__(params, **{**kwargs, "fused": False, "foreach": True})


def _strided_group_major(h, groups, width):
    return h.view(-1, groups, width).transpose(0, 1)


def _stacked_norm(self, h):
    """PerRobotMLP.norm before 2026-12-07: each robot's row selected and the rows stacked (the backward filled a
    zero tensor per row)."""
    if not self.layer_norm:
        return h
    return torch.stack([nn.functional.layer_norm(h[i], h.shape[-1:]) if i in self.layer_norm else h[i]
                        for i in range(self.num_robots)])


class _AutogradReLU(nn.ReLU):
    """A ReLU that is not ``nn.ReLU`` itself: the networks fall back to autograd + autocast layers."""


LAYER_NORM_LEVER = "the leader's layer-normalised rows stacked one by one (before; --critic-layer-norm leader)"
LEVERS = {
    # label: (where it is patched, the attribute or key, the alternative)
    "TorchRL's actor_loss (both twins evaluated) instead of Q1 only": (base.Algorithm, "_actor_loss",
                                                                     _torchrl_actor_loss),
    "twin critics in a Python loop (deactivate_vmap) instead of vmap": (matd3, "TD3Loss", _LoopTD3Loss),
    "foreach Adam instead of fused Adam (shipped since 2026-12-03)": (base.torch.optim, "Adam", _ForeachAdam),
    "autograd + autocast layers instead of the hand-written ReLU layers": (networks.ACTIVATIONS, "relu",
                                                                          _AutogradReLU),
    "the joint layer's output left strided (hand-written layers; bf16 paths)": (networks, "_group_major",
                                                                                _strided_group_major),
    LAYER_NORM_LEVER: (networks.PerRobotMLP, "norm", _stacked_norm),
}
PRECISION_VARIANTS = {  # label: (precision, patched to the autograd layers)
    "fp32, autograd layers (before)": ("fp32", True),
    "fp32, hand-written layers": ("fp32", False),
    "bf16, autograd layers + autocast (before)": ("bf16", True),
    "bf16, hand-written layers": ("bf16", False),
    "bf16_targets: bf16, hand-written layers, target passes in bf16 too": ("bf16_targets", False),
}


def _patched(target, name, value):
    if isinstance(target, dict):
        return mock.patch.dict(target, {name: value})
    return mock.patch.object(target, name, value)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=4)
    parser.add_argument("--threads", type=int, default=None, help="torch intra-op threads (default: torch's)")
    parser.add_argument("--precision", default="fp32", choices=["fp32", "bf16", "bf16_targets"],
                        help="the precision the levers are tried in")
    parser.add_argument("--precision-only", action="store_true", help="only the fp32 / bf16 comparison")
    parser.add_argument("--critic-layer-norm", default="none", choices=["none", "leader"],
                        help="the critics of both arms: leader = recipe=hindsight's (model.critic_layer_norm=leader)")
    parser.add_argument("--only", default="", help="only the levers whose label has this text (no precision table)")
    args = parser.parse_args()
    if args.critic_layer_norm == "leader":
        tt.make_critic = functools.partial(networks.make_critic, layer_norm=(0,))
    if args.threads:
        torch.set_num_threads(args.threads)
    logging.getLogger("torchrl").setLevel(logging.WARNING)
    print(f"# levers, PER-MATD3 gradient step, precision={args.precision}, torch {torch.__version__}, "
          f"{torch.get_num_threads()} threads\n")
    if not args.precision_only:
        print("| alternative | shipped ms | alternative ms | alternative / shipped | CPU ms shipped | CPU ms alt. | "
              "CPU alt. / shipped |")
        print("|---|---:|---:|---:|---:|---:|---:|")
        for label, (target, name, value) in LEVERS.items():
            if (label == LAYER_NORM_LEVER and args.critic_layer_norm == "none") or args.only not in label:
                continue  # (the layer-norm lever: no layer norm in either arm without the flag)
            shipped, alt = [], []
            for _ in range(args.rounds):
                shipped.append(tt.grad_step("per_matd3", steps=15, precision=args.precision))
                with _patched(target, name, value):
                    alt.append(tt.grad_step("per_matd3", steps=15, precision=args.precision))
            (s, sc), (a, ac) = _medians(shipped), _medians(alt)
            print(f"| {label} | {s:.1f} | {a:.1f} | {a / s:.2f} | {sc:.1f} | {ac:.1f} | {ac / sc:.2f} |", flush=True)
        print()
    if not args.only:
        precision_table(args.rounds)


def _medians(runs: list[dict]) -> tuple[float, float]:
    return statistics.median(r["ms"] for r in runs), statistics.median(r["cpu_ms"] for r in runs)


def _stepper(precision: str, before: bool):
    """One PER-MATD3 gradient step (sample, update, priority write-back) on a filled buffer, as a closure."""
    from dataclasses import replace

    from formation_rl.algorithms import make_algorithm
    from formation_rl.training.replay import make_replay_buffer

    cfg = tt.make_config("per_matd3")
    a, n, d = cfg.algo, cfg.env.num_robots, cfg.env.obs_dim
    torch.manual_seed(0)
    with _patched(networks.ACTIVATIONS, "relu", _AutogradReLU if before else nn.ReLU):
        actor, critic = networks.make_actor(n, d, cfg.model.hidden), networks.make_critic(n, d, cfg.model.hidden)
    networks.set_precision(actor, precision)
    networks.set_precision(critic, precision)
    for m in (*actor.modules(), *critic.modules()):
        if isinstance(m, networks.PerRobotMLP) and not before:
            m.hand_written = True  # in fp32 too (shipped: under bf16 only)
    algo = make_algorithm(actor, critic, a)
    buffer = make_replay_buffer(replace(a, buffer_size=50_000))
    buffer.extend(tt.random_transitions(50_000, n, d))

    def step():
        batch = buffer.sample()
        algo.update(batch)
        buffer.update_tensordict_priority(batch)

    return step


def precision_table(rounds: int) -> dict[str, tuple[float, float]]:
    """The step in fp32 and bf16, hand-written layers and autograd ones: all four built once, then
    ``8 * rounds`` rounds in a shuffled order, each timing 3 blocks of 2 steps (one with the actor
    step) after 2 untimed ones; medians of the blocks."""
    steppers = {k: _stepper(*v) for k, v in PRECISION_VARIANTS.items()}
    wall: dict[str, list[float]] = {k: [] for k in steppers}
    cpu: dict[str, list[float]] = {k: [] for k in steppers}
    rng = random.Random(0)
    for _ in range(8 * rounds):
        for label in rng.sample(list(steppers), len(steppers)):
            step = steppers[label]
            step(), step()
            for _ in range(3):
                t, c = time.perf_counter(), time.process_time()
                step(), step()
                wall[label].append((time.perf_counter() - t) * 1e3 / 2)
                cpu[label].append((time.process_time() - c) * 1e3 / 2)
    med = {k: (statistics.median(wall[k]), statistics.median(cpu[k])) for k in steppers}
    base, base_cpu = med["fp32, autograd layers (before)"]
    print("| PER-MATD3 step | ms | / fp32 before | CPU ms | CPU / fp32 before |")
    print("|---|---:|---:|---:|---:|")
    for label, (ms, c) in med.items():
        print(f"| {label} | {ms:.1f} | {ms / base:.2f} | {c:.1f} | {c / base_cpu:.2f} |", flush=True)
    return med


if __name__ == "__main__":
    main()

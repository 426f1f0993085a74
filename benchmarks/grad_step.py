"""Milliseconds per gradient step of each algorithm at the SPEC defaults (N=5, M=4, batch 1024).

    python benchmarks/grad_step.py [--steps 30]

One step = what the trainer does per `update_every` frames: sample a batch from a filled replay
buffer (prioritized for PER-MATD3), critic step, actor step every `policy_delay` critic steps, soft
target update, priority write-back. Median of `--steps` timed steps after 5 warm-up steps.
"""

from __future__ import annotations

import argparse
import statistics
import time

import torch

from formation_rl.algorithms import make_algorithm
from formation_rl.config import TrainConfig
from formation_rl.models import make_actor, make_critic
from formation_rl.replay import make_replay_buffer
from formation_rl.trainer import Trainer  # noqa: F401  (import cost outside the timing)

PRESETS = {
    "maddpg": dict(num_critics=1, policy_noise=0.0, noise_clip=0.0, policy_delay=1, prioritized=False),
    "matd3": dict(prioritized=False),
    "per_matd3": dict(),
}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=30)
    args = parser.parse_args()
    print(f"# gradient step, N=5, M=4, batch 1024, torch {torch.__version__}, {torch.get_num_threads()} threads")
    print("| algorithm | ms / step | gradient steps/s | frames/s at update_every=100 (updates only) |")
    print("|---|---:|---:|---:|")
    for name, preset in PRESETS.items():
        cfg = TrainConfig()
        cfg.algo.name = name
        for k, v in preset.items():
            setattr(cfg.algo, k, v)
        cfg.algo.buffer_size = 20_000
        n, d = cfg.env.num_robots, cfg.env.obs_dim
        algo = make_algorithm(make_actor(n, d), make_critic(n, d), cfg.algo)
        buffer = make_replay_buffer(cfg.algo)
        data = _random_transitions(20_000, n, d)
        buffer.extend(data)

        for _ in range(5):
            _step(algo, buffer, cfg.algo.prioritized)
        times = []
        for _ in range(args.steps):
            t = time.perf_counter()
            _step(algo, buffer, cfg.algo.prioritized)
            times.append(time.perf_counter() - t)
        ms = statistics.median(times) * 1e3
        print(f"| {name} | {ms:.1f} | {1e3 / ms:.1f} | {100 * 1e3 / ms:,.0f} |", flush=True)


def _step(algo, buffer, prioritized: bool) -> None:
    batch = buffer.sample()
    algo.update(batch)
    if prioritized:
        buffer.update_tensordict_priority(batch)


def _random_transitions(size: int, n: int, d: int):
    from tensordict import TensorDict

    done = torch.zeros(size, n, 1, dtype=torch.bool)
    return TensorDict(
        {
            ("agents", "observation"): torch.randn(size, n, d),
            ("agents", "action"): torch.rand(size, n, 2) * 2 - 1,
            ("next", "agents", "observation"): torch.randn(size, n, d),
            ("next", "agents", "reward"): torch.randn(size, n, 1),
            ("next", "agents", "done"): done,
            ("next", "agents", "terminated"): done.clone(),
        },
        [size],
    )


if __name__ == "__main__":
    main()

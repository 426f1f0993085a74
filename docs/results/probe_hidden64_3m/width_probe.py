"""The PER-MATD3 gradient step at several hidden widths, batches and precisions, alternated in one process.

PREC=bf16_targets WIDTHS=64,96,128 BATCHES=1024 .venv/bin/python docs/results/probe_hidden64_3m/width_probe.py 2
(the last argument: torch threads). Prints the median CPU and wall milliseconds per step of 4 rounds of 10 steps.
"""
import os
import sys
import time
from dataclasses import replace
from pathlib import Path

import torch

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "benchmarks"))
import train_throughput as tt  # noqa: E402

from formation_rl.algorithms import make_algorithm  # noqa: E402
from formation_rl.models.networks import make_actor, make_critic, set_precision  # noqa: E402
from formation_rl.training.replay import make_replay_buffer  # noqa: E402


def stepper(hidden: tuple[int, ...], precision: str, batch: int):
    """One PER-MATD3 gradient step (sample, update, priority write-back) on a filled buffer, as a closure."""
    cfg = tt.make_config("per_matd3")
    a, n, d = replace(cfg.algo, batch_size=batch), cfg.env.num_robots, cfg.env.obs_dim
    torch.manual_seed(0)
    actor, critic = make_actor(n, d, hidden), make_critic(n, d, hidden)
    set_precision(actor, precision)
    set_precision(critic, precision)
    algo = make_algorithm(actor, critic, a)
    buffer = make_replay_buffer(replace(a, buffer_size=50_000))
    buffer.extend(tt.random_transitions(50_000, n, d))

    def step() -> None:
        batch = buffer.sample()
        algo.update(batch)
        buffer.update_tensordict_priority(batch)

    return step


def main() -> None:
    torch.set_num_threads(int(sys.argv[1]) if len(sys.argv) > 1 else 1)
    precisions = os.environ.get("PREC", "bf16_targets,fp32").split(",")
    widths = [int(x) for x in os.environ.get("WIDTHS", "64,128").split(",")]
    batches = [int(x) for x in os.environ.get("BATCHES", "512,1024").split(",")]
    variants = {f"{p} h{h} b{b}": stepper((h, h), p, b) for p in precisions for h in widths for b in batches}
    results: dict[str, list[tuple[float, float]]] = {k: [] for k in variants}
    for _ in range(4):  # rounds, the variants alternated within each
        for name, step in variants.items():
            for _ in range(3):
                step()
            c0, t0 = time.process_time(), time.perf_counter()
            for _ in range(10):
                step()
            results[name].append((100 * (time.process_time() - c0), 100 * (time.perf_counter() - t0)))
    for name, runs in results.items():
        cpu, wall = sorted(c for c, _ in runs), sorted(w for _, w in runs)
        print(f"{name:28s} cpu ms {cpu[len(cpu) // 2]:6.1f}  wall ms {wall[len(wall) // 2]:6.1f}")


if __name__ == "__main__":
    main()

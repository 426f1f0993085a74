"""Environment throughput: frames/s (one frame = one copy stepping once) with random actions.

    python benchmarks/env_throughput.py [--batch 1 64 1024 4096] [--steps 300] [--json out.json]

Three paths per batch size B, all in this process:
- ``step``: ``env.step_and_maybe_reset`` in a loop (what a TorchRL collector does per step);
- ``rollout``: ``env.rollout(T, break_when_any_done=False)``, which also stacks the T steps;
- ``compiled``: the ``step`` loop with ``FormationEnv(..., compile_physics=True)`` (``torch.compile``);
- ``vmas``: the same ``step`` loop on VMAS's ``navigation`` scenario through TorchRL's ``VmasEnv``
  (only where ``vmas`` is installed: ``pip install vmas``), the baseline the ratio column uses.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import time

import torch

from formation_rl.envs import FormationEnv

REPEATS = 5  # the median of this many timed blocks: this machine's timings vary run to run


def _median_rate(frames_per_block: int, block, repeats: int = REPEATS) -> float:
    block()  # warm-up
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        block()
        times.append(time.perf_counter() - start)
    return frames_per_block / statistics.median(times)


def step_loop(env, steps: int) -> float:
    """Frames/s of random-action steps with auto-reset (``env.step_and_maybe_reset``)."""
    state = {"td": env.reset()}

    def block():
        td = state["td"]
        for _ in range(steps):
            td = env.rand_action(td)
            _, td = env.step_and_maybe_reset(td)
        state["td"] = td

    return _median_rate(env.batch_size.numel() * steps, block)


def rollout(env, steps: int) -> float:
    """Frames/s of ``env.rollout`` (steps and stacks the trajectory)."""
    return _median_rate(env.batch_size.numel() * steps, lambda: env.rollout(steps, break_when_any_done=False))


def vmas_env(batch: int):
    try:
        from torchrl.envs.libs.vmas import VmasEnv
    except ImportError:
        return None
    try:
        return VmasEnv("navigation", num_envs=batch, n_agents=5, continuous_actions=True, device="cpu", seed=0)
    except Exception:  # vmas not installed
        return None


def _fmt(x: float | None) -> str:
    return f"{x:,.0f}" if x else "n/a"


def _ratio(x: float | None, base: float | None) -> str:
    return f"{x / base:.1f}x" if x and base else "n/a"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--batch", type=int, nargs="+", default=[1, 64, 1024, 4096])
    parser.add_argument("--steps", type=int, default=100, help="steps per timed block (B <= 64: 4x)")
    parser.add_argument("--threads", type=int, default=torch.get_num_threads())
    parser.add_argument("--json", default=None, help="also write the results here")
    parser.add_argument("--no-compile", dest="compile", action="store_false", help="skip the compiled column")
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    print(f"# env throughput, N=5 robots, M=4 obstacles, {platform.machine()}, {os.cpu_count()} cores, "
          f"torch {torch.__version__}, {torch.get_num_threads()} threads; median of {REPEATS} blocks")
    print("| B | step frames/s | rollout frames/s | compiled step frames/s | VMAS navigation step frames/s "
          "| step / VMAS | compiled / VMAS |")
    print("|---:|---:|---:|---:|---:|---:|---:|")
    rows = []
    for b in args.batch:
        steps = args.steps * (4 if b <= 64 else 1)
        env = FormationEnv(b, seed=0)
        row = {"B": b, "step": step_loop(env, steps), "rollout": rollout(env, steps)}
        row["compiled"] = step_loop(FormationEnv(b, seed=0, compile_physics=True), steps) if args.compile else None
        venv = vmas_env(b)
        row["vmas"] = step_loop(venv, max(steps // 4, 10)) if venv is not None else None

        print(f"| {b} | {_fmt(row['step'])} | {_fmt(row['rollout'])} | {_fmt(row['compiled'])} | {_fmt(row['vmas'])} "
              f"| {_ratio(row['step'], row['vmas'])} | {_ratio(row['compiled'], row['vmas'])} |", flush=True)
        rows.append(row)
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"torch": torch.__version__, "threads": torch.get_num_threads(), "rows": rows}, f, indent=2)


if __name__ == "__main__":
    main()

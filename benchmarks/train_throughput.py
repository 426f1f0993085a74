"""Training throughput: the gradient step against the machine's matmul rate, end to end at the paper's ratio.

    python benchmarks/train_throughput.py [--json benchmarks/train_throughput.json] [--quick] [--profile]
    make bench

Everything is measured in one process, so the ratios hold even where this machine's absolute
speed drifts from run to run:

1. the fp32 matmul rate (GFLOP/s, the best of 1024^2 and 2048^2 square products): the reference;
2. the PER-MATD3 gradient step (below) in fp32, bf16 and bf16_targets (``precision=...``), alternated,
   each beside the square-matmul rate of its own precision and the lowest ratio to fp32 those rates
   allow (bf16 only where the CPU multiplies it natively);
3. per algorithm at the defaults (N=5, M=4, batch 1024): milliseconds per gradient step
   (replay sampling, critic step, actor step every ``policy_delay``, soft update, priority
   write-back), the step's GEMM FLOPs counted from the layer sizes (:func:`step_flops`),
   achieved GFLOP/s and its ratio to the matmul rate;
4. per algorithm, a real :class:`~formation_rl.training.trainer.Trainer` run at the paper's update ratio
   (one gradient step per 100 frames, 64 env copies): frames/s and the split of its wall time
   into env stepping, policy inference, buffer extend/sample, priority update, the update
   (losses, backward, optimisers, soft update), metrics and logging (evaluation excluded, reported
   apart); and the projected wall time of the paper's 9M-frame budget;
5. scaling in N (robots: 3, 5, 9, 17) and in B (env copies: 1, 64, 1024, 4096), PER-MATD3.

``--batch-sweep`` measures only the PER-MATD3 gradient step at replay batches 128 ... 2048 (gradient
steps/s and samples/s, against batch 1024 in the same process): what a smaller batch buys per second.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import platform
import statistics
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import torch
from omegaconf import OmegaConf
from tensordict import TensorDict

from formation_rl.algorithms import make_algorithm
from formation_rl.models import bf16_supported, make_actor, make_critic, set_precision
from formation_rl.training.config import TrainConfig
from formation_rl.training.replay import make_replay_buffer
from formation_rl.training.trainer import Trainer

ALGOS = ("maddpg", "matd3", "per_matd3")
CONF = Path(__file__).resolve().parents[1] / "formation_rl" / "conf"
PAPER_FRAMES, PAPER_RATIO = 9_000_000, 100


# ---------------------------------------------------------------------------------------- FLOPs
def _macs(sizes: list[int]) -> tuple[int, int]:
    """Multiply-adds per sample of an MLP with these layer sizes: (all layers, layers above the first)."""
    pairs = list(zip(sizes[:-1], sizes[1:], strict=True))
    return sum(a * b for a, b in pairs), sum(a * b for a, b in pairs[1:])


def step_flops(n: int, obs_dim: int, hidden: list[int], batch: int, critics: int, delay: int) -> float:
    """GEMM FLOPs of one gradient step (2 per multiply-add; elementwise work not counted).

    Critic step: target actors forward, target critics forward, critics forward, and the critics'
    backward (weight gradients of every layer, input gradients of every layer but the first).
    Actor step, every ``delay`` critic steps: actors forward, critic 1 forward, its backward to
    the actions (input gradients), the actors' backward (weights; inputs above the first layer).
    """
    actor, actor_upper = _macs([obs_dim, *hidden, 2])
    critic, critic_upper = _macs([n * (obs_dim + 2), *hidden, 1])
    per_sample_critic_step = n * (actor + critics * critic * 3 + critics * critic_upper)
    per_sample_actor_step = n * (actor + critic + critic_upper + actor + actor_upper)
    return 2.0 * batch * (per_sample_critic_step + per_sample_actor_step / delay)


def target_share(n: int, obs_dim: int, hidden: list[int], critics: int, delay: int) -> float:
    """Share of a step's GEMM FLOPs in the target passes (target actors and critics forward, no gradient),
    which ``precision=bf16`` keeps in fp32 by design (the TD target in fp32)."""
    target = 2.0 * n * (_macs([obs_dim, *hidden, 2])[0] + critics * _macs([n * (obs_dim + 2), *hidden, 1])[0])
    return target / step_flops(n, obs_dim, hidden, 1, critics, delay)


def bf16_floor(share_fp32: float, fp32_rate: float, bf16_rate: float) -> float:
    """The lowest bf16 / fp32 step ratio possible with ``share_fp32`` of the GEMM FLOPs in fp32: every GEMM
    at its precision's square-matmul rate and nothing else in the step (no elementwise work, no overhead)."""
    return share_fp32 + (1.0 - share_fp32) * fp32_rate / bf16_rate


def joint_layer_share(n: int, obs_dim: int, h1: int, critics: int, delay: int) -> float:
    """Share of a step's FLOPs in the critics' first layer, the one over the joint input of all robots.

    Its width is N(D+2) with D = 4 + 2(N-1) + 3M + 1, and there are N critics: O(N^3) per sample,
    the pairwise term of centralized training; every other layer costs O(N) per sample.
    """
    first = n * (obs_dim + 2) * h1 * n  # MACs per sample, N critics
    per_sample = critics * first * 3 + first / delay  # 3 passes in the critic step (target, forward, dW)
    return 2.0 * per_sample / step_flops(n, obs_dim, [h1, 128], 1, critics, delay)


# ---------------------------------------------------------------------------------------- timing
def matmul_rate(repeats: int = 10, dtype: torch.dtype = torch.float32) -> float:
    """GFLOP/s of a plain square matmul in ``dtype``, the best of sizes 1024 and 2048 (median of ``repeats``)."""
    best = 0.0
    for size in (1024, 2048):
        a, b = torch.randn(size, size, dtype=dtype), torch.randn(size, size, dtype=dtype)
        for _ in range(3):
            a @ b
        times = []
        for _ in range(repeats):
            t = time.perf_counter()
            a @ b
            times.append(time.perf_counter() - t)
        best = max(best, 2 * size**3 / statistics.median(times) / 1e9)
    return best


def make_config(algo: str, **top) -> TrainConfig:
    cfg = TrainConfig()
    cfg.algo = replace(cfg.algo, **OmegaConf.to_container(OmegaConf.load(CONF / "algo" / f"{algo}.yaml")))
    for k, v in top.items():
        if k == "num_robots":
            # 17 robots do not fit the default 1 m start square at the default spacing: a 1.6 m one
            cfg.env = replace(cfg.env, num_robots=v, start_high=-2.2 if v > 9 else cfg.env.start_high)
        else:
            setattr(cfg, k, v)
    return cfg


def grad_step(algo_name: str, n: int = 5, steps: int = 30, batch: int | None = None, precision: str = "fp32") -> dict:
    """Median milliseconds per gradient step on a filled buffer of random transitions, and its parts."""
    cfg = make_config(algo_name, num_robots=n)
    a, d = cfg.algo, cfg.env.obs_dim
    if batch is not None:
        a = replace(a, batch_size=batch)
    torch.manual_seed(0)
    actor, critic = make_actor(n, d, cfg.model.hidden), make_critic(n, d, cfg.model.hidden)
    set_precision(actor, precision)
    set_precision(critic, precision)
    algo = make_algorithm(actor, critic, replace(a))
    buffer = make_replay_buffer(replace(a, buffer_size=50_000))
    buffer.extend(random_transitions(50_000, n, d))
    parts: dict[str, list[float]] = {"total": [], "sample": [], "update": [], "priority": []}
    cpu: list[float] = []
    for i in range(steps + 5):
        c0 = time.process_time()
        t0 = time.perf_counter()
        batch = buffer.sample()
        t1 = time.perf_counter()
        algo.update(batch)
        t2 = time.perf_counter()
        if a.prioritized:
            buffer.update_tensordict_priority(batch)
        t3 = time.perf_counter()
        cpu.append(time.process_time() - c0)
        if i >= 5:  # warm-up steps excluded
            for k, v in (("total", t3 - t0), ("sample", t1 - t0), ("update", t2 - t1), ("priority", t3 - t2)):
                parts[k].append(v)
    flops = step_flops(n, d, list(cfg.model.hidden), a.batch_size, a.num_critics, a.policy_delay)
    # medians over windows of policy_delay steps (one of them with the actor step): the median of single
    # steps would pick either kind of step, whichever half it falls in
    ms = {k: 1e3 * _window_median(v, a.policy_delay) for k, v in parts.items()}
    # cpu_ms: the process's CPU time per step, which other jobs on the machine inflate less than wall time
    return {"ms": ms["total"], "parts_ms": ms, "gflop": flops / 1e9, "gflops": flops / ms["total"] / 1e6,
            "cpu_ms": 1e3 * _window_median(cpu[5:], a.policy_delay), "precision": precision}


def _window_median(values: list[float], window: int) -> float:
    """Median of the means of consecutive ``window``-long runs of ``values``."""
    means = [sum(values[i : i + window]) / window for i in range(0, len(values) - window + 1, window)]
    return statistics.median(means)


def random_transitions(size: int, n: int, d: int) -> TensorDict:
    done = torch.zeros(size, n, 1, dtype=torch.bool)
    return TensorDict({
        ("agents", "observation"): torch.randn(size, n, d),
        ("agents", "action"): torch.rand(size, n, 2) * 2 - 1,
        ("next", "agents", "observation"): torch.randn(size, n, d),
        ("next", "agents", "reward"): torch.randn(size, n, 1),
        ("next", "agents", "done"): done,
        ("next", "agents", "terminated"): done.clone(),
    }, [size])


def end_to_end(algo_name: str, frames: int, n: int = 5, num_envs: int = 64, steps_per_batch: int = 25,
               precision: str = "fp32") -> dict:
    """A real training run at one gradient step per 100 frames: frames/s and where the time went."""
    cfg = make_config(algo_name, num_robots=n, num_envs=num_envs, steps_per_batch=steps_per_batch,
                      total_frames=frames, eval_interval=10**12, checkpoint_interval=10**12, eval_episodes=10,
                      progress=False, precision=precision)
    cfg.algo = replace(cfg.algo, update_every=PAPER_RATIO, warmup_frames=cfg.algo.batch_size,
                       buffer_size=max(frames, cfg.algo.batch_size))
    with tempfile.TemporaryDirectory() as run_dir:
        trainer = Trainer(cfg, run_dir)
        start = time.perf_counter()
        trainer.train()
        wall = time.perf_counter() - start
    sec = dict(trainer.timings.seconds)
    # one-off costs, set aside: the frame-0 and final evaluations, the checkpoint, building the collector
    aside = sec.pop("evaluation", 0.0) + sec.pop("checkpoint", 0.0) + sec.pop("setup", 0.0)
    loop = wall - aside
    split = {k: v / loop for k, v in sec.items()}
    split["other"] = max(0.0, 1 - sum(split.values()))
    return {"frames": trainer.frames, "grad_steps": trainer.algo.critic_steps, "seconds": loop,
            "fps": trainer.frames / loop, "split": split}


def profile_step(steps: int = 10) -> None:
    """Where a PER-MATD3 gradient step's time goes, operator by operator (self CPU time)."""
    from torch.profiler import ProfilerActivity, profile

    cfg = make_config("per_matd3")
    a, n, d = cfg.algo, cfg.env.num_robots, cfg.env.obs_dim
    algo = make_algorithm(make_actor(n, d), make_critic(n, d), a)
    buffer = make_replay_buffer(replace(a, buffer_size=50_000))
    buffer.extend(random_transitions(50_000, n, d))

    def step():
        batch = buffer.sample()
        algo.update(batch)
        buffer.update_tensordict_priority(batch)

    for _ in range(5):
        step()
    start = time.perf_counter()
    with profile(activities=[ProfilerActivity.CPU]) as prof:
        for _ in range(steps):
            step()
    wall = (time.perf_counter() - start) / steps * 1e3
    table = prof.key_averages()
    ops = sum(e.self_cpu_time_total for e in table) / steps / 1e3
    print(f"{steps} PER-MATD3 steps, {wall:.1f} ms each under the profiler, {ops:.1f} ms of it inside operators "
          f"(the rest: Python, TensorDict, dispatch)\n")
    print(table.table(sort_by="self_cpu_time_total", row_limit=14))


def eval_seconds(episodes: int = 1000) -> float:
    """Wall time of one evaluation of ``episodes`` held-out episodes (the paper budget's cadence)."""
    cfg = make_config("per_matd3", eval_episodes=episodes, progress=False)
    with tempfile.TemporaryDirectory() as run_dir:
        trainer = Trainer(cfg, run_dir)
        trainer.evaluate()
        t = time.perf_counter()
        trainer.evaluate()
        return time.perf_counter() - t


# ---------------------------------------------------------------------------------------- report
def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", default=None, help="also write the results to this JSON file")
    parser.add_argument("--quick", action="store_true", help="fewer steps and frames (a smoke run, noisier)")
    parser.add_argument("--threads", type=int, default=None, help="torch intra-op threads (default: torch's)")
    parser.add_argument("--batch-sweep", action="store_true",
                        help="only the PER-MATD3 gradient step at batches 128-2048 (steps/s, samples/s vs 1024)")
    parser.add_argument("--precision", action="store_true",
                        help="only the matmul rates and the PER-MATD3 step in fp32, bf16 and bf16_targets")
    parser.add_argument("--profile", action="store_true",
                        help="only print torch.profiler's top operators of 10 PER-MATD3 gradient steps")
    args = parser.parse_args()
    if args.threads:
        torch.set_num_threads(args.threads)
    logging.getLogger("torchrl").setLevel(logging.WARNING)  # one INFO line per replay buffer otherwise
    if args.profile:
        profile_step()
        return
    if args.batch_sweep:
        batch_sweep(8 if args.quick else 30)
        return
    if args.precision:
        precision_step(15 if args.quick else 30, 2 if args.quick else 4)
        return
    steps, scale = (8, 0.25) if args.quick else (30, 1.0)
    out: dict = {"machine": {"cpu": _cpu(), "cores": os.cpu_count(), "threads": torch.get_num_threads(),
                             "torch": torch.__version__, "python": platform.python_version()}}
    say = print
    rate = matmul_rate()
    out["matmul_gflops"] = rate
    say(f"# Training throughput — {out['machine']['cpu']}, {out['machine']['cores']} cores, "
        f"torch {torch.__version__}, {torch.get_num_threads()} threads\n")
    say(f"fp32 matmul rate (reference, same process): {rate:.1f} GFLOP/s\n")

    out["precision"] = precision_step(15 if args.quick else 30, 2 if args.quick else 4, rate)
    if out["precision"]["bf16"]:
        out["matmul_gflops_bf16"] = out["precision"]["bf16"]["matmul_gflops"]

    say("## Gradient step (N=5, M=4, batch 1024)\n")
    say("| algorithm | ms / step | sample ms | update ms | priority ms | GFLOP / step | GFLOP/s | / matmul |")
    say("|---|---:|---:|---:|---:|---:|---:|---:|")
    out["grad_step"] = {}
    for name in ALGOS:
        r = grad_step(name, steps=steps)
        out["grad_step"][name] = r
        p = r["parts_ms"]
        say(f"| {name} | {r['ms']:.1f} | {p['sample']:.1f} | {p['update']:.1f} | {p['priority']:.1f} | "
            f"{r['gflop']:.2f} | {r['gflops']:.1f} | {100 * r['gflops'] / rate:.0f}% |")
        sys.stdout.flush()

    say("\n## End to end at the paper's ratio (1 gradient step / 100 frames, N=5, 64 env copies)\n")
    frames = int(100_000 * scale)
    cols = ("env", "policy", "buffer_extend", "buffer_sample", "update", "priority", "metrics", "logging", "other")
    say("| algorithm | frames/s | " + " | ".join(cols) + " | not the update |")
    say("|---|---:|" + "---:|" * (len(cols) + 1))
    out["end_to_end"] = {}

    def e2e_row(label: str, r: dict) -> None:
        s = r["split"]
        say(f"| {label} | {r['fps']:,.0f} | " + " | ".join(f"{100 * s.get(c, 0):.1f}%" for c in cols)
            + f" | {100 * (1 - s['update']):.1f}% |")
        sys.stdout.flush()

    for name in ALGOS:
        out["end_to_end"][name] = r = end_to_end(name, frames)
        e2e_row(name, r)
    projections = {"fp32": out["end_to_end"]["per_matd3"]}  # precision: its PER-MATD3 run
    if out["precision"]["bf16_targets"]:  # the same run with the update in bf16, target passes included
        out["end_to_end_bf16_targets"] = projections["bf16_targets"] = r = end_to_end(
            "per_matd3", frames, precision="bf16_targets")
        e2e_row("per_matd3, precision=bf16_targets", r)

    evals = PAPER_FRAMES // 500_000  # conf/budget/paper.yaml: every 500k frames, 1,000 episodes
    ev = eval_seconds(1000)
    for label, per in projections.items():
        projected = PAPER_FRAMES / per["fps"] + (evals + 1) * ev
        out["paper_projection" if label == "fp32" else f"paper_projection_{label}"] = {
            "frames": PAPER_FRAMES, "grad_steps": PAPER_FRAMES // PAPER_RATIO, "fps": per["fps"],
            "eval_seconds": ev, "evaluations": evals + 1, "minutes": projected / 60}
        say(f"\nProjected paper budget, PER-MATD3, precision={label} (9M frames, 90,000 gradient steps, "
            f"{evals + 1} evaluations of 1,000 episodes at {ev:.1f} s): **{projected / 60:.0f} min** "
            f"(= 9M / {per['fps']:,.0f} frames/s + evaluations; the replay buffer grows to 1M, sampling cost "
            "measured at 50k-100k)")
    say("")

    say("## Scaling in robots N (PER-MATD3, M=4, batch 1024, 64 env copies)\n")
    say("| N | obs width | ms / step | GFLOP / step | critics' joint-input layer | GFLOP/s | / matmul | "
        "frames/s (paper ratio) | step ms / N, vs N=5 |")
    say("|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    out["scaling_n"] = {}
    for n in (3, 5, 9, 17):
        g = grad_step("per_matd3", n=n, steps=max(5, steps // 2))
        e = end_to_end("per_matd3", int(12_000 * scale), n=n)
        out["scaling_n"][n] = {"grad_step": g, "end_to_end": e, "obs_dim": 4 + 2 * (n - 1) + 13}
    base = out["scaling_n"][5]["grad_step"]["ms"] / 5
    for n, r in out["scaling_n"].items():
        g, e = r["grad_step"], r["end_to_end"]
        joint = joint_layer_share(n, r["obs_dim"], 128, 2, 2)
        r["joint_layer_share"] = joint
        say(f"| {n} | {r['obs_dim']} | {g['ms']:.1f} | {g['gflop']:.2f} | {100 * joint:.0f}% | {g['gflops']:.1f} | "
            f"{100 * g['gflops'] / rate:.0f}% | {e['fps']:,.0f} | {g['ms'] / n / base:.2f}x |")

    say("\n## Scaling in env copies B (PER-MATD3, N=5, paper ratio)\n")
    say("| B | frames / collector batch | frames/s | env | policy | update |")
    say("|---:|---:|---:|---:|---:|---:|")
    out["scaling_b"] = {}
    for b, spb in ((1, 200), (64, 25), (1024, 2), (4096, 1)):
        frames_b = max(int(30_000 * scale), 2 * b * spb) if b > 1 else int(10_000 * scale)
        e = end_to_end("per_matd3", frames_b, num_envs=b, steps_per_batch=spb)
        out["scaling_b"][b] = e
        s = e["split"]
        say(f"| {b} | {b * spb:,} | {e['fps']:,.0f} | {100 * s.get('env', 0):.1f}% | "
            f"{100 * s.get('policy', 0):.1f}% | {100 * s['update']:.1f}% |")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(out, f, indent=2, default=float)
        say(f"\nJSON: {args.json}")


def precision_step(steps: int, rounds: int, fp32_rate: float | None = None) -> dict:
    """The PER-MATD3 gradient step in fp32, bf16 and bf16_targets, alternated ``rounds`` times (medians),
    beside each precision's square-matmul rate and the ratio's floor, all in this process; ``bf16`` and
    ``bf16_targets`` are ``None`` where the CPU lacks native bf16."""
    rates = {"fp32": fp32_rate or matmul_rate()}
    precisions = ["fp32"]
    if bf16_supported("cpu"):
        rates["bf16"] = rates["bf16_targets"] = matmul_rate(dtype=torch.bfloat16)
        precisions += ["bf16", "bf16_targets"]
    runs: dict[str, list[dict]] = {p: [] for p in precisions}
    for _ in range(rounds):
        for p in precisions:
            runs[p].append(grad_step("per_matd3", steps=steps, precision=p))
    cfg = make_config("per_matd3")  # the shapes grad_step timed
    share = target_share(cfg.env.num_robots, cfg.env.obs_dim, list(cfg.model.hidden), cfg.algo.num_critics,
                         cfg.algo.policy_delay)
    floors = {"fp32": 1.0}  # what the matmul rates allow at best: GEMMs only, each at its square-matmul rate
    if len(precisions) > 1:
        floors["bf16"] = bf16_floor(share, rates["fp32"], rates["bf16"])  # the target passes in fp32
        floors["bf16_targets"] = bf16_floor(0.0, rates["fp32"], rates["bf16"])  # every GEMM in bf16
    out: dict = {"bf16": None, "bf16_targets": None}
    print("## Gradient step by precision (PER-MATD3, N=5, M=4, batch 1024; alternated, same process)\n")
    print("| precision | matmul GFLOP/s | ms / step | CPU ms / step | GFLOP/s | / its matmul | step / fp32 step "
          "| floor |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for p in precisions:
        ms = statistics.median(r["ms"] for r in runs[p])
        r = {"matmul_gflops": rates[p], "ms": ms, "cpu_ms": statistics.median(r["cpu_ms"] for r in runs[p]),
             "gflops": runs[p][0]["gflop"] / ms * 1e3, "floor": floors[p]}
        r["vs_fp32"] = ms / out["fp32"]["ms"] if p != "fp32" else 1.0
        out[p] = r
        print(f"| {p} | {rates[p]:.1f} | {ms:.1f} | {r['cpu_ms']:.1f} | {r['gflops']:.1f} | "
              f"{100 * r['gflops'] / rates[p]:.0f}% | {r['vs_fp32']:.2f} | {floors[p]:.2f} |")
    if out["bf16"] is None:
        print("| bf16, bf16_targets | - | - | - | - | - | (this CPU has no native bf16) | - |")
    else:
        print(f"\nfloor: the lowest step / fp32 step the matmul rates allow (every GEMM at its precision's "
              f"square-matmul rate, no other work); bf16 keeps the target passes ({100 * share:.0f}% of the FLOPs) "
              "in fp32, bf16_targets runs them in bf16 too.")
    print(flush=True)
    return out


def batch_sweep(steps: int) -> None:
    """PER-MATD3 gradient step (N=5, M=4, 128-wide) at several replay batch sizes, one process."""
    print(f"## PER-MATD3 gradient step by replay batch (N=5, M=4, {torch.get_num_threads()} threads)\n")
    print("| batch | ms / step | steps/s | samples/s | samples/s vs batch 1024 |")
    print("|---:|---:|---:|---:|---:|")
    rows = {b: grad_step("per_matd3", steps=steps, batch=b)["ms"] for b in (128, 256, 512, 1024, 2048)}
    for b, ms in rows.items():
        print(f"| {b} | {ms:.1f} | {1e3 / ms:.1f} | {1e3 * b / ms:,.0f} | {b / ms / (1024 / rows[1024]):.2f}x |")


def _cpu() -> str:
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


if __name__ == "__main__":
    main()

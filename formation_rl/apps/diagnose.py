"""Why episodes fail: ``python -m formation_rl.apps.diagnose CKPT [CKPT ...] [--out DIR]``.

On the held-out episodes of ``make eval`` (same seed, the checkpoint's own world), success (SPEC §6)
is split into its three parts: the leader within ``rho_g`` of the goal at the last step, no
robot-robot collision, no robot-obstacle collision; and each episode's first collision of either
kind is timed. Prints a table per controller and writes ``failures.json`` and
``first_collision.png`` (when the first collisions happen, one line per controller) into ``--out``.
"""

from __future__ import annotations

import argparse
import functools
import json
import sys
from pathlib import Path

import torch

from formation_rl.envs import EnvConfig
from formation_rl.evaluation.diagnose import BINS, PARTS, breakdown, failure_metrics, first_step, last_step
from formation_rl.evaluation.evaluate import EVAL_SEED, evaluate_policy

__all__ = ["BINS", "PARTS", "breakdown", "failure_metrics", "first_step", "last_step", "format_rows", "main", "plot"]


def plot(results: dict[str, dict[str, torch.Tensor]], max_steps: int, out: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8), sharey=True)
    steps = torch.arange(1, max_steps + 1)
    for name, per_episode in results.items():
        for ax, key in zip(axes, ("first_robot_collision", "first_obstacle_collision"), strict=True):
            first = per_episode[key]
            share = ((first[None] >= 1) & (first[None] <= steps[:, None])).double().mean(1)
            ax.plot(steps.numpy(), 100 * share.numpy(), label=name)
    for ax, title in zip(axes, ("robot-robot", "robot-obstacle"), strict=True):
        ax.set_title(f"first {title} collision")
        ax.set_xlabel("step (0.1 s)")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("episodes collided by then (%)")
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "first_collision.png", dpi=120)
    plt.close(fig)
    return out / "first_collision.png"


def format_rows(name: str, b: dict[str, float]) -> str:
    windows = ", ".join(f"{lo}-{hi}: {100 * b[f'first_robot_collision_{lo}_{hi}']:.1f}%" for lo, hi in BINS)
    return (f"{name}\n  success {100 * b['success']:.1f}% = leader at the goal {100 * b['at_goal']:.1f}% x no "
            f"robot-robot collision {100 * b['no_robot_collision']:.1f}% x no obstacle collision "
            f"{100 * b['no_obstacle_collision']:.1f}% (jointly)\n"
            f"  first robot-robot collision by step: {windows}\n"
            f"  robot-robot collisions only in the first 20 steps: {100 * b['robot_collision_only_in_first_20']:.1f}%\n"
            f"  leader ends at a wall: {100 * b['leader_at_wall']:.1f}%; saturated action components (|a| > 0.99): "
            f"{100 * b['saturated_actions']:.1f}%")


def _edge(cfg: EnvConfig) -> float:
    return cfg.arena_half_size - cfg.robot_radius


def main(argv: list[str] | None = None) -> int:
    from formation_rl.evaluation.policy import load_policy

    parser = argparse.ArgumentParser(description="Split success into its parts and time the first collisions")
    parser.add_argument("ckpts", nargs="+", help="policy.pt, last.pt, run directory or apf")
    parser.add_argument("--episodes", type=int, default=1000, help="held-out episodes per controller (default 1000)")
    parser.add_argument("--seed", type=int, default=EVAL_SEED, help="evaluation seed (default: make eval's)")
    parser.add_argument("--out", default="outputs/diagnose", help="where failures.json and the figure go")
    args = parser.parse_args(argv)
    try:
        if args.episodes < 1:
            raise ValueError(f"--episodes = {args.episodes} is invalid: must be an integer >= 1")
        policies = {c: load_policy(c) for c in args.ckpts}  # every path checked before any rollout
        results = {c: evaluate_policy(p.module, p.env_config, args.episodes, 1000, args.seed, "cpu",
                                      metrics=functools.partial(failure_metrics, edge=_edge(p.env_config)))
                   for c, p in policies.items()}
        out = Path(args.out)
        try:
            out.mkdir(parents=True, exist_ok=True)
            rows = {c: breakdown(r) for c, r in results.items()}
            (out / "failures.json").write_text(json.dumps({"episodes": args.episodes, "seed": args.seed,
                                                           "controllers": rows}, indent=2))
            fig = plot(results, max(p.env_config.max_steps for p in policies.values()), out)
        except OSError as err:
            raise ValueError(f"cannot write to --out {out}: {err.strerror or err}") from None
    except ValueError as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    print("\n".join(format_rows(c, b) for c, b in rows.items()))
    print(f"wrote {out / 'failures.json'} and {fig}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

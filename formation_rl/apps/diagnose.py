"""Why episodes fail: ``python -m formation_rl.apps.diagnose ckpt=PATH`` (or ``ckpt=[PATH,apf,...]`` to compare).

On the held-out episodes of ``make eval`` (same seed, the checkpoint's own world), success (reference.md, Metrics)
is split into its three parts: the leader within ``rho_g`` of the goal at the last step, no
robot-robot collision, no robot-obstacle collision; and each episode's first collision of either
kind is timed. Prints a table per controller and writes ``failures.json``, ``first_collision.png`` (when the
first collisions happen, one line per controller) and ``formation_error.png`` (the formation error and the
share of episodes with the chain active, per step) into ``out``.
"""

from __future__ import annotations

import functools
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import hydra
import torch
from hydra.core.config_store import ConfigStore
from omegaconf import DictConfig, OmegaConf

from formation_rl.apps.cli import CONF, as_list, one_line_errors
from formation_rl.envs import EnvConfig
from formation_rl.evaluation.diagnose import BINS, breakdown, failure_metrics
from formation_rl.evaluation.evaluate import EVAL_SEED, evaluate_policy


@dataclass
class DiagnoseConfig:
    ckpt: Any = None  # policy.pt, last.pt, a run directory or apf; or a list of them, diagnosed side by side
    episodes: int = 1000  # held-out episodes per controller
    seed: int = EVAL_SEED  # make eval's held-out scenarios
    out: str = "outputs/diagnose"  # where failures.json, first_collision.png and formation_error.png go


ConfigStore.instance().store(name="diagnose_schema", node=DiagnoseConfig)


def _legend_below(fig, ax, rows: int) -> None:
    """One legend row per controller under the plots (checkpoint paths are long: inside they hide the curves)."""
    legend = 0.22 * rows  # inches
    fig.set_figheight(fig.get_figheight() + legend)
    fig.legend(*ax.get_legend_handles_labels(), loc="lower center", fontsize=8, frameon=False)
    fig.tight_layout(rect=(0, legend / fig.get_figheight() + 0.01, 1, 1))


def plot(results: dict[str, dict[str, torch.Tensor]], max_steps: int, out: Path) -> list[Path]:
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
    _legend_below(fig, axes[0], len(results))
    fig.savefig(out / "first_collision.png", dpi=120)
    plt.close(fig)

    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
    for name, per_episode in results.items():
        for ax, key in zip(axes, ("formation_error_per_step", "in_area_per_step"), strict=True):
            curve = per_episode[key].mean(0)
            scale = 100 if key == "in_area_per_step" else 1
            ax.plot(range(1, len(curve) + 1), scale * curve.numpy(), label=name)
    axes[0].set_title("formation error (RFSE is its mean over steps)")
    axes[0].set_ylabel("sum over constrained pairs of |d - d*| (m)")
    axes[1].set_title("leader in the obstacle area (the chain active)")
    axes[1].set_ylabel("episodes (%)")
    for ax in axes:
        ax.set_xlabel("step (0.1 s)")
        ax.grid(alpha=0.3)
    _legend_below(fig, axes[0], len(results))
    fig.savefig(out / "formation_error.png", dpi=120)
    plt.close(fig)
    return [out / "first_collision.png", out / "formation_error.png"]


def format_rows(name: str, b: dict[str, float]) -> str:
    windows = ", ".join(f"{lo}-{hi}: {100 * b[f'first_robot_collision_{lo}_{hi}']:.1f}%" for lo, hi in BINS)
    return (f"{name}\n  success {100 * b['success']:.1f}% = leader at the goal {100 * b['at_goal']:.1f}% x no "
            f"robot-robot collision {100 * b['no_robot_collision']:.1f}% x no obstacle collision "
            f"{100 * b['no_obstacle_collision']:.1f}% (jointly)\n"
            f"  first robot-robot collision by step: {windows}\n"
            f"  robot-robot collisions only in the first 20 steps: {100 * b['robot_collision_only_in_first_20']:.1f}%\n"
            f"  leader ends at a wall: {100 * b['leader_at_wall']:.1f}%; saturated action components (|a| > 0.99): "
            f"{100 * b['saturated_actions']:.1f}%\n"
            f"  followers' distance to the leader at the end: {b['follower_distance_end']:.2f} m; steps with the "
            f"leader in the obstacle area (chain active): {100 * b['leader_in_area_steps']:.1f}%; episodes whose "
            f"leader enters it: {100 * b['leader_enters_area']:.1f}%")


def _edge(cfg: EnvConfig) -> float:
    return cfg.arena_half_size - cfg.robot_radius


def run(cfg: DiagnoseConfig) -> tuple[dict[str, dict[str, float]], list[Path]]:
    """The breakdown of every controller in ``cfg.ckpt``, and the files written; bad input raises before any rollout."""
    from formation_rl.evaluation.policy import load_policy

    ckpts = as_list(cfg.ckpt)
    if not ckpts:
        raise ValueError(f"ckpt = {cfg.ckpt!r} is invalid: must be a policy.pt, last.pt, run directory or apf, or a "
                         "list of them (make diagnose CKPT=...)")
    if cfg.episodes < 1:
        raise ValueError(f"episodes = {cfg.episodes} is invalid: must be an integer >= 1")
    policies = {c: load_policy(c) for c in ckpts}  # every path checked before any rollout
    results = {c: evaluate_policy(p.module, p.env_config, cfg.episodes, 1000, cfg.seed, "cpu",
                                  metrics=functools.partial(failure_metrics, edge=_edge(p.env_config)))
               for c, p in policies.items()}
    out = Path(cfg.out)
    rows = {c: breakdown(r) for c, r in results.items()}
    try:
        out.mkdir(parents=True, exist_ok=True)
        (out / "failures.json").write_text(json.dumps({"episodes": cfg.episodes, "seed": cfg.seed,
                                                       "controllers": rows}, indent=2))
        figs = plot(results, max(p.env_config.max_steps for p in policies.values()), out)
    except OSError as err:
        raise ValueError(f"out = {str(out)!r} is invalid: cannot write there: {err.strerror or err}") from None
    return rows, [out / "failures.json", *figs]


@hydra.main(config_path=str(CONF), config_name="diagnose", version_base=None)
@one_line_errors
def main(cfg: DictConfig) -> None:
    rows, written = run(OmegaConf.to_object(cfg))
    print("\n".join(format_rows(c, b) for c, b in rows.items()))
    print(f"wrote {', '.join(map(str, written))}")


if __name__ == "__main__":
    from formation_rl.apps.cli import check_overrides

    check_overrides(DiagnoseConfig, ())
    main()

"""Evaluation by docs/reference.md, Evaluation protocol: deterministic actors on fresh episodes from held-out
seeds, batched over env copies; per-episode metrics, their means with 95% confidence intervals, the table
and the ``metrics.json`` / ``metrics.csv`` files of ``make eval`` (the app: :mod:`formation_rl.apps.evaluate`).
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Callable
from pathlib import Path

import torch
from tensordict import TensorDictBase
from tqdm import tqdm

from formation_rl.envs import EnvConfig, FormationEnv
from formation_rl.envs.metrics import episode_metrics

EVAL_SEED = 2_000_000_011  # held-out scenarios: training uses small seeds, periodic evaluation 1_000_000_007
# two-sided 95% Student t quantiles for df = 1..29; the normal 1.96 beyond
_T975 = [12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160, 2.145, 2.131,
         2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056, 2.052, 2.048, 2.045]


def mean_ci(values: torch.Tensor) -> tuple[float, float]:
    """Mean and half-width of the two-sided 95% confidence interval (Student t)."""
    x = values.double()
    n = x.numel()
    if n == 0:
        return float("nan"), float("nan")
    if n == 1:
        return x.item(), float("nan")
    t = _T975[n - 2] if n - 1 <= len(_T975) else 1.96
    return x.mean().item(), t * x.std(unbiased=True).item() / math.sqrt(n)


@torch.no_grad()
def evaluate_policy(policy: Callable[[TensorDictBase], TensorDictBase], env_cfg: EnvConfig, episodes: int,
                    num_envs: int = 1000, seed: int = EVAL_SEED, device="cpu",
                    progress: bool = True,
                    metrics: Callable[[TensorDictBase, float], dict[str, torch.Tensor]] = episode_metrics,
                    ) -> dict[str, torch.Tensor]:
    """Per-episode metrics (``{metric: [episodes]}``; reference.md, Metrics) of ``policy`` on fresh episodes.

    ``metrics(rollout, goal_radius)`` maps each round's ``[copies, max_steps]`` rollout, every copy
    from a reset, to per-episode values (default: :func:`~formation_rl.envs.metrics.episode_metrics`).
    """
    copies = min(num_envs, episodes)
    env = FormationEnv(copies, config=env_cfg, device=device, seed=seed)
    rounds = math.ceil(episodes / copies)
    out: dict[str, list[torch.Tensor]] = {}
    for _ in tqdm(range(rounds), desc="evaluate", unit="round", disable=not progress or rounds == 1):
        rollout = env.rollout(env_cfg.max_steps, policy, break_when_any_done=False)
        for k, v in metrics(rollout, env_cfg.goal_radius).items():
            out.setdefault(k, []).append(v)
    return {k: torch.cat(v)[:episodes] for k, v in out.items()}


def summarize_ci(per_episode: dict[str, torch.Tensor]) -> dict[str, dict[str, float]]:
    return {k: dict(zip(("mean", "ci95"), mean_ci(v), strict=True)) for k, v in per_episode.items()}


def format_table(summary: dict[str, dict[str, float]], title: str) -> str:
    w = max(len(k) for k in ("metric", *summary))
    rows = [f"{title}", f"{'metric':<{w}} {'mean':>12} {'95% CI':>12}"]
    rows += [f"{k:<{w}} {v['mean']:>12.4f} {'±':>2}{v['ci95']:>10.4f}" for k, v in summary.items() if k != "length"]
    return "\n".join(rows)


def write_results(summary: dict[str, dict[str, float]], out_dir: Path, meta: dict) -> tuple[Path, Path]:
    """``metrics.json`` (means, CIs and the evaluation's settings) and ``metrics.csv``, written whole."""
    try:
        return _write_results(summary, out_dir, meta)
    except OSError as err:
        raise ValueError(f"cannot write results to {out_dir}: {err.strerror or err}") from None


def _write_results(summary: dict[str, dict[str, float]], out_dir: Path, meta: dict) -> tuple[Path, Path]:
    out_dir.mkdir(parents=True, exist_ok=True)
    flat = {k: v["mean"] for k, v in summary.items()}
    js, cs = out_dir / "metrics.json", out_dir / "metrics.csv"
    tmp = js.with_suffix(".json.tmp")
    tmp.write_text(json.dumps({**flat, "ci95": {k: v["ci95"] for k, v in summary.items()}, "eval": meta}, indent=2))
    tmp.replace(js)
    tmp = cs.with_suffix(".csv.tmp")
    with tmp.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["metric", "mean", "ci95"])
        for k, v in summary.items():
            w.writerow([k, v["mean"], v["ci95"]])
    tmp.replace(cs)
    return js, cs

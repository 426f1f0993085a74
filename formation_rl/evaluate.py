"""Evaluate a policy by the protocol of SPEC §6: ``python -m formation_rl.evaluate ckpt=PATH [overrides]``.

Deterministic actors on ``episodes`` fresh episodes from held-out seeds, batched over env copies;
prints mean and 95% confidence interval of each metric and writes ``metrics.json`` and
``metrics.csv`` into ``out`` (default ``outputs/eval/<name>``, never beside the checkpoint:
:func:`formation_rl.policy.output_dir`). ``env.*``, ``formation=`` and ``reward=``
overrides change the evaluation world; the team size and observation width must stay the policy's.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import hydra
import torch
from hydra.core.config_store import ConfigStore
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig, OmegaConf
from tensordict import TensorDictBase
from tqdm import tqdm

from formation_rl.cli import CONF, check_device, one_line_errors
from formation_rl.envs import EnvConfig, FormationEnv
from formation_rl.envs.metrics import episode_metrics

EVAL_SEED = 2_000_000_011  # held-out scenarios: training uses small seeds, periodic evaluation 1_000_000_007
# two-sided 95% Student t quantiles for df = 1..29; the normal 1.96 beyond
_T975 = [12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160, 2.145, 2.131,
         2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056, 2.052, 2.048, 2.045]


@dataclass
class EvalConfig:
    ckpt: str | None = None  # policy.pt, last.pt, a run directory, or "apf" (the classical controller)
    episodes: int = 1000  # fresh held-out episodes (SPEC §6)
    num_envs: int = 1000  # copies stepped together (episodes run in rounds of this many)
    seed: int = EVAL_SEED
    out: str | None = None  # where metrics.json / metrics.csv go (default: outputs/eval/<checkpoint or run name>)
    device: str = "cpu"
    env: EnvConfig = field(default_factory=EnvConfig)  # only the keys overridden on the command line apply


ConfigStore.instance().store(name="eval_schema", node=EvalConfig)


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
    """Per-episode SPEC §6 metrics (``{metric: [episodes]}``) of ``policy`` on fresh episodes.

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


def _overridden_env(cfg: DictConfig, base: EnvConfig) -> EnvConfig:
    """The checkpoint's world with only the env keys the user overrode on the command line."""
    overrides = HydraConfig.get().overrides.task
    merged = OmegaConf.structured(base)
    for o in overrides:
        key = o.lstrip("+~").split("=", 1)[0]
        if key.startswith("env."):
            OmegaConf.update(merged, key[4:], OmegaConf.select(cfg, key), merge=False)
        elif key == "formation":
            merged.formation = cfg.env.formation
        elif key == "reward":
            merged.reward = cfg.env.reward
    return EnvConfig.from_dict(merged)


@hydra.main(config_path=str(CONF), config_name="evaluate", version_base=None)
@one_line_errors
def main(cfg: DictConfig) -> None:
    from formation_rl.policy import CLASSICAL, classical_policy, is_classical, load_policy, output_dir, policy_path

    check_device(cfg.device)
    ckpt = cfg.ckpt
    if not ckpt:
        raise ValueError("ckpt = None is invalid: must be a policy.pt, last.pt, run directory or apf "
                         "(make eval CKPT=...)")
    if cfg.episodes < 1 or cfg.num_envs < 1:
        field_, value = ("episodes", cfg.episodes) if cfg.episodes < 1 else ("num_envs", cfg.num_envs)
        raise ValueError(f"{field_} = {value} is invalid: must be an integer >= 1")
    if is_classical(ckpt):  # no checkpoint: the default world with the overrides
        source = CLASSICAL
        env_cfg = _overridden_env(cfg, EnvConfig())
        policy = classical_policy(env_cfg, cfg.device)
    else:
        path = policy_path(ckpt)
        source = str(path)
        policy = load_policy(path, cfg.device)
        env_cfg = _overridden_env(cfg, policy.env_config)
        policy.check_world(env_cfg)
    per_episode = evaluate_policy(policy.module, env_cfg, cfg.episodes, cfg.num_envs, cfg.seed, cfg.device)
    summary = summarize_ci(per_episode)
    out_dir = Path(cfg.out) if cfg.out else output_dir("eval", ckpt)
    meta = {"ckpt": source, "algo": policy.algo, "policy": policy.label, "episodes": cfg.episodes, "seed": cfg.seed,
            "env": dataclasses.asdict(env_cfg)}
    js, cs = write_results(summary, out_dir, meta)
    print(format_table(summary, f"{policy.label} on {cfg.episodes} held-out episodes (seed {cfg.seed}):"))
    print(f"wrote {js} and {cs}")


if __name__ == "__main__":
    from formation_rl.cli import check_overrides

    check_overrides(EvalConfig, ("formation", "reward", "env"))
    main()

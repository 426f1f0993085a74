"""Evaluate a policy by the reference.md protocol: ``python -m formation_rl.apps.evaluate ckpt=PATH [overrides]``.

Deterministic actors on ``episodes`` fresh episodes from held-out seeds, batched over env copies;
prints mean and 95% confidence interval of each metric and writes ``metrics.json`` and
``metrics.csv`` into ``out`` (default ``outputs/eval/<name>``, never beside the checkpoint:
:func:`formation_rl.evaluation.policy.output_dir`). ``env.*``, ``formation=`` and ``reward=``
overrides change the evaluation world; the team size and observation width must stay the policy's.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path

import hydra
from hydra.core.config_store import ConfigStore
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig, OmegaConf

from formation_rl.apps.cli import CONF, one_line_errors
from formation_rl.envs import EnvConfig
from formation_rl.evaluation.evaluate import EVAL_SEED, evaluate_policy, format_table, summarize_ci, write_results
from formation_rl.utils import check_device


@dataclass
class EvalConfig:
    ckpt: str | None = None  # policy.pt, last.pt, a run directory, or "apf" (the classical controller)
    episodes: int = 1000  # fresh held-out episodes (reference.md, Evaluation protocol)
    num_envs: int = 1000  # copies stepped together (episodes run in rounds of this many)
    seed: int = EVAL_SEED
    out: str | None = None  # where metrics.json / metrics.csv go (default: outputs/eval/<checkpoint or run name>)
    device: str = "cpu"
    env: EnvConfig = field(default_factory=EnvConfig)  # only the keys overridden on the command line apply


ConfigStore.instance().store(name="eval_schema", node=EvalConfig)


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
    from formation_rl.evaluation.policy import (
        CLASSICAL,
        classical_policy,
        is_classical,
        load_policy,
        output_dir,
        policy_path,
    )

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
    from formation_rl.apps.cli import check_overrides

    check_overrides(EvalConfig, ("formation", "reward", "env"))
    main()

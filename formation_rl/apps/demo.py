"""Roll the formation world and report: ``python -m formation_rl.apps.demo [hydra overrides]``.

Writes ``metrics.json`` (metric means over episodes; reference.md, Metrics) and ``rollout.gif`` (copy 0) into the Hydra
run directory and prints both paths.
"""

from __future__ import annotations

import json
import logging
import time
from dataclasses import dataclass, field
from pathlib import Path

import hydra
import torch
from hydra.core.config_store import ConfigStore
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig
from tqdm import tqdm

from formation_rl.apps.cli import CONF, check_device, one_line_errors
from formation_rl.envs import EnvConfig, FormationEnv
from formation_rl.envs.metrics import episode_metrics, summarize
from formation_rl.envs.render import save_gif


@dataclass
class RolloutConfig:
    env: EnvConfig = field(default_factory=EnvConfig)
    seed: int = 0
    num_envs: int = 64
    episodes: int = 1
    gif: bool = True
    device: str = "cpu"  # cpu | cuda | cuda:<index>


ConfigStore.instance().store(name="rollout_schema", node=RolloutConfig)
log = logging.getLogger(__name__)  # stdout and the run's rollout.log (conf/hydra/job_logging/plain.yaml)


def run(cfg: RolloutConfig | DictConfig, out_dir: Path) -> dict[str, float]:
    """Roll ``episodes`` episodes in each of ``num_envs`` copies with random actions; return the metrics."""
    check_device(cfg.device)
    if not (isinstance(cfg.num_envs, int) and cfg.num_envs >= 1):
        raise ValueError(f"num_envs = {cfg.num_envs!r} is invalid: must be an integer >= 1")
    if not (isinstance(cfg.episodes, int) and cfg.episodes >= 1):
        raise ValueError(f"episodes = {cfg.episodes!r} is invalid: must be an integer >= 1")
    env_cfg = cfg.env if isinstance(cfg.env, EnvConfig) else EnvConfig.from_dict(cfg.env)
    env = FormationEnv(cfg.num_envs, config=env_cfg, device=cfg.device, seed=cfg.seed)
    torch.manual_seed(cfg.seed)  # the random policy
    steps = cfg.episodes * env_cfg.max_steps
    bar = tqdm(total=steps * cfg.num_envs, unit="frame", unit_scale=True, desc="rollout")
    start = time.perf_counter()

    def progress(_env, td):
        bar.update(cfg.num_envs)
        bar.set_postfix(fps=f"{bar.n / (time.perf_counter() - start):,.0f}",
                        reward=f"{td['next', 'agents', 'reward'].mean().item():.2f}", refresh=False)

    rollout = env.rollout(steps, break_when_any_done=False, callback=progress)
    bar.close()
    metrics = summarize(episode_metrics(rollout, env_cfg.goal_radius))
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "metrics.json").write_text(json.dumps(metrics, indent=2))
    if cfg.gif:
        save_gif(rollout[:, : env_cfg.max_steps], out_dir / "rollout.gif", env_cfg, index=0)
    return metrics


@hydra.main(config_path=str(CONF), config_name="rollout", version_base=None)
@one_line_errors
def main(cfg: DictConfig) -> None:
    out_dir = Path(HydraConfig.get().runtime.output_dir)
    metrics = run(cfg, out_dir)
    width = max(map(len, metrics))
    log.info("\n".join(f"{k:<{width}}  {v:10.3f}" for k, v in metrics.items()))
    log.info(f"wrote {out_dir / 'metrics.json'}" + (f" and {out_dir / 'rollout.gif'}" if cfg.gif else ""))


if __name__ == "__main__":
    from formation_rl.apps.cli import check_overrides

    check_overrides(RolloutConfig, ("formation", "reward", "env"))
    main()

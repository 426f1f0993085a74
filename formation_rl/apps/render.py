"""Render one evaluation episode of a policy: ``python -m formation_rl.apps.render ckpt=PATH``.

Writes ``episode.gif`` (the episode) and ``trajectories.png`` (the paper's Figure 10: paths, the
formation at chosen steps, the obstacle area, collisions) into ``out`` (default ``outputs/render/<name>``,
never beside the checkpoint: :func:`formation_rl.evaluation.policy.output_dir`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import hydra
from hydra.core.config_store import ConfigStore
from omegaconf import DictConfig

from formation_rl.apps.cli import CONF, check_device, one_line_errors
from formation_rl.envs import FormationEnv
from formation_rl.envs.metrics import episode_metrics, summarize
from formation_rl.envs.render import plot_trajectories, save_gif
from formation_rl.evaluation.evaluate import EVAL_SEED


@dataclass
class RenderConfig:
    ckpt: str | None = None  # policy.pt, last.pt, a run directory or "apf" (the classical controller)
    seed: int = EVAL_SEED  # the held-out scenario to show
    steps: list[int] = field(default_factory=lambda: [10, 35, 95, 120])  # formation snapshots (Figure 10)
    out: str | None = None  # where the pictures go (default: outputs/render/<checkpoint or run name>)
    gif: bool = True
    fps: int = 15
    device: str = "cpu"  # cpu | cuda | cuda:<index>: where the episode is rolled


ConfigStore.instance().store(name="render_schema", node=RenderConfig)


@hydra.main(config_path=str(CONF), config_name="render", version_base=None)
@one_line_errors
def main(cfg: DictConfig) -> None:
    from formation_rl.evaluation.policy import load_policy, output_dir

    check_device(cfg.device)
    if not cfg.ckpt:
        raise ValueError("ckpt = None is invalid: must be a policy.pt, last.pt, run directory or apf "
                         "(make render CKPT=...)")
    policy = load_policy(cfg.ckpt, cfg.device)
    env_cfg = policy.env_config
    bad = [s for s in cfg.steps if not 0 <= s <= env_cfg.max_steps]
    if bad:
        raise ValueError(f"steps = {list(cfg.steps)} is invalid: each step must be in [0, {env_cfg.max_steps}]")
    env = FormationEnv(1, config=env_cfg, device=cfg.device, seed=cfg.seed)
    rollout = env.rollout(env_cfg.max_steps, policy, break_when_any_done=False).cpu()
    m = summarize(episode_metrics(rollout, env_cfg.goal_radius))
    out = Path(cfg.out) if cfg.out else output_dir("render", cfg.ckpt)
    title = (f"{policy.label}: CBRO {m['CBRO']:.1f}%  UDBLT {m['UDBLT']:.2f} m  RFSE {m['RFSE']:.2f} m  "
             f"success {m['success']:.0f}")
    try:
        png = plot_trajectories(rollout, env_cfg, out / "trajectories.png", steps=tuple(cfg.steps), title=title)
        print(f"wrote {png}")
        if cfg.gif:
            print(f"wrote {save_gif(rollout, out / 'episode.gif', env_cfg, fps=cfg.fps)}")
    except OSError as err:
        raise ValueError(f"cannot write pictures to {out}: {err.strerror or err}") from None


if __name__ == "__main__":
    from formation_rl.apps.cli import check_overrides

    check_overrides(RenderConfig, ())
    main()

"""Train MADDPG / MATD3 / PER-MATD3: ``python -m formation_rl.apps.train algo=per_matd3 [overrides]``.

Writes TensorBoard events (``tb/``), checkpoints (``checkpoints/last.pt``, ``checkpoints/policy.pt``,
``checkpoints/best_policy.pt``) and the final evaluation (``metrics.json``) into the Hydra run directory.
"""

from __future__ import annotations

import json
import logging
import sys
from pathlib import Path

import hydra
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig

from formation_rl.apps.cli import CONF, one_line_errors
from formation_rl.models import bf16_speedup
from formation_rl.training.checkpoint import BEST_POLICY, CHECKPOINT
from formation_rl.training.config import BF16_MIN_SPEEDUP, register
from formation_rl.training.trainer import Trainer, to_train_config

register()
log = logging.getLogger(__name__)  # stdout and the run's train.log (conf/hydra/job_logging/plain.yaml)


def check_fresh_run_dir(argv: list[str] | None = None) -> None:
    """Refuse, before Hydra writes into it, a ``hydra.run.dir`` that already holds a run's checkpoint unless
    ``resume`` is given: a new run there would overwrite that run's checkpoints and config."""
    from hydra.core.override_parser.overrides_parser import OverridesParser

    argv = sys.argv[1:] if argv is None else argv
    try:  # Hydra's own parser, so quoted values read as Hydra will read them
        given = {o.key_or_group: o.value() for o in OverridesParser.create().parse_overrides(
            [a for a in argv if "=" in a and not a.startswith("-")]) if not o.is_sweep_override()}
    except Exception:  # noqa: BLE001  (malformed: Hydra reports it)
        return
    run_dir = given.get("hydra.run.dir")
    if run_dir and given.get("resume") in (None, False, "") and (Path(str(run_dir)) / CHECKPOINT).is_file():
        print(f"error: hydra.run.dir = {run_dir!r} is invalid: it already holds a run ({CHECKPOINT}); "
              "resume=auto continues it, or give another directory", file=sys.stderr)
        sys.exit(2)


@hydra.main(config_path=str(CONF), config_name="config", version_base=None)
@one_line_errors
def main(cfg: DictConfig) -> float:
    run_dir = Path(HydraConfig.get().runtime.output_dir)
    trainer = Trainer(to_train_config(cfg), run_dir)
    if cfg.precision == "auto":
        speed = bf16_speedup(cfg.device)
        why = (f"bf16 GEMM {speed:.2f}x fp32's speed here" if speed > 0 else "no native bf16 here")
        log.info(f"precision=auto: {trainer.cfg.precision} on this {cfg.device} "
                 f"({why}; bf16_targets from {BF16_MIN_SPEEDUP}x)")
    if cfg.resume:
        trainer.load_checkpoint(cfg.resume)
    metrics = trainer.train()
    (run_dir / "metrics.json").write_text(json.dumps(metrics, indent=2))
    width = max(map(len, metrics))
    log.info(f"final evaluation ({cfg.eval_episodes} validation episodes, seed {cfg.eval_seed}):")
    log.info("\n".join(f"  {k:<{width}}  {v:10.3f}" for k, v in metrics.items()))
    if trainer.best is not None:
        b = trainer.best
        log.info(f"best validation evaluation: success {b['success']:.3f}, RFSE {b['RFSE']:.3f} at {b['frames']:,} "
                 f"frames -> {run_dir / BEST_POLICY} (make eval CKPT=<that file>)")
    log.info(f"wall time {trainer.timings.total():.0f} s: {trainer.timings.summary()}")
    log.info(f"run directory: {run_dir}")
    return metrics["episode_reward"]


if __name__ == "__main__":
    from formation_rl.apps.cli import check_overrides
    from formation_rl.training.config import TrainConfig

    check_overrides(TrainConfig, ("algo", "formation", "reward", "budget", "recipe", "env"))
    check_fresh_run_dir()
    main()

"""Hyperparameter study:
``python -m formation_rl.apps.tune [study=NAME] [trials=N] [workers=K] [launcher=local|slurm]``.

A current Optuna driven from Hydra's compose API rather than Hydra's Optuna sweeper: that sweeper
(hydra-optuna-sweeper 1.2) pins ``optuna<3``, whose SQLite storage does not run on SQLAlchemy 2, and a
study must survive a kill and take several workers at once. Every trial composes the training config
(``conf/config.yaml``) from the study's ``base`` overrides plus the values it samples from ``space``,
trains one seed, and is scored on its evaluation of *validation* scenarios (``eval_seed``, disjoint
from training seeds and from ``make eval``'s held-out test seed): see :func:`score`.

The study lives in an SQLite file (``outputs/tune/<study>.db``): run the same command again to resume
(finished trials are kept, a trial killed midway is marked failed and its place given to a new one).
Workers are submitit jobs: local processes (``launcher=local``) or SLURM jobs (``launcher=slurm``,
``slurm.*`` for the partition and limits), each pulling trials until the study has ``trials`` of them.
At the end the top 10 trials and the best parameters go to ``outputs/tune/<study>/summary.md``.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import signal
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import hydra
from hydra.core.config_store import ConfigStore
from omegaconf import DictConfig, OmegaConf

from formation_rl.apps.cli import CONF, one_line_errors

KINDS = ("float", "int", "categorical")


@dataclass
class SlurmConfig:
    partition: str | None = None
    timeout_min: int = 240
    cpus_per_task: int = 1
    mem_gb: int = 8


@dataclass
class TuneConfig:
    study: str = "recipe"  # study name: outputs/tune/<study>.db and outputs/tune/<study>/
    trials: int = 24  # trials in the study, all workers together (finished + pruned)
    workers: int = 2  # parallel workers (local processes or SLURM jobs)
    launcher: str = "local"  # local | slurm (submitit)
    storage: str | None = None  # an Optuna storage URL (default: sqlite:///outputs/tune/<study>.db)
    seed: int = 0  # the training seed of every trial (the sampler is seeded from it too)
    threads: int = 1  # torch threads per worker
    base: list[str] = field(default_factory=list)  # overrides every trial starts from (conf/config.yaml's)
    space: dict[str, Any] = field(default_factory=dict)  # key -> {type, low, high, log} or {type, choices}
    slurm: SlurmConfig = field(default_factory=SlurmConfig)
    out: str = "outputs/tune"
    prune_after: int = 50_000  # frames before a trial may be pruned (median of earlier trials at the same frames)


ConfigStore.instance().store(name="tune_schema", node=TuneConfig)


SCORE = "success + 0.1 at_goal - 0.01 (min(UDBLT, 10) + min(RFSE, 10))"  # as score() computes it


def score(metrics: dict[str, float]) -> float:
    """The study's objective (maximised), a weighted score on validation scenarios:
    ``success + 0.1 at_goal - 0.01 (min(UDBLT, 10) + min(RFSE, 10))`` (fractions in [0, 1], distances in m).
    Success weighs most; the leader's arrival, its final distance to the goal and the formation error give
    the study a gradient while success is still zero, and together outweigh at most 30 points of success."""
    return (metrics["success"] + 0.1 * metrics["at_goal"]
            - 0.01 * (min(metrics["UDBLT"], 10.0) + min(metrics["RFSE"], 10.0)))


def check_space(space: dict[str, Any]) -> None:
    """One-line errors for a malformed search space, before any trial runs."""
    for key, spec in space.items():
        kind = spec.get("type") if isinstance(spec, dict) else None
        if kind not in KINDS:
            raise ValueError(f"space.{key}.type = {kind!r} is invalid: must be one of {', '.join(KINDS)}")
        if kind == "categorical":
            if not spec.get("choices"):
                raise ValueError(f"space.{key}.choices = {spec.get('choices')!r} is invalid: must be a non-empty list")
        elif not (isinstance(spec.get("low"), int | float) and isinstance(spec.get("high"), int | float)
                  and spec["low"] < spec["high"]):
            raise ValueError(f"space.{key} = {dict(spec)!r} is invalid: must have numbers low < high")


def suggest(trial, space: dict[str, Any]) -> list[str]:
    """The trial's sampled values as Hydra overrides."""
    out = []
    for key, spec in space.items():
        if spec["type"] == "float":
            value = trial.suggest_float(key, spec["low"], spec["high"], log=spec.get("log", False))
        elif spec["type"] == "int":
            value = trial.suggest_int(key, spec["low"], spec["high"], log=spec.get("log", False))
        else:
            value = trial.suggest_categorical(key, list(spec["choices"]))
        out.append(f"{key}={value}")
    return out


def storage_url(cfg: TuneConfig) -> str:
    if cfg.storage:
        return cfg.storage
    path = Path(cfg.out).resolve() / f"{cfg.study}.db"
    path.parent.mkdir(parents=True, exist_ok=True)
    return f"sqlite:///{path}"


def train_config(overrides: list[str]):
    """The training config composed from ``conf/`` as ``python -m formation_rl.apps.train`` would."""
    from hydra import compose, initialize_config_dir
    from hydra.core.global_hydra import GlobalHydra

    from formation_rl.training.config import register
    from formation_rl.training.trainer import to_train_config

    register()
    GlobalHydra.instance().clear()  # inside this app's own @hydra.main: compose needs Hydra's global free
    with initialize_config_dir(config_dir=str(CONF), version_base=None):
        return to_train_config(compose(config_name="config", overrides=overrides))


def objective(trial, cfg: TuneConfig) -> float:
    import optuna

    from formation_rl.training.trainer import Trainer

    overrides = [*cfg.base, *suggest(trial, cfg.space), f"seed={cfg.seed}", f"threads={cfg.threads}",
                 "progress=false"]
    train = train_config(overrides)
    run_dir = Path(cfg.out).resolve() / cfg.study / f"trial_{trial.number:03d}"
    trainer = Trainer(train, run_dir)
    trial.set_user_attr("run_dir", str(run_dir))
    trial.set_user_attr("overrides", overrides)

    def report(frames: int, metrics: dict[str, float]) -> None:
        if frames == 0:
            return
        trial.report(score(metrics), frames)
        if trial.should_prune():
            raise optuna.TrialPruned(f"pruned at {frames:,} frames")

    trainer.on_evaluate.append(report)
    metrics = trainer.train()
    (run_dir / "metrics.json").write_text(json.dumps(metrics, indent=2))
    for k in ("success", "at_goal", "RFSE", "CBRO", "CBRS", "UDBLT"):
        trial.set_user_attr(k, metrics[k])
    return score(metrics)


def run_worker(cfg_dict: dict, worker: int = 0) -> int:
    """One worker: pull trials from the shared study until it holds ``trials`` finished or pruned ones.

    Each worker seeds its sampler with ``seed + worker``: the same seed everywhere would have every
    worker draw the same first (random) trials."""
    from optuna.study import MaxTrialsCallback
    from optuna.trial import TrialState

    cfg = OmegaConf.to_object(OmegaConf.merge(OmegaConf.structured(TuneConfig), cfg_dict))
    study = load_study(cfg, worker)
    study.optimize(lambda t: objective(t, cfg), catch=(),
                   callbacks=[MaxTrialsCallback(cfg.trials, states=(TrialState.COMPLETE, TrialState.PRUNED))])
    return len(study.trials)


def load_study(cfg: TuneConfig, worker: int = 0):
    import optuna

    # a worker killed mid-trial stops its heartbeat: the trial is marked failed and retried once
    storage = optuna.storages.RDBStorage(
        storage_url(cfg), heartbeat_interval=60, grace_period=180,
        heartbeat_stale_trial_callback=optuna.storages.RetryHeartbeatStaleTrialCallback(1))
    return optuna.create_study(
        study_name=cfg.study, storage=storage, direction="maximize", load_if_exists=True,
        sampler=optuna.samplers.TPESampler(seed=cfg.seed + worker, n_startup_trials=8, multivariate=True),
        pruner=optuna.pruners.MedianPruner(n_startup_trials=6, n_warmup_steps=cfg.prune_after),
    )


def summary(study, top: int = 10) -> str:
    """Markdown: the search space, the top trials and the best parameters."""
    from optuna.trial import TrialState

    done = sorted((t for t in study.trials if t.state == TrialState.COMPLETE), key=lambda t: -t.value)
    counts = {s.name.lower(): sum(t.state == s for t in study.trials) for s in TrialState}
    keys = sorted({k for t in done for k in t.params})
    lines = [f"# Study `{study.study_name}`", "",
             "Trials: " + ", ".join(f"{v} {k}" for k, v in counts.items() if v), "",
             f"score = {SCORE}, on validation scenarios", "",
             "| # | score | success | at_goal | UDBLT | RFSE | CBRO | CBRS | " + " | ".join(keys) + " |",
             "|" + "---|" * (8 + len(keys))]
    for t in done[:top]:
        u = t.user_attrs
        cells = [str(t.number), f"{t.value:.3f}", *(f"{u.get(k, math.nan):.3f}" for k in ("success", "at_goal")),
                 *(f"{u.get(k, math.nan):.2f}" for k in ("UDBLT", "RFSE", "CBRO", "CBRS")),
                 *(_fmt(t.params.get(k)) for k in keys)]
        lines.append("| " + " | ".join(cells) + " |")
    if done:
        lines += ["", f"Best parameters (trial {done[0].number}):", "", "```",
                  *(f"{k}={_fmt(v)}" for k, v in done[0].params.items()), "```"]
    return "\n".join(lines) + "\n"


def _fmt(v) -> str:
    return f"{v:.4g}" if isinstance(v, float) else str(v)


@hydra.main(config_path=str(CONF), config_name="tune", version_base=None)
@one_line_errors
def main(dcfg: DictConfig) -> None:
    cfg: TuneConfig = OmegaConf.to_object(dcfg)
    if cfg.launcher not in ("local", "slurm"):
        raise ValueError(f"launcher = {cfg.launcher!r} is invalid: must be local or slurm")
    for name in ("trials", "workers", "threads"):
        if getattr(cfg, name) < 1:
            raise ValueError(f"{name} = {getattr(cfg, name)!r} is invalid: must be an integer >= 1")
    if cfg.prune_after < 0:
        raise ValueError(f"prune_after = {cfg.prune_after!r} is invalid: must be an integer >= 0 (frames)")
    check_space(cfg.space)
    from formation_rl.training.config import validate

    first = train_config([*cfg.base, *(f"{k}={_first(s)}" for k, s in cfg.space.items())])
    validate(first)  # a bad base or space fails now, in one line, not in every worker
    first.env.validate()
    study = load_study(cfg)
    print(f"study {cfg.study} in {storage_url(cfg)}: {len(study.trials)} trials so far, {cfg.trials} wanted, "
          f"{cfg.workers} {cfg.launcher} workers")
    import submitit

    folder = Path(cfg.out) / cfg.study / "workers"
    executor = submitit.AutoExecutor(folder=folder, cluster="local" if cfg.launcher == "local" else "slurm")
    executor.update_parameters(timeout_min=cfg.slurm.timeout_min, cpus_per_task=cfg.threads)
    if cfg.launcher == "slurm":
        executor.update_parameters(slurm_partition=cfg.slurm.partition, mem_gb=cfg.slurm.mem_gb,
                                   cpus_per_task=cfg.slurm.cpus_per_task)
    plain = dataclasses.asdict(cfg)
    from formation_rl.apps.tune import run_worker as worker  # by reference: this file may be running as __main__

    jobs = []
    signal.signal(signal.SIGTERM, _interrupt)  # a kill of this command stops its local workers too
    # Ctrl-C raises here, and the workers inherit a SIGINT they act on (submitit cancels local jobs with it):
    # a command started in the background by a shell inherits SIGINT ignored, and so would its workers
    signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        jobs += [executor.submit(worker, plain, k) for k in range(cfg.workers)]
        for job in jobs:
            try:
                job.result()
            except Exception as err:  # noqa: BLE001  (a worker's failure is reported, the others keep their trials)
                print(f"worker {job.job_id} failed: {str(err).splitlines()[-1] if str(err) else type(err).__name__} "
                      f"(log: {folder})", file=sys.stderr)
    except KeyboardInterrupt:
        if cfg.launcher == "local":  # SLURM jobs run on without this process, as cluster jobs do
            for job in jobs:
                job.cancel(check=False)
        print(f"stopped: the study in {storage_url(cfg)} keeps its finished trials; run the same command to "
              "resume", file=sys.stderr, flush=True)
        sys.stdout.flush()
        os._exit(130)  # no interpreter shutdown: submitit's job objects clean up in __del__, which fails there
    del jobs  # submitit's jobs clean up in __del__, which fails at interpreter exit
    text = summary(load_study(cfg))
    path = Path(cfg.out) / cfg.study / "summary.md"
    path.write_text(text)
    print(text)
    print(f"summary: {path}")


def _interrupt(signum, frame) -> None:
    raise KeyboardInterrupt


def _first(spec: dict) -> Any:
    return spec["choices"][0] if spec["type"] == "categorical" else spec["low"]


if __name__ == "__main__":
    main()

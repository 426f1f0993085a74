"""Shared test helpers: a plain module, importable because tests/conftest.py puts tests/ on sys.path."""

import subprocess
import sys
from pathlib import Path

from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

from formation_rl.envs import EnvConfig
from formation_rl.training.config import TrainConfig

ROOT = Path(__file__).resolve().parents[1]


def run_module(module: str, *args: str) -> subprocess.CompletedProcess:
    """``python -m module args...`` from the repository root, output captured (a command test's call)."""
    return subprocess.run([sys.executable, "-m", module, *args], cwd=ROOT, capture_output=True, text=True,
                          timeout=600)


def tiny(algo="per_matd3", frames=2400, **kw) -> TrainConfig:
    cfg = TrainConfig(env=EnvConfig(num_robots=3, num_obstacles=1, max_steps=20), total_frames=frames, num_envs=8,
                      steps_per_batch=20, eval_interval=1600, eval_episodes=4, checkpoint_interval=1600,
                      progress=False, **kw)
    cfg.algo.name = algo
    if algo == "maddpg":
        cfg.algo.num_critics, cfg.algo.policy_delay, cfg.algo.policy_noise, cfg.algo.prioritized = 1, 1, 0.0, False
    if algo == "matd3":
        cfg.algo.prioritized = False
    cfg.algo.batch_size, cfg.algo.warmup_frames, cfg.algo.update_every = 64, 320, 20
    cfg.model.hidden = [32, 32]
    return cfg


def scalars(run_dir: Path) -> dict[str, list]:
    """Every scalar of a run, over all its event files (a resumed run adds one)."""
    out: dict[str, list] = {}
    for events in sorted((run_dir / "tb").glob("events*")):
        ea = EventAccumulator(str(events))
        ea.Reload()
        for tag in ea.Tags()["scalars"]:
            out.setdefault(tag, []).extend((e.step, e.value) for e in ea.Scalars(tag))
    return out

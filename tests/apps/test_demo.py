"""The main job until training lands: `python -m formation_rl.apps.demo` (Hydra)."""

import json
import subprocess
import sys
from pathlib import Path

from formation_rl.apps.demo import RolloutConfig, run
from formation_rl.envs import EnvConfig

ROOT = Path(__file__).resolve().parents[2]


def test_run_writes_metrics_and_gif(tmp_path):
    cfg = RolloutConfig(env=EnvConfig(max_steps=8), num_envs=3, episodes=2)
    metrics = run(cfg, tmp_path)
    saved = json.loads((tmp_path / "metrics.json").read_text())
    assert saved == metrics and saved["length"] == 8.0
    assert set(saved) >= {"episode_reward", "CBRS", "CBRO", "UDBLT", "RFSE", "success"}
    assert (tmp_path / "rollout.gif").stat().st_size > 0


def _cli(*args, cwd=ROOT):
    return subprocess.run([sys.executable, "-m", "formation_rl.apps.demo", *args], cwd=cwd, capture_output=True,
                          text=True, timeout=300)


def test_cli_end_to_end(tmp_path):
    out = _cli("num_envs=2", "env.max_steps=5", "gif=false", f"hydra.run.dir={tmp_path}")
    assert out.returncode == 0, out.stderr
    assert "CBRO" in out.stdout and (tmp_path / "metrics.json").exists()
    assert "CBRO" in (tmp_path / "rollout.log").read_text()  # the job's log holds its summary


def test_cli_bad_input_fails_before_work(tmp_path):
    out = _cli("env.num_robots=1", f"hydra.run.dir={tmp_path}")
    assert out.returncode == 2 and out.stderr.strip() == "error: env.num_robots = 1 is invalid: must be an integer >= 2"
    assert not (tmp_path / "metrics.json").exists()
    out = _cli("num_env=2", f"hydra.run.dir={tmp_path}")
    assert out.returncode != 0 and "num_env" in out.stderr

"""A regular (non-editable) install works: the wheel carries the Hydra configs, and its apps train and
evaluate from another directory, importing the installed copy, not this checkout."""

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TINY = ["algo=maddpg", "total_frames=1000", "num_envs=4", "steps_per_batch=25", "algo.warmup_frames=200",
        "algo.batch_size=32", "eval_episodes=2", "env.max_steps=25", "model.hidden=[16,16]", "progress=false"]


def _run(args, cwd, env=None, timeout=300):
    out = subprocess.run(args, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
    assert out.returncode == 0, (out.stdout[-2000:], out.stderr[-3000:])
    return out


def test_wheel_installs_and_its_apps_train_and_evaluate(tmp_path):
    src = tmp_path / "src"  # a copy: the build writes build/ and *.egg-info beside the sources
    src.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(ROOT / name, src / name)
    shutil.copytree(ROOT / "formation_rl", src / "formation_rl", ignore=shutil.ignore_patterns("__pycache__"))
    pip_env = {**os.environ, "PIP_DISABLE_PIP_VERSION_CHECK": "1", "PIP_NO_INPUT": "1"}
    pip = [sys.executable, "-m", "pip"]
    _run([*pip, "wheel", "--no-deps", "--no-build-isolation", "--no-index", "--no-cache-dir", "-q",
          "-w", str(tmp_path / "dist"), "."], cwd=src, env=pip_env)
    (wheel,) = (tmp_path / "dist").glob("formation_rl-*.whl")
    site = tmp_path / "site"
    _run([*pip, "install", "--no-deps", "--no-index", "--no-cache-dir", "-q", "--target", str(site), str(wheel)],
         cwd=tmp_path, env=pip_env)
    assert len(list((site / "formation_rl" / "conf").rglob("*.yaml"))) == len(
        list((ROOT / "formation_rl" / "conf").rglob("*.yaml")))

    work = tmp_path / "work"  # neither the checkout nor the install: only PYTHONPATH finds the package
    work.mkdir()
    env = {**os.environ, "PYTHONPATH": str(site)}
    where = _run([sys.executable, "-c", "import formation_rl; print(formation_rl.__file__)"], cwd=work, env=env)
    assert Path(where.stdout.strip()).resolve().is_relative_to(site.resolve()), where.stdout

    run = work / "run"
    out = _run([sys.executable, "-m", "formation_rl.apps.train", *TINY, f"hydra.run.dir={run}"], cwd=work, env=env)
    assert "final evaluation" in out.stdout and (run / "checkpoints" / "policy.pt").is_file()
    _run([sys.executable, "-m", "formation_rl.apps.evaluate", f"ckpt={run}", "episodes=4", "num_envs=4",
          f"out={work / 'eval'}"], cwd=work, env=env)
    metrics = json.loads((work / "eval" / "metrics.json").read_text())
    assert metrics["eval"]["episodes"] == 4 and metrics["length"] == 25

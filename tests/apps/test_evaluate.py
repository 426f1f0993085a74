"""formation_rl.apps.evaluate (and render, demo where they share it): files, overrides, one-line errors, where
outputs go."""

import csv
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import torch
from helpers import run_module as _cli

ROOT = Path(__file__).resolve().parents[2]


def test_eval_cli_writes_json_and_csv(trained, tmp_path):
    out = _cli("formation_rl.apps.evaluate", f"ckpt={trained}", "episodes=12", "num_envs=5", f"out={tmp_path}")
    assert out.returncode == 0, out.stderr[-2000:]
    js = json.loads((tmp_path / "metrics.json").read_text())
    assert js["eval"]["episodes"] == 12 and js["eval"]["env"]["num_robots"] == 3 and js["length"] == 20
    rows = {r["metric"]: r for r in csv.DictReader((tmp_path / "metrics.csv").open())}
    assert float(rows["CBRO"]["mean"]) == pytest.approx(js["CBRO"]) and "success" in rows
    assert "95% CI" in out.stdout
    # overrides change the world; a world the policy cannot read is one clear error
    out = _cli("formation_rl.apps.evaluate", f"ckpt={trained}", "episodes=3", "env.max_steps=7", f"out={tmp_path}")
    assert out.returncode == 0 and json.loads((tmp_path / "metrics.json").read_text())["length"] == 7
    out = _cli("formation_rl.apps.evaluate", f"ckpt={trained}", "env.num_robots=4", f"out={tmp_path}/x")
    assert out.returncode == 2 and "env.num_robots = 4 is invalid: the policy was trained with 3 robots" in out.stderr
    out = _cli("formation_rl.apps.evaluate", "ckpt=/nonexistent/run")
    assert out.returncode == 2 and "ckpt = '/nonexistent/run' is invalid" in out.stderr


@pytest.mark.parametrize("module, args", [("formation_rl.apps.evaluate", ["ckpt=apf", "episodes=1", "out={out}"]),
                                          ("formation_rl.apps.render", ["ckpt=apf", "out={out}"]),
                                          ("formation_rl.apps.demo", [])])
def test_unavailable_device_is_one_line_error_before_any_work(module, args, tmp_path):
    """`make eval|render|demo ARGS="device=cuda"` without the GPU: the one-line error training gives, no traceback."""
    args = [a.format(out=tmp_path / "out") for a in args]
    out = _cli(module, *args, "device=cuda:99", f"hydra.run.dir={tmp_path}/run")
    assert out.returncode == 2 and len(out.stderr.strip().splitlines()) == 1, out.stderr[-2000:]
    assert out.stderr.startswith("error: device = 'cuda:99' is invalid: must be cpu")
    assert not (tmp_path / "out").exists() and not (tmp_path / "run").exists()


def test_device_check_is_the_one_of_training(monkeypatch):
    from formation_rl.apps.cli import check_device
    from formation_rl.training.config import TrainConfig, validate

    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    message = "device = 'cuda' is invalid: must be cpu here: CUDA is not available on this machine"
    with pytest.raises(ValueError, match=f"^{message}$"):
        check_device("cuda")
    with pytest.raises(ValueError, match=f"^{message}$"):
        validate(TrainConfig(device="cuda"))
    with pytest.raises(ValueError, match=r"^device = 'gpu' is invalid: must be cpu, cuda or cuda:<index>$"):
        check_device("gpu")
    check_device("cpu")


def _cli_in(cwd, module, *args):
    """The command run from another directory (a user's project), importing this checkout."""
    return subprocess.run([sys.executable, "-m", module, *args], cwd=cwd, capture_output=True, text=True,
                          timeout=600, env={**os.environ, "PYTHONPATH": str(ROOT)})


def test_eval_and_render_write_under_outputs_never_beside_the_checkpoint(tmp_path):
    """`make eval|render CKPT=pretrained/...` wrote into pretrained/ (both the same metrics.json): now
    outputs/eval/<name> and outputs/render/<name>, titled with what the policy is."""
    shipped = tmp_path / "pretrained"
    shipped.mkdir()
    shutil.copy(ROOT / "pretrained" / "per_matd3_fast.pt", shipped / "fast.pt")
    out = _cli_in(tmp_path, "formation_rl.apps.evaluate", "ckpt=pretrained/fast.pt", "episodes=2", "num_envs=2")
    assert out.returncode == 0, out.stderr[-2000:]
    assert "per_matd3 residual=apf on 2 held-out episodes" in out.stdout
    assert json.loads((tmp_path / "outputs/eval/fast/metrics.json").read_text())["eval"]["policy"] == \
        "per_matd3 residual=apf"
    out = _cli_in(tmp_path, "formation_rl.apps.render", "ckpt=pretrained/fast.pt", "gif=false", "steps=[10]")
    assert out.returncode == 0, out.stderr[-2000:]
    assert (tmp_path / "outputs/render/fast/trajectories.png").is_file()
    assert [p.name for p in shipped.iterdir()] == ["fast.pt"]
    # and no empty timestamped Hydra directory beside them
    assert sorted(str(p.relative_to(tmp_path)) for p in (tmp_path / "outputs").rglob("*") if p.is_dir()) == \
        ["outputs/eval", "outputs/eval/fast", "outputs/render", "outputs/render/fast"]

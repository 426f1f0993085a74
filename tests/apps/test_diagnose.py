"""formation_rl.apps.diagnose (`make diagnose`): success split into its parts, first collisions timed."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from formation_rl.apps import diagnose
from formation_rl.envs import EnvConfig
from formation_rl.evaluation.diagnose import failure_metrics
from formation_rl.evaluation.evaluate import evaluate_policy
from formation_rl.evaluation.policy import load_policy

ROOT = Path(__file__).resolve().parents[2]


def test_diagnose_splits_success_and_times_collisions(tmp_path):
    rows, written = diagnose.run(diagnose.DiagnoseConfig(ckpt="apf", episodes=40, out=str(tmp_path)))
    b = json.loads((tmp_path / "failures.json").read_text())["controllers"]["apf"]
    assert b == rows["apf"] and written == [tmp_path / n for n in ("failures.json", "first_collision.png",
                                                                    "formation_error.png")]
    per = evaluate_policy(load_policy("apf").module, EnvConfig(), 40, progress=False, metrics=failure_metrics)
    assert b["success"] == pytest.approx(per["success"].mean().item())
    assert b["success"] <= min(b["at_goal"], b["no_robot_collision"], b["no_obstacle_collision"])
    windows = sum(v for k, v in b.items() if k.startswith("first_robot_collision_"))
    assert windows + b["no_robot_collision"] == pytest.approx(1.0)  # every collided episode falls in one window
    assert (per["first_robot_collision"] == 0).tolist() == (per["CBRS"] == 0).tolist()
    assert (per["last_robot_collision"] >= per["first_robot_collision"]).all()
    assert (tmp_path / "first_collision.png").stat().st_size > 0 and "at the goal" in diagnose.format_rows("apf", b)
    # the per-step curves behind formation_error.png: RFSE is the formation error's mean over steps
    assert per["formation_error_per_step"].shape == (40, 150) and (tmp_path / "formation_error.png").stat().st_size
    assert per["formation_error_per_step"].mean(1) == pytest.approx(per["RFSE"], rel=1e-5)
    assert per["in_area_per_step"].mean(1).tolist() == per["leader_in_area_steps"].tolist()
    assert b["leader_enters_area"] == pytest.approx((per["leader_in_area_steps"] > 0).double().mean().item())
    assert b["leader_enters_area"] > 0.5  # the controller takes its leader through the area


def test_bad_input_is_one_error_before_any_rollout(tmp_path):
    with pytest.raises(ValueError, match=r"^episodes = 0 is invalid: must be an integer >= 1$"):
        diagnose.run(diagnose.DiagnoseConfig(ckpt="apf", episodes=0, out=str(tmp_path / "x")))
    with pytest.raises(ValueError, match=r"^ckpt = '.*missing' is invalid: no policy.pt at"):
        diagnose.run(diagnose.DiagnoseConfig(ckpt=["apf", str(tmp_path / "missing")], out=str(tmp_path / "x")))
    with pytest.raises(ValueError, match=r"^ckpt = None is invalid: must be a policy.pt, last.pt, run directory"):
        diagnose.run(diagnose.DiagnoseConfig(out=str(tmp_path / "x")))
    assert not (tmp_path / "x").exists()


def test_cli_diagnoses_a_list_of_controllers_and_leaves_no_hydra_directory(tmp_path):
    """The list form `make diagnose` passes (ckpt=[...]); the command writes only into `out`."""
    out = subprocess.run([sys.executable, "-m", "formation_rl.apps.diagnose", "ckpt=[apf]", "episodes=4", "out=d"],
                         cwd=tmp_path, capture_output=True, text=True, timeout=300,
                         env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.startswith("apf\n  success ")
    assert "wrote d/failures.json, d/first_collision.png, d/formation_error.png" in out.stdout
    assert [p.name for p in tmp_path.iterdir()] == ["d"]

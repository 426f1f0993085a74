"""make tune: an Optuna study over the training recipe, stored in SQLite, scored on validation scenarios."""

import subprocess
import sys
from pathlib import Path

import optuna
import pytest

from formation_rl.apps.tune import check_space, score

ROOT = Path(__file__).resolve().parents[2]
TINY = ('base=["total_frames=1600","eval_interval=800","checkpoint_interval=1600","eval_episodes=4",'
        '"algo.warmup_frames=400","algo.batch_size=32","num_envs=8","env.max_steps=20","model.hidden=[16,16]"]')


def _tune(*args):
    return subprocess.run([sys.executable, "-m", "formation_rl.apps.tune", *args], cwd=ROOT, capture_output=True,
                          text=True, timeout=600)


def test_score_ranks_success_first_then_the_tie_breakers():
    base = {"success": 0.3, "at_goal": 0.5, "RFSE": 2.0, "UDBLT": 1.0}
    assert score({**base, "success": 0.61}) > score({**base, "at_goal": 1.0, "RFSE": 0.0, "UDBLT": 0.0})
    assert score({**base, "at_goal": 0.6}) > score(base) > score({**base, "RFSE": 3.0}) > score({**base, "RFSE": 3.0,
                                                                                              "UDBLT": 2.0})
    assert score({**base, "RFSE": 50.0, "UDBLT": 20.0}) == score({**base, "RFSE": 10.0, "UDBLT": 10.0})  # capped


def test_space_errors_name_the_key():
    with pytest.raises(ValueError, match=r"^space.algo.gamma.type = 'uniform' is invalid"):
        check_space({"algo.gamma": {"type": "uniform", "low": 0.9, "high": 0.99}})
    with pytest.raises(ValueError, match=r"^space.algo.tau = .* must have numbers low < high"):
        check_space({"algo.tau": {"type": "float", "low": 0.1, "high": 0.01}})


def test_study_runs_two_workers_resumes_and_writes_a_summary(tmp_path):
    """Two local submitit workers share one SQLite study; running again adds trials to the same study."""
    out = _tune(f"out={tmp_path}", "trials=2", "workers=2", TINY)
    assert out.returncode == 0, out.stderr[-2000:]
    study = optuna.load_study(study_name="recipe", storage=f"sqlite:///{tmp_path}/recipe.db")
    done = [t for t in study.trials if t.state == optuna.trial.TrialState.COMPLETE]
    assert len(done) >= 2 and all(0 <= t.user_attrs["success"] <= 1 for t in done)
    assert done[0].params != done[1].params  # the workers' samplers are seeded apart
    assert all(Path(t.user_attrs["run_dir"], "metrics.json").is_file() for t in done)
    summary = (tmp_path / "recipe" / "summary.md").read_text()
    assert "| # | score |" in summary and "Best parameters" in summary
    again = _tune(f"out={tmp_path}", "trials=3", "workers=1", TINY)
    assert again.returncode == 0, again.stderr[-2000:]
    assert len(optuna.load_study(study_name="recipe", storage=f"sqlite:///{tmp_path}/recipe.db").trials) >= 3


def test_bad_input_is_one_line_before_any_trial(tmp_path):
    bad = _tune(f"out={tmp_path}", "launcher=cloud")
    assert bad.returncode == 2 and bad.stderr.strip().endswith("launcher = 'cloud' is invalid: must be local or slurm")
    bad = _tune(f"out={tmp_path}", "prune_after=-1")
    assert bad.returncode == 2 and bad.stderr.strip().endswith("prune_after = -1 is invalid: must be an integer >= 0 "
                                                               "(frames)")
    bad = _tune(f"out={tmp_path}", 'base=["algo.tau=2"]')
    assert bad.returncode == 2 and "algo.tau = 2.0 is invalid" in bad.stderr
    assert list(tmp_path.iterdir()) == []  # nothing written


def test_stopping_the_command_stops_its_local_workers(tmp_path):
    """SIGTERM (or Ctrl-C) on `make tune` cancels its local submitit workers: none keeps training alone."""
    import os
    import signal
    import time

    # output to files, not pipes: submitit's local controller inherits them, so a pipe stays open until the
    # worker is gone, and reading it to the end would wait for the worker, not for the command
    log = (tmp_path / "out.txt").open("w")
    proc = subprocess.Popen([sys.executable, "-m", "formation_rl.apps.tune", f"out={tmp_path}", "trials=50",
                             "workers=1", TINY.replace("total_frames=1600", "total_frames=400000")], cwd=ROOT,
                            stdout=log, stderr=subprocess.STDOUT, text=True)
    pid_file = None
    for _ in range(600):  # until the worker has started (its submitit files appear; slow on a loaded machine)
        time.sleep(0.5)
        started = list((tmp_path / "recipe" / "workers").glob("*_0_log.out")) if (tmp_path / "recipe").exists() else []
        if started or proc.poll() is not None:
            pid_file = started[0] if started else None
            break
    if pid_file is None:
        proc.kill()
        proc.wait(timeout=60)
        raise AssertionError(f"no worker started in 300 s: {(tmp_path / 'out.txt').read_text()}")
    worker_id = int(pid_file.name.split("_")[0])
    proc.send_signal(signal.SIGTERM)
    assert proc.wait(timeout=60) == 130
    log.close()
    assert "run the same command to resume" in (tmp_path / "out.txt").read_text()
    for _ in range(240):  # the worker gets SIGINT and stops (up to a minute on a loaded machine)
        try:
            os.kill(worker_id, 0)
        except ProcessLookupError:
            break
        time.sleep(0.25)
    else:
        raise AssertionError(f"worker {worker_id} still running after the command stopped")

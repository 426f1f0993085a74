"""Evaluation (SPEC §6 protocol), rendering and the report: numbers, files, errors."""

import csv
import json
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import torch
import yaml
from test_train import tiny
from torch.utils.tensorboard import SummaryWriter

from formation_rl.apps import diagnose, report
from formation_rl.envs import EnvConfig, FormationEnv
from formation_rl.envs.metrics import episode_metrics
from formation_rl.evaluation.evaluate import evaluate_policy, mean_ci
from formation_rl.evaluation.policy import load_policy, output_dir
from formation_rl.training.trainer import Trainer

ROOT = Path(__file__).resolve().parents[1]


def scripted(td):
    """A hand-made controller: every robot pushes towards the goal's quadrant, +x +y."""
    td.set(("agents", "action"), torch.full(td["agents", "observation"].shape[:-1] + (2,), 0.5))
    return td


def test_mean_ci_on_known_numbers():
    mean, ci = mean_ci(torch.tensor([1.0, 2.0, 3.0, 4.0, 5.0]))
    assert mean == 3.0 and ci == pytest.approx(2.776 * math.sqrt(2.5) / math.sqrt(5), abs=1e-9)
    mean, ci = mean_ci(torch.ones(100) * 2)
    assert (mean, ci) == (2.0, 0.0)
    assert math.isnan(mean_ci(torch.tensor([1.0]))[1])


def test_evaluation_equals_the_metrics_module_on_the_same_rollouts():
    cfg = EnvConfig(max_steps=30)
    per_episode = evaluate_policy(scripted, cfg, episodes=8, num_envs=4, seed=11, progress=False)
    env = FormationEnv(4, config=cfg, seed=11)
    rollouts = [env.rollout(30, scripted, break_when_any_done=False) for _ in range(2)]
    expected = [episode_metrics(r, cfg.goal_radius) for r in rollouts]
    for k, v in per_episode.items():
        torch.testing.assert_close(v, torch.cat([e[k] for e in expected]))
    assert per_episode["CBRO"].shape == (8,)


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    run = tmp_path_factory.mktemp("run")
    Trainer(tiny("per_matd3", frames=800), run).train()
    return run


def _cli(module, *args):
    return subprocess.run([sys.executable, "-m", module, *args], cwd=ROOT, capture_output=True, text=True,
                          timeout=600)


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


def test_render_cli_writes_gif_and_figure_10(trained, tmp_path):
    out = _cli("formation_rl.apps.render", f"ckpt={trained}", "steps=[2,10,19]", f"out={tmp_path}")
    assert out.returncode == 0, out.stderr[-2000:]
    assert (tmp_path / "trajectories.png").stat().st_size > 10_000 and (tmp_path / "episode.gif").exists()
    out = _cli("formation_rl.apps.render", f"ckpt={trained}", "steps=[500]", f"out={tmp_path}")
    assert out.returncode == 2 and "steps = [500] is invalid" in out.stderr


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


def test_default_output_directory_names_the_checkpoint_or_run(tmp_path):
    run = tmp_path / "2026-01-01_00-00-00_seed0"
    (run / "checkpoints").mkdir(parents=True)
    (run / "checkpoints" / "policy.pt").touch()
    assert output_dir("eval", run) == Path("outputs/eval/2026-01-01_00-00-00_seed0")
    assert output_dir("render", run / "checkpoints" / "last.pt") == Path("outputs/render/2026-01-01_00-00-00_seed0")
    assert output_dir("eval", ROOT / "pretrained" / "per_matd3.pt") == Path("outputs/eval/per_matd3")
    assert output_dir("render", "apf") == Path("outputs/render/apf")


def synthetic_run(root: Path, algo: str, seed: int, final: dict, slope: float) -> Path:
    run = root / f"{algo}_seed{seed}"
    (run / ".hydra").mkdir(parents=True)
    (run / ".hydra" / "config.yaml").write_text(yaml.safe_dump({"algo": {"name": algo}, "seed": seed,
                                                                "env": {"num_robots": 5}}))
    w = SummaryWriter(str(run / "tb"))
    for k in range(10):
        frames = 1500 * (k + 1)
        w.add_scalar("perf/episodes", 10 * (k + 1), frames)
        for tag in ("episode_reward", "CBRS", "CBRO", "UDBLT", "RFSE"):
            w.add_scalar(f"train/{tag}", slope * k, frames)
    w.close()
    (run / "metrics.json").write_text(json.dumps(final))
    return run


def test_report_on_two_synthetic_runs(tmp_path):
    base = {"episode_reward": -100.0, "CBRS": 1.0, "CBRO": 2.0, "UDBLT": 0.1, "RFSE": 0.5, "success": 0.5}
    synthetic_run(tmp_path, "matd3", 0, base, 1.0)
    synthetic_run(tmp_path, "matd3", 1, {**base, "CBRO": 4.0, "success": 1.0}, 2.0)
    assert report.main([str(tmp_path), "--smooth", "0"]) == 0
    for name in report.FIGURES:
        assert (tmp_path / name).stat().st_size > 5_000
    rows = list(csv.DictReader((tmp_path / "table1.csv").open()))
    assert len(rows) == 1 and rows[0]["group"] == "matd3" and rows[0]["seeds"] == "2"
    assert float(rows[0]["CBRO"]) == pytest.approx(3.0) and float(rows[0]["success"]) == pytest.approx(0.75)
    assert float(rows[0]["CBRO_ci95"]) == pytest.approx(12.706 * math.sqrt(2.0) / math.sqrt(2), rel=1e-6)
    assert float(rows[0]["paper_CBRO"]) == 4.29
    assert "| matd3 | 2 |" in (tmp_path / "table1.md").read_text()


def test_report_time_to_quality(tmp_path):
    run = synthetic_run(tmp_path, "per_matd3", 0, {"success": 0.2}, 1.0)
    w = SummaryWriter(str(run / "tb"), filename_suffix=".eval")
    # evaluations at 0, 1000, 2000, 3000 frames, 60 s apart: UDBLT <= 0.08 first at 2000, 10% success at 3000
    for k, (udblt, success) in enumerate([(5.0, 0.0), (0.5, 0.0), (0.07, 0.05), (0.06, 0.2)]):
        for tag, v in (("UDBLT", udblt), ("success", success), ("CBRO", 1.0), ("RFSE", 3.0)):
            w.add_scalar(f"eval/{tag}", v, 1000 * k, walltime=1000.0 + 60 * k)
    w.close()
    loaded = report.load_run(run)
    assert report.time_to_quality(loaded) == {"UDBLT <= 0.08 m": (2000, pytest.approx(120.0, abs=0.1)),
                                              "success >= 10%": (3000, pytest.approx(180.0, abs=0.1)),
                                              "paper PER-MATD3 row + 90% success": None}
    assert report.main([str(tmp_path)]) == 0
    md = (tmp_path / "time_to_quality.md").read_text()
    assert "| per_matd3 | per_matd3_seed0 | 2,000 frames, 2.0 min | 3,000 frames, 3.0 min | not reached |" in md
    assert (tmp_path / "time_to_quality.png").stat().st_size > 5_000


def test_report_keeps_two_evaluations_at_one_frame_count(tmp_path):
    """actor_init=apf evaluates at frame 0 twice (untrained, then cloned): each keeps its own time."""
    run = synthetic_run(tmp_path, "per_matd3", 0, {"success": 0.2}, 1.0)
    w = SummaryWriter(str(run / "tb"), filename_suffix=".eval")
    for frames, wall, success in ((0, 1000.0, 0.0), (0, 1240.0, 0.21), (1000, 1300.0, 0.25)):
        for tag, v in (("UDBLT", 0.05), ("success", success), ("CBRO", 1.0), ("RFSE", 3.0)):
            w.add_scalar(f"eval/{tag}", v, frames, walltime=wall)
    w.close()
    loaded = report.load_run(run)
    assert [(f, round(t), round(m["success"], 2)) for f, t, m in loaded.evals] == [(0, 0, 0.0), (0, 240, 0.21),
                                                                                (1000, 300, 0.25)]
    assert report.time_to_quality(loaded)["success >= 10%"] == (0, pytest.approx(240.0, abs=0.1))


def evaluation_dir(root: Path, name: str, algo: str, variant: str, final: dict) -> Path:
    """What ``make eval ... ARGS="out=DIR"`` leaves: metrics.json recording what it evaluated."""
    out = root / name
    out.mkdir(parents=True)
    record = {"ckpt": f"outputs/train/{name}/checkpoints/policy.pt", "algo": algo, "episodes": 1000,
              "env": {"num_robots": 5, "reward": {"variant": variant}}}
    (out / "metrics.json").write_text(json.dumps({**final, "ci95": {}, "eval": record}))
    return out


def test_report_table_from_evaluation_directories(tmp_path):
    """Table 1 rebuilt from kept metrics.json files once the training runs' tb/ are gone."""
    base = {"episode_reward": -100.0, "CBRS": 1.0, "CBRO": 2.0, "UDBLT": 0.1, "RFSE": 0.5, "success": 0.5}
    results = tmp_path / "results"
    evaluation_dir(results, "per_matd3_seed0", "per_matd3", "hybrid", base)
    evaluation_dir(results, "per_matd3_seed1", "per_matd3", "hybrid", {**base, "CBRO": 1.0})
    evaluation_dir(results, "per_matd3_fixed_seed0", "per_matd3", "fixed", {**base, "CBRO": 5.0})
    figures = tmp_path / "figures"
    assert report.main([str(results), "--out", str(figures)]) == 0
    rows = {r["group"]: r for r in csv.DictReader((figures / "table1.csv").open())}
    assert rows["per_matd3"]["seeds"] == "3" and float(rows["per_matd3"]["CBRO"]) == pytest.approx(8 / 3)
    assert not list(figures.glob("*.png")) and not (figures / "time_to_quality.md").exists()
    assert report.main([str(results), "--by", "env.reward.variant", "--out", str(figures)]) == 0
    rows = {r["group"]: r for r in csv.DictReader((figures / "table1.csv").open())}
    assert float(rows["hybrid"]["CBRO"]) == pytest.approx(1.5) and rows["fixed"]["seeds"] == "1"
    # the evaluation kept inside a training run is that run's final, not a second run
    run = synthetic_run(tmp_path / "runs", "matd3", 0, base, 1.0)
    evaluation_dir(run, "checkpoints", "matd3", "hybrid", {**base, "CBRO": 9.0})
    assert report.main([str(tmp_path / "runs")]) == 0
    rows = list(csv.DictReader((tmp_path / "runs" / "table1.csv").open()))
    assert len(rows) == 1 and rows[0]["seeds"] == "1" and float(rows[0]["CBRO"]) == pytest.approx(9.0)
    # so is make eval's default outputs/eval/<run>, which records the run's checkpoint
    other = synthetic_run(tmp_path / "runs2", "matd3", 0, base, 1.0)
    kept = evaluation_dir(tmp_path / "eval", other.name, "matd3", "hybrid", {**base, "CBRO": 7.0})
    record = json.loads((kept / "metrics.json").read_text())
    record["eval"]["ckpt"] = str(other / "checkpoints" / "policy.pt")
    (kept / "metrics.json").write_text(json.dumps(record))
    assert report.main([str(tmp_path / "runs2"), str(tmp_path / "eval"), "--out", str(figures)]) == 0
    rows = list(csv.DictReader((figures / "table1.csv").open()))
    assert len(rows) == 1 and rows[0]["seeds"] == "1" and float(rows[0]["CBRO"]) == pytest.approx(7.0)


@pytest.mark.skipif(shutil.which("make") is None, reason="no make")
def test_make_tensorboard_passes_args():
    """`make tensorboard ARGS="--port 6100"` ignored ARGS."""
    out = subprocess.run(["make", "-n", "tensorboard", "RUNS=outputs/train", "ARGS=--port 6100"], cwd=ROOT,
                         capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert any(line.endswith("/bin/tensorboard --logdir outputs/train --port 6100") for line in out.stdout.splitlines())


def test_report_names_groups_of_numbers_and_flags_by_their_key():
    run = report.Run(Path("r"), {"algo": {"name": "matd3", "batch_size": 256}, "env": {"relative_positions": True}})
    assert report.group_key(run, "algo.name") == "matd3"
    assert report.group_key(run, "algo.batch_size") == "batch_size=256"
    assert report.group_key(run, "env.relative_positions") == "relative_positions=True"


def test_report_errors(tmp_path, capsys):
    assert report.main([str(tmp_path)]) == 2
    assert "no training run" in capsys.readouterr().err
    assert report.main([str(tmp_path / "missing")]) == 2
    assert "does not exist" in capsys.readouterr().err


@pytest.mark.parametrize("launcher", ["local", "slurm_local"])
def test_two_job_multirun(tmp_path, launcher):
    out = _cli("formation_rl.apps.train", "-m", f"hydra/launcher={launcher}", f"hydra.sweep.dir={tmp_path}",
               "algo=maddpg,matd3", "total_frames=400", "num_envs=4", "steps_per_batch=20",
               "algo.warmup_frames=160", "algo.batch_size=32", "eval_episodes=2", "env.max_steps=20",
               "model.hidden=[16,16]", "threads=1", "progress=false")
    assert out.returncode == 0, out.stderr[-3000:]
    for algo in ("maddpg", "matd3"):
        assert (tmp_path / f"{algo}_seed0" / "metrics.json").is_file()
        assert list((tmp_path / f"{algo}_seed0" / "tb").glob("events*"))


def test_report_rejects_mixed_team_sizes_and_runs_without_curves(tmp_path, capsys):
    base = {"episode_reward": -1.0, "CBRS": 0.0, "CBRO": 0.0, "UDBLT": 0.0, "RFSE": 0.0, "success": 0.0}
    run = synthetic_run(tmp_path / "a", "matd3", 0, base, 1.0)
    other = synthetic_run(tmp_path / "a", "matd3", 1, base, 1.0)
    cfg = yaml.safe_load((other / ".hydra" / "config.yaml").read_text())
    cfg["env"]["num_robots"] = 7
    (other / ".hydra" / "config.yaml").write_text(yaml.safe_dump(cfg))
    assert report.main([str(tmp_path / "a")]) == 2
    assert "runs mix team sizes [5, 7]" in capsys.readouterr().err
    for f in (run / "tb").glob("events*"):
        f.unlink()
    assert report.main([str(run)]) == 2
    assert "has train/* curves" in capsys.readouterr().err


def test_corrupt_or_foreign_checkpoint_is_one_clear_error(tmp_path):
    from formation_rl.evaluation.policy import load_policy

    (tmp_path / "policy.pt").write_bytes(b"\x00garbage")
    with pytest.raises(ValueError, match="cannot be read .*: it is truncated or corrupt"):
        load_policy(tmp_path)
    torch.save({"format": 99, "version": "9.9"}, tmp_path / "policy.pt")
    with pytest.raises(ValueError, match=r"has format 99 \(formation_rl 9.9\); this formation_rl .* reads format 1"):
        load_policy(tmp_path)


def test_first_and_last_collision_steps():
    flags = torch.tensor([[False, True, False, True, False], [False] * 5, [True, False, False, False, False]])
    assert diagnose.first_step(flags).tolist() == [2, 0, 1]
    assert diagnose.last_step(flags).tolist() == [4, 0, 1]


def test_diagnose_splits_success_and_times_collisions(tmp_path, capsys):
    assert diagnose.main(["apf", "--episodes", "40", "--out", str(tmp_path)]) == 0
    b = json.loads((tmp_path / "failures.json").read_text())["controllers"]["apf"]
    per = evaluate_policy(load_policy("apf").module, EnvConfig(), 40, progress=False, metrics=diagnose.failure_metrics)
    assert b["success"] == pytest.approx(per["success"].mean().item())
    assert b["success"] <= min(b["at_goal"], b["no_robot_collision"], b["no_obstacle_collision"])
    windows = sum(v for k, v in b.items() if k.startswith("first_robot_collision_"))
    assert windows + b["no_robot_collision"] == pytest.approx(1.0)  # every collided episode falls in one window
    assert (per["first_robot_collision"] == 0).tolist() == (per["CBRS"] == 0).tolist()
    assert (per["last_robot_collision"] >= per["first_robot_collision"]).all()
    assert (tmp_path / "first_collision.png").stat().st_size > 0 and "at the goal" in capsys.readouterr().out
    assert diagnose.main(["apf", "--episodes", "0"]) == 2
    assert diagnose.main([str(tmp_path / "missing")]) == 2


def test_diagnose_finds_a_leader_pinned_at_a_wall():
    """A policy that pushes every robot east ends with the leader at the arena's edge, actions saturated."""
    from tensordict.nn import TensorDictModule

    class East(torch.nn.Module):
        def forward(self, obs):
            return torch.zeros(*obs.shape[:-1], 2).index_fill_(-1, torch.tensor([0]), 1.0)

    east = TensorDictModule(East(), in_keys=[("agents", "observation")], out_keys=[("agents", "action")])
    per = evaluate_policy(east, EnvConfig(), 8, progress=False, metrics=diagnose.failure_metrics)
    assert per["leader_at_wall"].tolist() == [1.0] * 8 and per["saturated_actions"].tolist() == [0.5] * 8
    apf = evaluate_policy(load_policy("apf").module, EnvConfig(), 8, progress=False, metrics=diagnose.failure_metrics)
    assert apf["leader_at_wall"].sum() == 0

"""formation_rl.apps.report (`make compare`): Figures 6-9, Table 1 and time to quality from runs and evaluations."""

import csv
import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest
import yaml
from torch.utils.tensorboard import SummaryWriter

from formation_rl.apps import report

ROOT = Path(__file__).resolve().parents[2]


def run_report(runs, **kw) -> list[Path]:
    return report.run(report.ReportConfig(runs=runs, **kw))


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
    run_report([str(tmp_path)], smooth=0)
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
    run_report([str(tmp_path)])
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
    run_report([str(results)], out=str(figures))
    rows = {r["group"]: r for r in csv.DictReader((figures / "table1.csv").open())}
    assert rows["per_matd3"]["seeds"] == "3" and float(rows["per_matd3"]["CBRO"]) == pytest.approx(8 / 3)
    assert not list(figures.glob("*.png")) and not (figures / "time_to_quality.md").exists()
    run_report([str(results)], by="env.reward.variant", out=str(figures))
    rows = {r["group"]: r for r in csv.DictReader((figures / "table1.csv").open())}
    assert float(rows["hybrid"]["CBRO"]) == pytest.approx(1.5) and rows["fixed"]["seeds"] == "1"
    # the evaluation kept inside a training run is that run's final, not a second run
    run = synthetic_run(tmp_path / "runs", "matd3", 0, base, 1.0)
    evaluation_dir(run, "checkpoints", "matd3", "hybrid", {**base, "CBRO": 9.0})
    run_report([str(tmp_path / "runs")])
    rows = list(csv.DictReader((tmp_path / "runs" / "table1.csv").open()))
    assert len(rows) == 1 and rows[0]["seeds"] == "1" and float(rows[0]["CBRO"]) == pytest.approx(9.0)
    # so is make eval's default outputs/eval/<run>, which records the run's checkpoint
    other = synthetic_run(tmp_path / "runs2", "matd3", 0, base, 1.0)
    kept = evaluation_dir(tmp_path / "eval", other.name, "matd3", "hybrid", {**base, "CBRO": 7.0})
    record = json.loads((kept / "metrics.json").read_text())
    record["eval"]["ckpt"] = str(other / "checkpoints" / "policy.pt")
    (kept / "metrics.json").write_text(json.dumps(record))
    run_report([str(tmp_path / "runs2"), str(tmp_path / "eval")], out=str(figures))
    rows = list(csv.DictReader((figures / "table1.csv").open()))
    assert len(rows) == 1 and rows[0]["seeds"] == "1" and float(rows[0]["CBRO"]) == pytest.approx(7.0)


def test_report_names_groups_of_numbers_and_flags_by_their_key():
    run = report.Run(Path("r"), {"algo": {"name": "matd3", "batch_size": 256}, "env": {"relative_positions": True}})
    assert report.group_key(run, "algo.name") == "matd3"
    assert report.group_key(run, "algo.batch_size") == "batch_size=256"
    assert report.group_key(run, "env.relative_positions") == "relative_positions=True"


def test_report_errors_name_the_field_before_any_work(tmp_path):
    with pytest.raises(ValueError, match=r"^runs = \[.*\] is invalid: no training run .* and no evaluation"):
        run_report([str(tmp_path)])
    with pytest.raises(ValueError, match=r"^runs = '.*missing' is invalid: no such directory$"):
        run_report([str(tmp_path / "missing")])
    with pytest.raises(ValueError, match=r"^runs = None is invalid: must be run directories"):
        run_report(None)
    with pytest.raises(ValueError, match=r"^smooth = 1.0 is invalid: must be in \[0, 1\)$"):
        run_report([str(tmp_path)], smooth=1.0)
    base = {"episode_reward": -1.0, "CBRS": 0.0, "CBRO": 0.0, "UDBLT": 0.0, "RFSE": 0.0, "success": 0.0}
    synthetic_run(tmp_path, "matd3", 0, base, 1.0)
    with pytest.raises(ValueError, match=r"^by = 'algo.lr' is invalid: run .*matd3_seed0 has no config key 'algo.lr'$"):
        run_report([str(tmp_path)], by="algo.lr")
    assert not list(tmp_path.glob("*.png")) and not list(tmp_path.glob("*.md"))


def test_report_rejects_mixed_team_sizes_and_runs_without_curves(tmp_path):
    base = {"episode_reward": -1.0, "CBRS": 0.0, "CBRO": 0.0, "UDBLT": 0.0, "RFSE": 0.0, "success": 0.0}
    run = synthetic_run(tmp_path / "a", "matd3", 0, base, 1.0)
    other = synthetic_run(tmp_path / "a", "matd3", 1, base, 1.0)
    cfg = yaml.safe_load((other / ".hydra" / "config.yaml").read_text())
    cfg["env"]["num_robots"] = 7
    (other / ".hydra" / "config.yaml").write_text(yaml.safe_dump(cfg))
    with pytest.raises(ValueError, match=r"^runs mix team sizes \[5, 7\]: compare one N at a time \(or by=env"):
        run_report([str(tmp_path / "a")])
    run_report([str(tmp_path / "a")], by="env.num_robots", out=str(tmp_path / "by_n"))
    assert {r["group"] for r in csv.DictReader((tmp_path / "by_n" / "table1.csv").open())} == {"num_robots=5",
                                                                                              "num_robots=7"}
    for f in (run / "tb").glob("events*"):
        f.unlink()
    with pytest.raises(ValueError, match="has train/\\* curves"):
        run_report([str(run)])


def test_cli_writes_the_report_and_nothing_else(tmp_path):
    """`make compare RUNS=...`: one Hydra list of directories; no Hydra directory left in the working directory."""
    base = {"episode_reward": -100.0, "CBRS": 1.0, "CBRO": 2.0, "UDBLT": 0.1, "RFSE": 0.5, "success": 0.5}
    synthetic_run(tmp_path / "runs", "matd3", 0, base, 1.0)
    synthetic_run(tmp_path / "more", "maddpg", 0, base, 1.0)
    out = subprocess.run([sys.executable, "-m", "formation_rl.apps.report", "runs=[runs,more]", "out=report"],
                         cwd=tmp_path, capture_output=True, text=True, timeout=300,
                         env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert out.returncode == 0, out.stderr[-2000:]
    assert "| matd3 | 1 |" in out.stdout and "| maddpg | 1 |" in out.stdout and "wrote report/" in out.stdout
    assert sorted(p.name for p in tmp_path.iterdir()) == ["more", "report", "runs"]

"""formation_rl.apps.ceiling: the success ceiling of the classical controller by sensing range."""

import json

import pytest

from formation_rl.apps import ceiling
from formation_rl.envs import EnvConfig
from formation_rl.evaluation.evaluate import evaluate_policy
from formation_rl.evaluation.policy import classical_policy


def test_leader_share_bounds_team_success_per_episode():
    """success => leader at goal without obstacle contact => leader at goal; a leader contact is a team contact."""
    cfg = EnvConfig()
    per = evaluate_policy(classical_policy(cfg).module, cfg, 200, 200, seed=5, progress=False,
                          metrics=ceiling.team_metrics)
    touched = per["leader_obstacle_gap"] - cfg.robot_radius < cfg.obstacle_collision_margin
    at_goal = per["UDBLT"] <= cfg.goal_radius
    leader_ok = at_goal & ~touched
    success = per["success"].bool()
    assert not (success & ~leader_ok).any() and not (touched & (per["CBRO"] == 0)).any()
    assert touched.any() and leader_ok.any()  # both kinds occur at the SPEC's 0.2 m sensing


def test_ceiling_writes_table_json_and_figure(tmp_path):
    ceiling.main(["--ranges", "0.2", "0.4", "--trials", "2", "--episodes", "20", "--held-out", "20",
                  "--out", str(tmp_path)])
    rows = json.loads((tmp_path / "ceiling.json").read_text())["rows"]
    assert [r["sensing_range"] for r in rows] == [0.2, 0.4]
    for r in rows:
        h = r["held_out"]
        assert 0 <= h["success"] <= h["leader_ok"] <= h["at_goal"] <= 1
    assert (tmp_path / "ceiling.png").stat().st_size > 0
    assert (tmp_path / "ceiling.md").read_text().count("\n") == 4


@pytest.mark.parametrize("args, field", [(["--trials", "0"], "--trials"), (["--ranges", "0.2", "-1"], "--ranges")])
def test_ceiling_bad_input_is_one_line(args, field, tmp_path, capsys):
    with pytest.raises(SystemExit) as err:
        ceiling.main([*args, "--out", str(tmp_path / "x")])
    assert field in str(err.value) and "\n" not in str(err.value)
    assert not (tmp_path / "x").exists()


def test_braking_limit_and_safe_path_time_follow_the_world():
    """The physics behind the ceiling: more sensing range, more speed that can be braked; a slower
    crossing of where obstacles may be, a longer path; at v_max the straight line."""
    spec = EnvConfig()
    axis, corner = ceiling.braking_limit(spec, corner=False), ceiling.braking_limit(spec, corner=True)
    assert 0 < axis < corner < spec.max_speed
    assert ceiling.braking_limit(EnvConfig(sensing_range=0.3), corner=False) > axis
    free = ceiling.safe_path_time(spec, spec.max_speed)
    straight = ((spec.goal_low + spec.goal_high) / 2 - (spec.start_low + spec.start_high) / 2) * 2 ** 0.5
    assert abs(free - straight / spec.max_speed) < 0.01
    assert free < ceiling.safe_path_time(spec, corner) < ceiling.safe_path_time(spec, axis)

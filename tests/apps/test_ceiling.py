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
    assert touched.any() and leader_ok.any()  # both kinds occur at the default 0.2 m sensing


def test_ceiling_writes_table_json_and_figure(tmp_path):
    cfg = ceiling.CeilingConfig(ranges=[0.2, 0.4], trials=2, episodes=20, held_out=20, out=str(tmp_path))
    written = ceiling.run(cfg)
    assert written == [tmp_path / "ceiling.json", tmp_path / "ceiling.md", tmp_path / "ceiling.png"]
    rows = json.loads((tmp_path / "ceiling.json").read_text())["rows"]
    assert [r["sensing_range"] for r in rows] == [0.2, 0.4]
    for r in rows:
        h = r["held_out"]
        assert 0 <= h["success"] <= h["leader_ok"] <= h["at_goal"] <= 1
    assert (tmp_path / "ceiling.png").stat().st_size > 0
    assert (tmp_path / "ceiling.md").read_text().count("\n") == 4


@pytest.mark.parametrize("change, message", [
    ({"trials": 0}, "trials = 0 is invalid: must be an integer >= 1"),
    ({"held_out": -3}, "held_out = -3 is invalid: must be an integer >= 1"),
    ({"ranges": [0.2, -1.0]}, "ranges = [0.2, -1.0] is invalid: must be a non-empty list of sensing ranges > 0 m"),
    ({"ranges": []}, "ranges = [] is invalid: must be a non-empty list of sensing ranges > 0 m"),
])
def test_ceiling_bad_input_is_one_error_before_any_search(change, message, tmp_path):
    with pytest.raises(ValueError) as err:
        ceiling.run(ceiling.CeilingConfig(**change, out=str(tmp_path / "x")))
    assert str(err.value) == message
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

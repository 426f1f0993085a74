"""The metrics (reference.md, Metrics) on hand-built rollouts."""

import pytest
import torch
from tensordict import TensorDict

from formation_rl.envs import FormationEnv
from formation_rl.envs.metrics import EpisodeTracker, episode_metrics, summarize


def rollout(rewards, robot, obstacle, goal_distance, formation_error, done):
    """A ``[B, T]`` rollout tensordict with only the keys the metrics read."""
    t = lambda x, dt=torch.float32: torch.tensor(x, dtype=dt).unsqueeze(-1)  # noqa: E731
    nxt = {
        ("agents", "reward"): torch.tensor(rewards, dtype=torch.float32).unsqueeze(-1),  # [B, T, N, 1]
        "robot_collision": t(robot, torch.bool),
        "obstacle_collision": t(obstacle, torch.bool),
        "goal_distance": t(goal_distance),
        "formation_error": t(formation_error),
        "done": t(done, torch.bool),
    }
    b, steps = len(done), len(done[0])
    return TensorDict({("next", *([k] if isinstance(k, str) else k)): v for k, v in nxt.items()}, batch_size=[b, steps])


def three_steps():
    # copy 0: a robot-robot collision at step 2; copy 1: clean, ends on the goal
    return rollout(
        rewards=[[[1.0, 3.0], [0.0, -2.0], [-1.0, 1.0]], [[10.0, 1.0], [10.0, 1.0], [10.0, 2.0]]],
        robot=[[False, True, False], [False, False, False]],
        obstacle=[[False, False, True], [False, False, False]],
        goal_distance=[[1.0, 0.5, 0.2], [0.3, 0.1, 0.04]],
        formation_error=[[0.3, 0.6, 0.9], [0.0, 0.1, 0.2]],
        done=[[False, False, True], [False, False, True]],
    )


def test_three_step_rollout():
    m = episode_metrics(three_steps(), goal_radius=0.05)
    assert m["episode_reward"].tolist() == pytest.approx([2.0 - 1.0 + 0.0, 5.5 + 5.5 + 6.0])
    assert m["leader_reward"].tolist() == pytest.approx([0.0, 30.0])
    assert m["follower_reward"].tolist() == pytest.approx([2.0, 4.0])
    assert m["CBRS"].tolist() == pytest.approx([100 / 3, 0.0])
    assert m["CBRO"].tolist() == pytest.approx([100 / 3, 0.0])
    assert m["UDBLT"].tolist() == pytest.approx([0.2, 0.04])
    assert m["RFSE"].tolist() == pytest.approx([0.6, 0.1])
    assert m["success"].tolist() == [0.0, 1.0]
    assert m["at_goal"].tolist() == [0.0, 1.0]
    assert m["no_robot_collision"].tolist() == [0.0, 1.0]
    assert m["no_obstacle_collision"].tolist() == [0.0, 1.0]
    assert m["length"].tolist() == [3.0, 3.0]
    assert summarize(m)["success"] == 0.5


def test_success_needs_goal_and_no_collision():
    r = three_steps()
    r["next", "goal_distance"][1, 2] = 0.06  # just outside rho_g
    assert episode_metrics(r, 0.05)["success"].tolist() == [0.0, 0.0]


def test_episodes_spanning_batches_and_several_per_batch():
    r = three_steps()
    r["next", "done"][0, 0] = True  # copy 0: episodes of 1 step then 2 steps
    tracker = EpisodeTracker(2, 0.05)
    first = tracker.update(r[:, :2])  # copy 0's first episode ends, copy 1's goes on
    second = tracker.update(r[:, 2:])
    assert first["length"].tolist() == [1.0]
    assert first["episode_reward"].tolist() == pytest.approx([2.0])
    assert second["length"].tolist() == [2.0, 3.0]
    assert second["episode_reward"].tolist() == pytest.approx([-1.0, 17.0])
    assert second["CBRS"].tolist() == pytest.approx([50.0, 0.0])
    assert second["RFSE"].tolist() == pytest.approx([0.75, 0.1])


def test_tracker_rejects_wrong_batch():
    with pytest.raises(ValueError, match=r"num_envs=3"):
        EpisodeTracker(3, 0.05).update(three_steps())


def test_env_rollout_metrics_are_consistent_with_diagnostics():
    env = FormationEnv(4, seed=1)
    r = env.rollout(300, break_when_any_done=False)
    m = episode_metrics(r, env.config.goal_radius)
    assert m["length"].tolist() == [150.0] * 8
    first = r[:, :150]
    cbro = 100 * first["next", "obstacle_collision"].float().mean((1, 2))
    by_copy = {k: v.view(4, 2) for k, v in m.items()}  # episodes come by copy, then time
    assert by_copy["CBRO"][:, 0].tolist() == pytest.approx(cbro.tolist(), abs=1e-4)
    assert by_copy["UDBLT"][:, 1].tolist() == pytest.approx(r["next", "goal_distance"][:, -1, 0].tolist(), abs=1e-6)


def test_success_splits_into_goal_and_collision_parts():
    env = FormationEnv(16, seed=3)
    m = episode_metrics(env.rollout(150, break_when_any_done=False), env.config.goal_radius)
    assert torch.equal(m["success"], m["at_goal"] * m["no_robot_collision"] * m["no_obstacle_collision"])
    assert torch.equal(m["no_robot_collision"] == 1, m["CBRS"] == 0)
    assert torch.equal(m["no_obstacle_collision"] == 1, m["CBRO"] == 0)
    assert torch.equal(m["at_goal"] == 1, m["UDBLT"] <= env.config.goal_radius)

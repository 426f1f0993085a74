"""The PettingZoo face passes PettingZoo's own API and seed tests."""

import numpy as np
import pytest
from pettingzoo.test import parallel_api_test, parallel_seed_test

from formation_rl.envs import formation_v0


def test_parallel_api():
    parallel_api_test(formation_v0.parallel_env(), num_cycles=200)


def test_parallel_api_other_sizes():
    parallel_api_test(formation_v0.parallel_env(num_robots=3, num_obstacles=2), num_cycles=50)


def test_parallel_seed():
    parallel_seed_test(formation_v0.parallel_env, num_cycles=50)


def test_agents_spaces_and_episode_end():
    env = formation_v0.parallel_env(max_steps=5)
    obs, infos = env.reset(seed=3)
    assert env.agents == ["leader", "follower_1", "follower_2", "follower_3", "follower_4"]
    assert obs["leader"].shape == (25,) and obs["leader"].dtype == np.float32
    assert env.action_space("follower_2").shape == (2,)
    for _ in range(5):
        obs, rew, term, trunc, info = env.step({a: env.action_space(a).sample() for a in env.agents})
    assert all(trunc.values()) and not any(term.values()) and env.agents == []
    assert set(info["leader"]) >= {"robot_collision", "obstacle_collision", "goal_distance", "formation_error"}


def test_same_world_as_torchrl_env():
    env = formation_v0.parallel_env()
    obs, _ = env.reset(seed=5)
    from formation_rl.envs import FormationEnv

    ref = FormationEnv(1, seed=0)
    ref.set_seed(5)
    td = ref.reset()
    np.testing.assert_array_equal(obs["follower_3"], td["agents", "observation"][0, 3].numpy())


def test_render_and_bad_input():
    env = formation_v0.parallel_env(render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    assert frame.ndim == 3 and frame.shape[2] == 3 and frame.dtype == np.uint8
    with pytest.raises(ValueError, match="actions: no action for agent 'follower_4'"):
        env.step({a: np.zeros(2, np.float32) for a in env.agents[:-1]})
    with pytest.raises(ValueError, match="render_mode = 'human' is invalid"):
        formation_v0.parallel_env(render_mode="human")
    with pytest.raises(ValueError, match="env.num_robots = 1"):
        formation_v0.parallel_env(num_robots=1)

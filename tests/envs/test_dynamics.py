"""Dynamics (reference.md, World): semi-implicit Euler, speed clipping, wall clamp, to 1e-6."""

import math

import pytest
import torch
from tensordict import TensorDict

from formation_rl.envs import EnvConfig, FormationEnv


def reference_step(p, v, a, cfg):
    """The dynamics (reference.md, World) for one robot in plain Python floats."""
    v = [v[k] + a[k] * cfg.max_force / cfg.mass * cfg.dt for k in range(2)]
    speed = math.hypot(*v)
    if speed > cfg.max_speed:
        v = [c * cfg.max_speed / speed for c in v]
    p = [p[k] + v[k] * cfg.dt for k in range(2)]
    lim = cfg.arena_half_size - cfg.robot_radius
    for k in range(2):
        if p[k] <= -lim and v[k] < 0 or p[k] >= lim and v[k] > 0:
            v[k] = 0.0
        p[k] = min(max(p[k], -lim), lim)
    return p, v


def _step(env, actions):
    td = TensorDict({("agents", "action"): torch.tensor([actions], dtype=torch.float32)}, batch_size=[1])
    return env.step(td)["next"]


@pytest.fixture
def env():
    return FormationEnv(1, config=EnvConfig(num_robots=3, num_obstacles=0), seed=0)


def test_acceleration_then_speed_clip(env):
    env.set_world_state(positions=[[[0.0, 0.0], [-1.0, 1.0], [1.0, -1.0]]], velocities=torch.zeros(1, 3, 2))
    xs = []
    for _ in range(5):
        nxt = _step(env, [[1.0, 0.0], [1.0, 1.0], [0.0, 0.0]])
        xs.append(nxt["state", "positions"][0].double())
    v = nxt["state", "velocities"][0].double()
    # robot 0: dv = 0.2 per step, |v| capped at 0.85 on the 5th; p = 0.02 + 0.04 + 0.06 + 0.08 + 0.085
    assert [x[0, 0].item() for x in xs] == pytest.approx([0.02, 0.06, 0.12, 0.20, 0.285], abs=1e-6)
    assert v[0].tolist() == pytest.approx([0.85, 0.0], abs=1e-6)
    # robot 1 pushed diagonally: after 4 steps |(0.8, 0.8)| > 0.85, so it is rescaled onto the cap
    c = 0.85 / math.sqrt(2)
    assert v[1].tolist() == pytest.approx([c, c], abs=1e-6)
    assert v[1].norm().item() == pytest.approx(0.85, abs=1e-6)
    assert v[2].tolist() == [0.0, 0.0]


def test_wall_clamp_zeroes_velocity_into_wall(env):
    env.set_world_state(positions=[[[3.85, 0.0], [-3.85, -3.85], [0.0, 0.0]]],
                        velocities=[[[0.5, 0.3], [-0.5, 0.2], [0.0, 0.0]]])
    nxt = _step(env, [[1.0, 0.0], [-1.0, -1.0], [0.0, 0.0]])
    p, v = nxt["state", "positions"][0], nxt["state", "velocities"][0]
    assert p[0].tolist() == pytest.approx([3.9, 0.03], abs=1e-6)  # x clamped to 4 - r
    assert v[0].tolist() == pytest.approx([0.0, 0.3], abs=1e-6)  # x component into the wall zeroed
    # robot 1: v = (-0.7, 0.0) -> p = (-3.92, -3.85) -> x clamped, vx zeroed; vy = 0 is not into a wall
    assert p[1].tolist() == pytest.approx([-3.9, -3.85], abs=1e-6)
    assert v[1].tolist() == pytest.approx([0.0, 0.0], abs=1e-6)


def test_matches_reference_over_a_long_fixed_sequence(env):
    cfg = env.config
    p = [[0.0, 0.0], [3.5, 3.5], [-3.0, 2.0]]
    v = [[0.0, 0.0], [0.1, 0.0], [0.0, -0.2]]
    env.set_world_state(positions=[p], velocities=[v])
    for t in range(60):
        actions = [[math.sin(0.3 * t), math.cos(0.2 * t)], [1.0, 1.0], [-1.0, (-1.0) ** t]]
        nxt = _step(env, actions)
        for i in range(3):
            p[i], v[i] = reference_step(p[i], v[i], actions[i], cfg)
        exact = dict(atol=1e-6, rtol=0)
        torch.testing.assert_close(nxt["state", "positions"][0].double(), torch.tensor(p, dtype=torch.float64), **exact)
        torch.testing.assert_close(nxt["state", "velocities"][0].double(), torch.tensor(v).double(), **exact)


def test_actions_outside_bounds_are_clipped(env):
    env.set_world_state(positions=[[[0.0, 0.0], [-1.0, 1.0], [1.0, -1.0]]], velocities=torch.zeros(1, 3, 2))
    nxt = _step(env, [[5.0, -5.0], [0.0, 0.0], [0.0, 0.0]])
    assert nxt["state", "velocities"][0, 0].tolist() == pytest.approx([0.2, -0.2], abs=1e-6)

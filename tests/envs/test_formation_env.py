"""The TorchRL env: specs, observation layout, resets, seeding, robustness."""

import math

import pytest
import torch
from torchrl.envs.utils import check_env_specs

from formation_rl.envs import EnvConfig, FormationEnv


@pytest.mark.parametrize("num_envs", [1, 64])
def test_check_env_specs(num_envs):
    env = FormationEnv(num_envs, seed=0)
    check_env_specs(env)
    td = env.rollout(3)
    b = num_envs
    assert td["agents", "observation"].shape == (b, 3, 5, 25)
    assert td["agents", "action"].shape == (b, 3, 5, 2)
    assert td["next", "agents", "reward"].shape == (b, 3, 5, 1)
    assert td["next", "done"].shape == (b, 3, 1)
    assert td["next", "state", "obstacle_centers"].shape == (b, 3, 4, 2)
    assert td["next", "state", "obstacle_radii"].shape == (b, 3, 4)
    for k in ("robot_collision", "obstacle_collision", "in_obstacle_area"):
        assert td["next", k].dtype == torch.bool and td["next", k].shape == (b, 3, 1)


@pytest.mark.parametrize("n,m", [(2, 0), (3, 1), (9, 6)])
def test_other_team_sizes(n, m):
    env = FormationEnv(8, config=EnvConfig(num_robots=n, num_obstacles=m), seed=0)
    check_env_specs(env)
    assert env.observation_spec["agents", "observation"].shape == (8, n, 4 + 2 * (n - 1) + 3 * m + 1)


def test_observation_layout():
    cfg = EnvConfig(num_robots=3, num_obstacles=2)
    env = FormationEnv(1, config=cfg, seed=0)
    pos = [[1.0, 1.0], [0.0, 1.2], [-2.0, 3.0]]
    vel = [[0.1, 0.2], [0.0, -0.3], [0.5, 0.0]]
    # obstacle 0: gap to robot 0 is |(1,1)-(1,1.75)| - 0.1 - 0.5 = 0.15 <= rho_d; robot 1: 1.14 - 0.6 > 0.2
    obs = env.set_world_state(positions=[pos], velocities=[vel], goal=[[3.2, 3.1]],
                              obstacle_centers=[[[1.0, 1.75], [-3.0, -1.0]]], obstacle_radii=[[0.5, 0.4]])
    o = obs["agents", "observation"][0]
    assert o.shape == (3, 4 + 4 + 6 + 1)
    expected_leader = [1.0, 1.0, 0.1, 0.2, 1.0 - 3.2, 1.0 - 3.1, 0.0, 0.0, 0.0, -0.75, 1.0, 0.0, 0.0, 0.0, 1.0]
    assert o[0].tolist() == pytest.approx(expected_leader, abs=1e-6)
    # followers: other robots' positions in index order, nothing sensed; flag = leader in area
    assert o[1].tolist() == pytest.approx([0.0, 1.2, 0.0, -0.3, 1.0, 1.0, -2.0, 3.0] + [0.0] * 6 + [1.0], abs=1e-6)
    assert o[2].tolist() == pytest.approx([-2.0, 3.0, 0.5, 0.0, 1.0, 1.0, 0.0, 1.2] + [0.0] * 6 + [1.0], abs=1e-6)


def test_relative_positions_shift_only_the_followers_view_of_the_others():
    """env.relative_positions: follower i sees p_j - p_i in the same slots; everything else as in reference.md."""
    state = dict(positions=[[[1.0, 1.0], [0.0, 1.2], [-2.0, 3.0]]], velocities=[[[0.1, 0.2], [0.0, -0.3], [0.5, 0.0]]],
                 goal=[[3.2, 3.1]], obstacle_centers=[[[1.0, 1.75], [-3.0, -1.0]]], obstacle_radii=[[0.5, 0.4]])
    obs = {}
    for rel in (False, True):
        cfg = EnvConfig(num_robots=3, num_obstacles=2, relative_positions=rel)
        obs[rel] = FormationEnv(1, config=cfg, seed=0).set_world_state(**state)["agents", "observation"][0]
    spec, rel = obs[False], obs[True]
    assert rel[1, 4:8].tolist() == pytest.approx([1.0, -0.2, -2.0, 1.8], abs=1e-6)  # leader, robot 2 from robot 1
    assert rel[2, 4:8].tolist() == pytest.approx([3.0, -2.0, 2.0, -1.8], abs=1e-6)  # leader, robot 1 from robot 2
    assert torch.equal(rel[0], spec[0])  # the leader's observation is unchanged
    assert torch.equal(rel[:, :4], spec[:, :4]) and torch.equal(rel[:, 8:], spec[:, 8:])
    check_env_specs(FormationEnv(4, config=EnvConfig(relative_positions=True), seed=0))


@pytest.mark.parametrize("rel", [False, True])
def test_observe_velocities_adds_the_others_velocities_after_their_positions(rel):
    """env.observe_velocities: a follower's role block goes on with the others' velocities (relative to its own
    with relative_positions); the leader gets zeros there; everything else moves back by that block, unchanged."""
    state = dict(positions=[[[1.0, 1.0], [0.0, 1.2], [-2.0, 3.0]]], velocities=[[[0.1, 0.2], [0.0, -0.3], [0.5, 0.0]]],
                 goal=[[3.2, 3.1]], obstacle_centers=[[[1.0, 1.75], [-3.0, -1.0]]], obstacle_radii=[[0.5, 0.4]])
    obs = {}
    for vel in (False, True):
        cfg = EnvConfig(num_robots=3, num_obstacles=2, relative_positions=rel, observe_velocities=vel)
        assert cfg.obs_dim == 4 + 4 + 6 + 1 + (4 if vel else 0)
        obs[vel] = FormationEnv(1, config=cfg, seed=0).set_world_state(**state)["agents", "observation"][0]
    plain, more = obs[False], obs[True]
    v = torch.tensor(state["velocities"][0])
    for i, others in ((1, (0, 2)), (2, (0, 1))):
        expected = torch.cat([v[j] - (v[i] if rel else 0) for j in others])
        torch.testing.assert_close(more[i, 8:12], expected)
    assert (more[0, 8:12] == 0).all()
    assert torch.equal(more[:, :8], plain[:, :8]) and torch.equal(more[:, 12:], plain[:, 8:])
    check_env_specs(FormationEnv(4, config=EnvConfig(observe_velocities=True, relative_positions=rel), seed=0))


@pytest.mark.parametrize("inside", [False, True])
def test_observe_distance_errors_adds_each_kept_pairs_error_under_the_active_formation(inside):
    """env.observe_distance_errors: a follower's role block ends with d_ij - d*_ij to each other robot j, signed,
    under the active formation (V outside the obstacle area, the chain inside), 0 where it keeps no distance to j;
    the leader gets zeros; everything else is the observation without it."""
    leader = [1.0, 1.0] if inside else [-3.5, 3.5]  # strictly inside the obstacle area or not
    pos = [leader, [leader[0] - 0.3, leader[1] + 0.1], [leader[0] + 0.2, leader[1] - 0.6]]
    state = dict(positions=[pos], velocities=[[[0.1, 0.2], [0.0, -0.3], [0.5, 0.0]]], goal=[[3.2, 3.1]],
                 obstacle_centers=[[[3.0, 1.75], [-3.0, -1.0]]], obstacle_radii=[[0.5, 0.4]])
    obs = {}
    for gaps in (False, True):
        cfg = EnvConfig(num_robots=3, num_obstacles=2, relative_positions=True, observe_velocities=True,
                        observe_distance_errors=gaps)
        assert cfg.obs_dim == 4 + 8 + (2 if gaps else 0) + 6 + 1
        obs[gaps] = FormationEnv(1, config=cfg, seed=0).set_world_state(**state)["agents", "observation"][0]
    plain, more = obs[False], obs[True]
    assert more[0, -1] == float(inside)  # the obstacle-area flag
    p = torch.tensor(pos)
    d = torch.cdist(p, p)
    v, s = 0.5 * math.sqrt(2 - 2 * math.cos(math.radians(90))), 0.5  # V: L1 and R1 0.5 m from the leader
    if inside:  # the chain: L1 keeps 0.4 m to the leader, R1 0.4 m to L1, nothing else
        expected = {1: [d[1, 0] - 0.4, 0.0], 2: [0.0, d[2, 1] - 0.4]}
    else:  # the V: every pair
        expected = {1: [d[1, 0] - s, d[1, 2] - v], 2: [d[2, 0] - s, d[2, 1] - v]}
    for i in (1, 2):
        torch.testing.assert_close(more[i, 12:14], torch.tensor(expected[i]))
    assert (more[0, 12:14] == 0).all()
    assert torch.equal(more[:, :12], plain[:, :12]) and torch.equal(more[:, 14:], plain[:, 12:])
    check_env_specs(FormationEnv(4, config=EnvConfig(observe_distance_errors=True, relative_positions=True), seed=0))


def test_partial_reset_only_touches_flagged_copies():
    env = FormationEnv(3, seed=0)
    td = env.reset()
    for _ in range(5):
        td = env.rand_step(td)
        td = td["next"].exclude(("agents", "reward"))
    before = env.world_state().clone()
    flag = torch.tensor([[False], [True], [False]])
    td = env.reset(td.update({"_reset": flag}))  # TorchRL's way: the current data plus the mask
    after = env.world_state()
    for k in ("positions", "velocities", "goal", "obstacle_centers", "obstacle_radii"):
        assert torch.equal(after[k][[0, 2]], before[k][[0, 2]]), k
        assert torch.equal(td["state", k], after[k]), k
        if k != "velocities":
            assert not torch.equal(after[k][1], before[k][1]), k
    assert after["velocities"][1].abs().sum() == 0
    # copy 1 restarted its clock: copies 0 and 2 truncate 5 steps before it
    dones = []
    for _ in range(150):
        td = env.rand_step(td)
        dones.append(td["next", "truncated"][:, 0].clone())
        td = td["next"].exclude(("agents", "reward"))
    first = [int(torch.stack(dones)[:, i].nonzero()[0]) + 1 for i in range(3)]
    assert first == [145, 150, 145]


def test_auto_reset_in_rollout():
    env = FormationEnv(2, config=EnvConfig(max_steps=10), seed=0)
    r = env.rollout(25, break_when_any_done=False)
    assert r["next", "done"][:, :, 0].sum(1).tolist() == [2, 2]
    assert r["next", "truncated"][0, 9, 0] and r["next", "truncated"][0, 19, 0]
    # the step after a truncation starts a fresh episode from rest
    assert r["state", "velocities"][:, 10].abs().sum() == 0


def test_an_episode_ends_by_truncation_only():
    """After max_steps the episode is done and truncated, never terminated (reference.md, World), collisions or not: its
    last transition keeps the bootstrap from the next observation (the replay side: tests/training/test_replay.py)."""
    env = FormationEnv(16, config=EnvConfig(max_steps=12), seed=0)
    nxt = env.rollout(12, break_when_any_done=False)["next"]
    assert nxt["robot_collision"].any()  # random actions collide, and that ends nothing
    assert nxt["done"][:, -1].all() and nxt["truncated"][:, -1].all() and not nxt["terminated"].any()
    assert not nxt["done"][:, :-1].any() and not nxt["truncated"][:, :-1].any()


def test_seeding_reproduces_scenarios():
    a, b = FormationEnv(16, seed=7), FormationEnv(16, seed=7)
    ra, rb = a.reset(), b.reset()
    assert torch.equal(ra["state", "positions"], rb["state", "positions"])
    assert torch.equal(ra["state", "obstacle_centers"], rb["state", "obstacle_centers"])
    c = FormationEnv(16, seed=8).reset()
    assert not torch.equal(ra["state", "goal"], c["state", "goal"])
    a.set_seed(3)
    b.set_seed(3)
    assert torch.equal(a.reset()["state", "obstacle_radii"], b.reset()["state", "obstacle_radii"])


def test_sampled_scenarios_follow_the_spec():
    cfg = EnvConfig()
    s = FormationEnv(512, seed=0).reset()["state"]
    c, r, p, g = s["obstacle_centers"], s["obstacle_radii"], s["positions"], s["goal"]
    assert ((r > 0.4) & (r < 0.6)).all()
    assert ((c[..., 0] >= -3) & (c[..., 0] <= 3) & (c[..., 1] >= -2) & (c[..., 1] <= 2)).all()
    gaps = torch.cdist(c, c) - r[:, :, None] - r[:, None, :] + torch.eye(4) * 10
    assert gaps.min() >= 0.5 - 1e-6
    assert ((g >= 3.0) & (g <= 3.5)).all()
    assert ((p >= -3.8) & (p <= -2.8)).all()
    dists = torch.cdist(p, p) + torch.eye(5) * 10
    assert dists.min() >= 2 * cfg.robot_radius + cfg.robot_collision_margin - 1e-6
    assert not FormationEnv(512, seed=0).reset()["obstacle_collision"].any()


def _random_walk(env, steps, extreme):
    td = env.reset()
    lim = env.config.arena_half_size - env.config.robot_radius
    for t in range(steps):
        if extreme:  # always +-1, alternating every 7 steps per robot
            sign = 1.0 if (t // 7) % 2 == 0 else -1.0
            action = torch.full(env.full_action_spec["agents", "action"].shape, sign)
            action[:, ::2] *= -1
        else:
            action = env.full_action_spec["agents", "action"].rand()
        td.set(("agents", "action"), action)
        out, td = env.step_and_maybe_reset(td)
        nxt = out["next"]
        for key, value in nxt.items(include_nested=True, leaves_only=True):
            if value.is_floating_point():
                assert torch.isfinite(value).all(), (key, t)
        pos = nxt["state", "positions"]
        assert (pos.abs() <= lim + 1e-6).all(), t
        assert (nxt["state", "velocities"].norm(dim=-1) <= env.config.max_speed + 1e-5).all(), t


@pytest.mark.parametrize("extreme", [False, True])
def test_hundred_thousand_random_steps_stay_finite_and_inside(extreme):
    env = FormationEnv(500, seed=1)
    _random_walk(env, 200, extreme)  # 500 copies x 200 steps = 10^5 frames


@pytest.mark.slow
@pytest.mark.parametrize("extreme", [False, True])
def test_million_random_steps_stay_finite_and_inside(extreme):
    env = FormationEnv(1000, seed=2)
    _random_walk(env, 1000, extreme)  # 10^6 frames


def test_world_state_round_trip_and_unknown_key():
    env = FormationEnv(2, seed=0)
    s = env.world_state()
    env.set_world_state(**{k: s[k] for k in s.keys()})
    assert torch.equal(env.world_state()["positions"], s["positions"])
    with pytest.raises(ValueError, match="unknown key 'pos'"):
        env.set_world_state(pos=torch.zeros(2, 5, 2))


def test_leader_speed_bounded_distance_per_episode():
    # a sanity number: at v_max for 150 steps the leader covers at most 0.85 * 15 = 12.75 m
    env = FormationEnv(4, seed=0)
    r = env.rollout(150, policy=lambda td: td.set(("agents", "action"), torch.ones(4, 5, 2)))
    path = r["next", "state", "positions"][:, :, 0].diff(dim=1).norm(dim=-1).sum(1)
    assert (path <= 0.85 * 15 + 1e-4).all()
    torch.testing.assert_close(r["next", "state", "positions"][:, -1, 0], torch.full((4, 2), 3.9), atol=1e-5, rtol=0)
    assert math.isclose(r["next", "state", "velocities"][:, -1].abs().max().item(), 0.0, abs_tol=1e-6)


def test_compiled_step_matches_eager():
    eager, compiled = FormationEnv(8, seed=4), FormationEnv(8, seed=4, compile_physics=True)
    torch.manual_seed(0)
    ra = eager.rollout(160, break_when_any_done=False)
    torch.manual_seed(0)
    rb = compiled.rollout(160, break_when_any_done=False)
    for key in (("next", "agents", "observation"), ("next", "agents", "reward"), ("next", "state", "positions"),
                ("next", "formation_error"), ("next", "obstacle_collision"), ("next", "done")):
        torch.testing.assert_close(rb[key], ra[key], atol=1e-5, rtol=1e-5)


def test_rand_action_is_uniform_in_bounds():
    env = FormationEnv(256, seed=0)
    a = env.rand_action()["agents", "action"]
    assert a.shape == (256, 5, 2) and a.min() >= -1 and a.max() <= 1
    assert env.full_action_spec["agents", "action"].is_in(a)
    assert a.mean().abs() < 0.05 and abs(a.std().item() - 3**-0.5) < 0.02  # U(-1, 1): mean 0, std 1/sqrt(3)


def test_start_anywhere_spreads_training_starts_and_zero_keeps_the_spec_square():
    """FormationEnv(start_anywhere=p): a share p of episodes start with robots anywhere in the arena (exploring
    starts for training); 0, the default and every evaluation's, keeps the default start square."""
    cfg = EnvConfig()
    spec = FormationEnv(256, config=cfg, seed=0).reset()["state", "positions"]
    assert spec.min() >= cfg.start_low and spec.max() <= cfg.start_high
    env = FormationEnv(256, config=cfg, seed=0, start_anywhere=0.5)
    pos = env.reset()["state", "positions"]  # [B, N, 2]
    outside = (pos > cfg.start_high).any(-1).any(-1).float().mean().item()
    assert 0.3 < outside < 0.6  # about half the copies (a few spread ones land in the square by chance)
    assert pos.abs().max() <= cfg.arena_half_size - cfg.robot_radius
    d = torch.cdist(pos, pos) + torch.eye(cfg.num_robots) * 10
    assert d.min() >= 2 * cfg.robot_radius + cfg.robot_collision_margin - 1e-6
    assert not env.reset()["obstacle_collision"].any()
    with pytest.raises(ValueError, match=r"^start_anywhere = 2 is invalid: must be a number in \[0, 1\]"):
        FormationEnv(1, start_anywhere=2)


def test_actions_that_require_grad_are_detached_by_the_step():
    """A policy outside torch.no_grad() gives actions with a graph; the world steps on their values."""
    weight = torch.full((2,), 0.5, requires_grad=True)

    def policy(td):
        td.set(("agents", "action"), torch.zeros_like(td["agents", "observation"][..., :2]) + weight)
        return td

    plain = FormationEnv(3, config=EnvConfig(max_steps=10), seed=4).rollout(10, lambda td: td.set(
        ("agents", "action"), torch.full_like(td["agents", "observation"][..., :2], 0.5)))
    graded = FormationEnv(3, config=EnvConfig(max_steps=10), seed=4).rollout(10, policy)
    assert graded["agents", "action"].requires_grad and not graded["next", "state", "positions"].requires_grad
    torch.testing.assert_close(graded["next", "state", "positions"], plain["next", "state", "positions"])


def test_start_team_moves_the_start_square_with_the_team():
    """start_team=True: spread episodes keep the team inside a start-square-sized box, moved anywhere."""
    cfg = EnvConfig()
    env = FormationEnv(256, config=cfg, seed=0, start_anywhere=1.0, start_team=True)
    pos = env.reset()["state", "positions"]  # [B, N, 2]
    side = cfg.start_high - cfg.start_low
    extent = pos.amax(1) - pos.amin(1)  # [B, 2]: the team's bounding box
    assert (extent <= side + 1e-5).all()
    low = pos.amin(1)
    assert low.std(0).min() > 1.0  # the boxes are spread over the arena, not in the default start corner
    assert pos.abs().max() <= cfg.arena_half_size - cfg.robot_radius
    d = torch.cdist(pos, pos) + torch.eye(cfg.num_robots) * 10
    assert d.min() >= 2 * cfg.robot_radius + cfg.robot_collision_margin - 1e-6
    assert not env.reset()["obstacle_collision"].any()
    single = FormationEnv(256, config=cfg, seed=0, start_anywhere=1.0).reset()["state", "positions"]
    assert ((single.amax(1) - single.amin(1)) > side + 1e-5).any()  # without it, robots spread apart


def test_relabel_goal_measures_observations_and_rewards_again_under_the_new_goal():
    env = FormationEnv(4, config={"relative_positions": True, "num_robots": 3, "num_obstacles": 2}, seed=0)
    td = env.rollout(30, break_when_any_done=False)  # [4, 30]
    same = env.relabel_goal(td, td.get(("state", "goal")))
    for key in (("agents", "observation"), ("next", "agents", "observation"), ("next", "agents", "reward")):
        torch.testing.assert_close(same.get(key), td.get(key))
    reached = td.get(("next", "state", "positions"))[:, 10, 0]  # [4, 2]: where the leader is after step 10
    moved = env.relabel_goal(td, reached[:, None].expand(4, 30, 2))
    reward = moved.get(("next", "agents", "reward"))
    hit = (td.get(("next", "robot_collision")) | td.get(("next", "obstacle_collision")))[:, 10, 0]
    expect = torch.where(hit, reward[:, 10, 0, 0], torch.full((4,), env.config.reward.goal))
    torch.testing.assert_close(reward[:, 10, 0, 0], expect)  # the leader's goal event at that step
    torch.testing.assert_close(reward[..., 1:, :], td.get(("next", "agents", "reward"))[..., 1:, :])  # followers
    obs = moved.get(("next", "agents", "observation"))
    torch.testing.assert_close(obs[:, 10, 0, 4:6], torch.zeros(4, 2))  # p_lea - p_g = 0 there
    torch.testing.assert_close(obs[..., 1:, :], td.get(("next", "agents", "observation"))[..., 1:, :])
    torch.testing.assert_close(td.get(("state", "goal")), same.get(("state", "goal")))  # the batch is untouched
    assert not torch.equal(moved.get(("state", "goal")), td.get(("state", "goal")))

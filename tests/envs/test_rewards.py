"""reference.md, Formations and Rewards: formation geometry, sparse events and guided terms, hybrid and fixed."""

import math

import numpy as np
import pytest
import torch
from tensordict import TensorDict

from formation_rl.envs import EnvConfig, FormationEnv, formations
from formation_rl.envs.config import FormationConfig, RewardConfig

S = 0.5 / math.sqrt(2)  # V slot offset per rank at s = 0.5, phi = 45 deg
FAR = [[0.0, -1.5]]  # an obstacle nobody touches


def v_slots(origin=(0.0, 3.0)):
    """The V (reference.md, Formations) for N = 5, written out: leader, L1, R1, L2, R2."""
    x, y = origin
    return [[x, y], [x - S, y + S], [x - S, y - S], [x - 2 * S, y + 2 * S], [x - 2 * S, y - 2 * S]]


def v_dstar():
    s = np.array(v_slots((0.0, 0.0)))
    return np.linalg.norm(s[:, None] - s[None], axis=-1)


def make_env(variant="hybrid"):
    cfg = EnvConfig(num_obstacles=1, reward=RewardConfig(variant=variant) if variant == "fixed" else RewardConfig())
    if variant == "fixed":
        cfg.reward.area_formation = None
    return FormationEnv(1, config=cfg, seed=0)


def rewards_at(env, positions, goal=(3.2, 3.2), center=FAR, radius=(0.5,)):
    """Rewards of the state reached by a zero action from rest at ``positions`` (nothing moves)."""
    env.set_world_state(positions=[positions], velocities=torch.zeros(1, 5, 2), goal=[goal],
                        obstacle_centers=[center], obstacle_radii=[radius])
    td = TensorDict({("agents", "action"): torch.zeros(1, 5, 2)}, batch_size=[1])
    nxt = env.step(td)["next"]
    return nxt["agents", "reward"][0, :, 0].double().numpy(), nxt


def test_v_and_chain_desired_distances_for_five_robots():
    d = formations.desired_distances(FormationConfig(), 5)
    expected = {(0, 1): 0.5, (0, 2): 0.5, (0, 3): 1.0, (1, 2): math.sqrt(0.5), (1, 3): 0.5,
                (1, 4): math.sqrt(1.25), (2, 3): math.sqrt(1.25), (3, 4): math.sqrt(2.0)}
    for (i, j), v in expected.items():
        assert d[i, j].item() == pytest.approx(v, abs=1e-6)
    np.testing.assert_allclose(d.numpy(), v_dstar(), atol=1e-6)
    chain = FormationConfig(shape="chain", spacing=0.4)
    dc = formations.desired_distances(chain, 5)
    assert [dc[i, i - 1].item() for i in range(1, 5)] == pytest.approx([0.4] * 4, abs=1e-6)
    own = formations.constraints(chain, 5)
    assert own.sum().item() == 4 and all(own[i, i - 1] for i in range(1, 5))  # predecessor only
    assert formations.pair_mask(FormationConfig(), 5).sum().item() == 10  # V: every unordered pair


def test_perfect_v_outside_area_gives_r2_and_guided_leader():
    r, nxt = rewards_at(make_env(), v_slots())
    assert r[0] == pytest.approx(-math.hypot(3.2, 0.2), abs=1e-5)  # guided: -|p_lea - p_g|
    assert r[1:].tolist() == pytest.approx([1.0] * 4)  # R2
    assert not nxt["in_obstacle_area"].item()
    assert nxt["formation_error"].item() == pytest.approx(0.0, abs=1e-5)


def test_leader_at_goal_gets_r1():
    r, _ = rewards_at(make_env(), v_slots(), goal=(0.0, 3.0))
    assert r[0] == pytest.approx(10.0)


def test_perturbed_v_guided_followers_sum_all_constraints():
    p = v_slots()
    p[3][0] += 0.1  # L2 moved
    r, nxt = rewards_at(make_env(), p)
    pa = np.array(p)
    err = np.abs(np.linalg.norm(pa[:, None] - pa[None], axis=-1) - v_dstar())
    held = [np.all(err[i, np.arange(5) != i] <= 0.05) for i in range(5)]
    assert held[1:] == [False, True, False, True]  # L1 and L2 miss a constraint; R1, R2 still hold
    for i in (1, 3):
        assert r[i] == pytest.approx(-err[i].sum(), abs=1e-5)
    assert r[2] == r[4] == 1.0
    assert nxt["formation_error"].item() == pytest.approx(np.triu(err, 1).sum(), abs=1e-5)


def chain_line(dx=(0.0, -0.4, -1.0, -1.4, -1.8)):
    return [[x, 0.0] for x in dx]  # leader at the origin, inside the obstacle area


def test_chain_inside_area_with_hybrid_reward():
    r, nxt = rewards_at(make_env(), chain_line(), center=[[2.5, 1.5]])
    assert nxt["in_obstacle_area"].item()
    assert r[0] == pytest.approx(-math.hypot(3.2, 3.2), abs=1e-5)
    assert r[1] == 1.0 and r[3] == 1.0 and r[4] == 1.0  # R3: predecessor at 0.4
    assert r[2] == pytest.approx(-0.2, abs=1e-5)  # guided: -|d_{2,1} - s_chain| = -|0.6 - 0.4|
    assert nxt["formation_error"].item() == pytest.approx(0.2, abs=1e-5)  # chain pairs only


def test_fixed_reward_keeps_v_inside_area():
    p = chain_line()
    r, nxt = rewards_at(make_env("fixed"), p, center=[[2.5, 1.5]])
    assert nxt["in_obstacle_area"].item()
    pa = np.array(p)
    err = np.abs(np.linalg.norm(pa[:, None] - pa[None], axis=-1) - v_dstar())
    assert r[1:].tolist() == pytest.approx([-err[i].sum() for i in range(1, 5)], abs=1e-5)
    assert nxt["formation_error"].item() == pytest.approx(np.triu(err, 1).sum(), abs=1e-5)


def test_area_is_strict():
    p = [[x - 3.0, y] for x, y in chain_line()]  # leader exactly on the area's edge x = -3
    _, nxt = rewards_at(make_env(), p, center=[[2.5, 1.5]])
    assert not nxt["in_obstacle_area"].item()
    p = [[x - 2.99, y] for x, y in chain_line()]
    _, nxt = rewards_at(make_env(), p, center=[[2.5, 1.5]])
    assert nxt["in_obstacle_area"].item()


def test_obstacle_collision_replaces_guided_and_sums_with_other_events():
    p = v_slots()
    # obstacle surface 0.05 from the leader's surface: gap 0.05 < rho_o
    r, nxt = rewards_at(make_env(), p, center=[[0.65, 3.0]], radius=(0.5,))
    assert nxt["obstacle_collision"].item()
    assert r[0] == pytest.approx(-20.0)  # R4 replaces guided
    assert r[1:].tolist() == pytest.approx([1.0] * 4)
    # a follower in formation that also hits the obstacle: R2 + R4
    p = v_slots((0.0, 3.0))
    r, _ = rewards_at(make_env(), p, center=[[-S - 0.65, 3.0 + S]], radius=(0.5,))
    assert r[1] == pytest.approx(1.0 - 20.0)


def test_robot_collisions():
    p = v_slots()
    p[2] = [p[1][0] + 0.25, p[1][1]]  # R1 0.25 from L1: |d| - 2r = 0.05 < rho_r
    r, nxt = rewards_at(make_env(), p)
    assert nxt["robot_collision"].item()
    assert r[1] == pytest.approx(-10.0) and r[2] == pytest.approx(-10.0)  # R5 (no formation bonus: broken)
    p = v_slots()
    p[1] = [0.0 - 0.2, 3.0 + 0.1]  # L1 onto the leader
    r, _ = rewards_at(make_env(), p, center=[[0.65, 3.0]])
    assert r[0] == pytest.approx(-10.0 - 20.0)  # R4 + R5 for the leader


def test_spacing_of_exactly_the_margin_is_not_a_collision():
    p = v_slots()
    p[2] = [p[1][0] + 0.3125, p[1][1]]  # 0.3125 - 0.2 = 0.1125 >= rho_r
    _, nxt = rewards_at(make_env(), p)
    assert not nxt["robot_collision"].item()


def test_progress_terms_reward_motion_toward_the_goal_and_the_formation():
    """reward=shaped's guided terms: (d_prev - d) / (v_max dt) for the leader, the same on the active-formation
    error for followers, plus the weighted level terms, all times scale; sparse events still replace them."""
    cfg = EnvConfig(num_obstacles=1)
    cfg.reward = RewardConfig(leader_distance=0.1, leader_progress=1.0, follower_error=0.1, follower_progress=1.0,
                              scale=0.5)
    env = FormationEnv(1, config=cfg, seed=0)
    slots = np.array(v_slots((-1.0, 3.0)))  # outside the obstacle area (y > 2)
    start = slots.copy()
    start[1] += [0.0, 0.3]  # L1 off its slot
    goal = (3.2, 3.2)
    vel = np.zeros((5, 2))
    vel[0] = [0.5, 0.0]  # leader flies toward the goal (east), L1 back toward its slot (south)
    vel[1] = [0.0, -0.5]
    env.set_world_state(positions=[start.tolist()], velocities=[vel.tolist()], goal=[goal],
                        obstacle_centers=[FAR], obstacle_radii=[(0.5,)])
    nxt = env.step(TensorDict({("agents", "action"): torch.zeros(1, 5, 2)}, batch_size=[1]))["next"]
    r = nxt["agents", "reward"][0, :, 0].double().numpy()
    pos = nxt["state", "positions"][0].double().numpy()
    unit = cfg.max_speed * cfg.dt

    def follower_error(p, i):
        d = np.linalg.norm(p[:, None] - p[None], axis=-1)
        return np.abs(d[i] - v_dstar()[i]).sum()

    d_prev, d_now = np.linalg.norm(start[0] - goal), np.linalg.norm(pos[0] - goal)
    assert d_now < d_prev
    assert r[0] == pytest.approx(0.5 * (-0.1 * d_now + (d_prev - d_now) / unit), abs=1e-4)
    e_prev, e_now = follower_error(start, 1), follower_error(pos, 1)
    assert e_now < e_prev
    assert r[1] == pytest.approx(0.5 * (-0.1 * e_now + (e_prev - e_now) / unit), abs=1e-4)
    assert r[1] > 0  # moving back toward its slot pays more than the error costs

    # a collision still replaces the guided term (times scale); L2 holds the V too, so R2 adds to R4
    env.set_world_state(positions=[slots.tolist()], velocities=torch.zeros(1, 5, 2), goal=[goal],
                        obstacle_centers=[[slots[3].tolist()]], obstacle_radii=[(0.5,)])
    nxt = env.step(TensorDict({("agents", "action"): torch.zeros(1, 5, 2)}, batch_size=[1]))["next"]
    rw = cfg.reward
    assert nxt["agents", "reward"][0, 3, 0].item() == pytest.approx(0.5 * (rw.obstacle_collision + rw.formation_open))


def test_shaped_reward_config_composes():
    """conf/reward/shaped.yaml: the hybrid switch with progress terms; the paper's variants keep their weights."""
    from omegaconf import OmegaConf

    shaped = OmegaConf.load("formation_rl/conf/reward/shaped.yaml")
    assert shaped.variant == "hybrid" and shaped.leader_progress > 0 and shaped.follower_progress > 0
    paper = RewardConfig()
    assert (paper.leader_distance, paper.leader_progress, paper.follower_error, paper.follower_progress,
            paper.leader_team, paper.scale) == (1.0, 0.0, 1.0, 0.0, 0.0, 1.0)


def test_proximity_ramps_toward_a_collision_before_it_happens():
    cfg = EnvConfig(num_obstacles=1)
    cfg.reward = RewardConfig(proximity=2.0, proximity_range=0.2)
    env = FormationEnv(1, config=cfg, seed=0)
    base, _ = rewards_at(make_env(), v_slots())  # the paper's reward of the same state
    slots = v_slots()
    r, _ = rewards_at(env, slots)
    np.testing.assert_allclose(r, base, atol=1e-5)  # V slots are >= 0.5 m apart: clearance 0.2, no ramp
    near = [list(p) for p in slots]
    near[1] = [slots[0][0] - 0.25, slots[0][1] + 0.25]  # L1 0.354 m from the leader: clearance 0.054 m
    r, _ = rewards_at(env, near)
    ref, _ = rewards_at(make_env(), near)
    ramp = 1 - (math.hypot(0.25, 0.25) - 0.3) / 0.2
    assert r[0] == pytest.approx(ref[0] - 2.0 * ramp, abs=1e-5)
    assert r[1] == pytest.approx(ref[1] - 2.0 * ramp, abs=1e-5)
    # the leader's share of R5 scales its robot ramp too (followers unchanged): at 0 it answers for no contact
    cfg.reward = RewardConfig(proximity=2.0, proximity_range=0.2, leader_robot_collision=0.0)
    shared, _ = rewards_at(FormationEnv(1, config=cfg, seed=0), near)
    free = EnvConfig(num_obstacles=1)
    free.reward = RewardConfig(leader_robot_collision=0.0)
    ref0, _ = rewards_at(FormationEnv(1, config=free, seed=0), near)
    assert shared[0] == pytest.approx(ref0[0], abs=1e-5)
    assert shared[1] == pytest.approx(r[1], abs=1e-5)


def test_leader_robot_collision_share():
    """reward.leader_robot_collision: the leader's share of R5; at 0 a contact leaves its guided term in place."""
    slots = v_slots()
    near = [list(p) for p in slots]
    near[1] = [slots[0][0] - 0.15, slots[0][1] + 0.1]  # L1 0.18 m from the leader: a robot contact
    ref, _ = rewards_at(make_env(), near)
    assert ref[0] == pytest.approx(RewardConfig().robot_collision)  # the paper: the leader takes R5
    for share, r5 in ((0.0, -10.0), (0.5, -10.0), (0.2, -50)):  # (an integer R5 from Python, as from a script)
        cfg = EnvConfig(num_obstacles=1)
        cfg.reward = RewardConfig(leader_robot_collision=share, robot_collision=r5)
        r, _ = rewards_at(FormationEnv(1, config=cfg, seed=0), near)
        assert r[1] == pytest.approx(r5)  # the follower in contact takes R5, the others are unchanged
        np.testing.assert_allclose(r[2:], ref[2:], atol=1e-6)
        if share:
            assert r[0] == pytest.approx(share * r5)
        else:  # the leader's guided term: -|p - g| at the paper's weights
            assert r[0] == pytest.approx(-math.dist(slots[0], (3.2, 3.2)), abs=1e-5)
    with pytest.raises(ValueError, match=r"env.reward.leader_robot_collision = 2"):
        bad = EnvConfig()
        bad.reward = RewardConfig(leader_robot_collision=2)
        bad.validate()


def test_start_robot_collision_prices_a_contact_inside_the_start_square():
    """reward.start_robot_collision: a robot in contact pays it while inside the start square, R5 elsewhere."""
    cfg = EnvConfig(num_obstacles=1)
    cfg.reward = RewardConfig(robot_collision=-10.0, start_robot_collision=-25.0, leader_robot_collision=0.0)
    env = FormationEnv(1, config=cfg, seed=0)
    inside = [[-3.5, -3.5], [-3.3, -3.3], [-2.0, 0.0], [0.0, 2.0], [2.0, 0.0]]  # leader and L1 in contact, inside
    r, _ = rewards_at(env, inside)
    assert r[1] == pytest.approx(-25.0)
    assert r[0] == pytest.approx(-math.dist(inside[0], (3.2, 3.2)), abs=1e-5)  # the leader's share is 0
    straddle = [[-2.9, -2.9], [-2.7, -2.7], [-2.0, 0.0], [0.0, 2.0], [2.0, 0.0]]  # L1 just outside the square
    r, _ = rewards_at(env, straddle)
    assert r[1] == pytest.approx(-10.0)
    cfg.reward = RewardConfig(robot_collision=-10.0, start_robot_collision=-25.0)  # the paper's share: both pay
    r, _ = rewards_at(FormationEnv(1, config=cfg, seed=0), straddle)
    assert (r[0], r[1]) == (pytest.approx(-25.0), pytest.approx(-10.0))
    with pytest.raises(ValueError, match=r"env.reward.start_robot_collision = nan"):
        bad = EnvConfig()
        bad.reward = RewardConfig(start_robot_collision=float("nan"))
        bad.validate()


def test_follower_slot_is_the_distance_to_the_slot_turned_to_the_leaders_heading():
    """reward.follower_slot: a follower pays w x its distance to its V slot, the V placed at the leader and turned to
    its heading (L2 is 0.2 m off its slot, so no follower holds the V's distances and earns R2 instead); nothing
    while the leader is inside the obstacle area (the chain active)."""
    slots = np.array(v_slots())  # outside the obstacle area: the V is active
    team = slots.copy()
    team[3, 1] -= 0.2  # (toward the arena: the wall would stop it)

    def rewards(slot, heading, offset=(0.0, 0.0)):
        cfg = EnvConfig(num_obstacles=1)
        cfg.reward = RewardConfig(follower_slot=slot, leader_distance=0.0, follower_error=0.0)
        env = FormationEnv(1, config=cfg, seed=0)
        vel = torch.tensor(heading, dtype=torch.float32).expand(1, 5, 2)
        env.set_world_state(positions=[(team + offset).tolist()], velocities=vel, goal=[(3.2, 3.2)],
                            obstacle_centers=[FAR], obstacle_radii=[(0.5,)])
        td = TensorDict({("agents", "action"): torch.zeros(1, 5, 2)}, batch_size=[1])
        return env.step(td)["next", "agents", "reward"][0, :, 0].double().numpy()

    ahead = rewards(2.0, (0.5, 0.0)) - rewards(0.0, (0.5, 0.0))
    np.testing.assert_allclose(ahead, [0.0, 0.0, 0.0, -2.0 * 0.2, 0.0], atol=1e-4)
    # flying along +y the V turns by 90 degrees: slot (x, y) relative to the leader goes to (-y, x)
    offsets = slots - slots[0]
    turned_slots = slots[0] + np.stack([-offsets[:, 1], offsets[:, 0]], -1)
    expected = -2.0 * np.linalg.norm(team - turned_slots, axis=-1)
    expected[0] = 0.0
    np.testing.assert_allclose(rewards(2.0, (0.0, 0.5)) - rewards(0.0, (0.0, 0.5)), expected, atol=1e-4)
    inside = (0.0, -2.8)  # the leader at (0, 0.2): inside the area
    np.testing.assert_allclose(rewards(2.0, (0.0, 0.5), inside), rewards(0.0, (0.0, 0.5), inside), atol=1e-6)


def test_follower_slot_in_the_course_frame_does_not_turn_with_the_leader():
    """reward.slot_frame=course: the V's slots point from the start square's centre (-3.3, -3.3) to the goal
    (3.2, 3.2), 45 degrees, whatever the leader's heading; a team laid out in that frame pays nothing."""
    slots = np.array(v_slots())
    offsets = slots - slots[0]
    c = s = np.sqrt(0.5)
    team = slots[0] + offsets @ np.array([[c, s], [-s, c]])  # offsets turned by +45 degrees

    def rewards(slot, heading):
        cfg = EnvConfig(num_obstacles=1)
        cfg.reward = RewardConfig(follower_slot=slot, slot_frame="course", leader_distance=0.0, follower_error=0.0)
        env = FormationEnv(1, config=cfg, seed=0)
        vel = torch.tensor(heading, dtype=torch.float32).expand(1, 5, 2)
        env.set_world_state(positions=[team.tolist()], velocities=vel, goal=[(3.2, 3.2)],
                            obstacle_centers=[FAR], obstacle_radii=[(0.5,)])
        td = TensorDict({("agents", "action"): torch.zeros(1, 5, 2)}, batch_size=[1])
        return env.step(td)["next", "agents", "reward"][0, :, 0].double().numpy()

    for heading in ((0.5, 0.0), (0.0, 0.5), (0.0, 0.0)):
        np.testing.assert_allclose(rewards(2.0, heading) - rewards(0.0, heading), 0.0, atol=1e-4)
    with pytest.raises(ValueError, match=r"env.reward.slot_frame = 'north'"):
        EnvConfig(reward=RewardConfig(slot_frame="north")).validate()


def test_own_progress_credits_a_follower_with_its_own_move_only():
    """reward.own_progress: follower i's progress is e_i(its previous position, the others now) - e_i(now):
    a follower that stands still earns nothing when the others move, whichever way they go."""
    cfg = EnvConfig(num_obstacles=1)
    cfg.reward = RewardConfig(leader_distance=0.0, follower_error=0.0, leader_progress=1.0, follower_progress=1.0,
                              own_progress=True)
    env = FormationEnv(1, config=cfg, seed=0)
    start = np.array(v_slots((-1.0, 3.0)))
    start[1] += [0.0, 0.3]  # L1 off its slot
    vel = np.zeros((5, 2))
    vel[0] = [0.5, 0.0]  # the leader moves; L2 drifts; R1 moves back toward the V; L1 stands still
    vel[3] = [0.0, 0.5]
    vel[2] = [0.3, 0.3]
    env.set_world_state(positions=[start.tolist()], velocities=[vel.tolist()], goal=[(3.2, 3.2)],
                        obstacle_centers=[FAR], obstacle_radii=[(0.5,)])
    nxt = env.step(TensorDict({("agents", "action"): torch.zeros(1, 5, 2)}, batch_size=[1]))["next"]
    r = nxt["agents", "reward"][0, :, 0].double().numpy()
    pos = nxt["state", "positions"][0].double().numpy()
    unit = cfg.max_speed * cfg.dt

    def error(p, i):
        d = np.linalg.norm(p[:, None] - p[None], axis=-1)
        return np.abs(d[i] - v_dstar()[i]).sum()

    assert r[1] == pytest.approx(0.0, abs=1e-5)  # L1 did not move: no credit, though its error changed
    assert error(pos, 1) != pytest.approx(error(start, 1), abs=1e-3)
    for i in (2, 3):  # a follower that moved: its error from its old place to its new one, the others fixed
        own_prev = pos.copy()
        own_prev[i] = start[i]
        assert r[i] == pytest.approx((error(own_prev, i) - error(pos, i)) / unit, abs=1e-4)


def test_follower_velocity_charges_a_follower_its_velocity_gap_to_the_leader():
    """reward.follower_velocity: a follower's guided term loses w |v_i - v_lea| / v_max; one moving with the leader
    loses nothing, and the leader's own reward is untouched."""
    cfg = EnvConfig(num_obstacles=1)
    cfg.reward = RewardConfig(leader_distance=0.0, follower_error=0.0, follower_velocity=2.0)
    env = FormationEnv(1, config=cfg, seed=0)
    vel = np.zeros((5, 2))
    vel[:] = [0.4, 0.0]  # everyone with the leader ...
    vel[2] = [0.0, 0.3]  # ... but R1 and L2
    vel[3] = [0.4, -0.3]
    loose = (np.array(v_slots((0.0, 0.0))) * 1.5 + [-1.0, 2.0]).tolist()  # off the V: no R2 replaces the guided term
    env.set_world_state(positions=[loose], velocities=[vel.tolist()], goal=[(3.2, 3.2)],
                        obstacle_centers=[FAR], obstacle_radii=[(0.5,)])
    nxt = env.step(TensorDict({("agents", "action"): torch.zeros(1, 5, 2)}, batch_size=[1]))["next"]
    r = nxt["agents", "reward"][0, :, 0].double().numpy()
    v = nxt["state", "velocities"][0].double().numpy()
    assert r[0] == pytest.approx(0.0) and r[1] == pytest.approx(0.0, abs=1e-6) and r[4] == pytest.approx(0.0, abs=1e-6)
    for i in (2, 3):
        assert r[i] < -0.5 and r[i] == pytest.approx(-2.0 * np.linalg.norm(v[i] - v[0]) / cfg.max_speed, abs=1e-5)


def test_follower_chain_slot_is_the_distance_to_the_point_behind_the_robot_ahead():
    """reward.follower_chain_slot: while the chain is active a follower pays w x its distance to the point 0.4 m
    behind its predecessor (leader, L1, R1, L2) along that robot's heading; from rest, along the line to it, where
    the term is the chain error; nothing while the V is active."""
    chain = np.array([[1.0, 0.0], [0.6, 0.0], [0.2, 0.0], [-0.2, 0.0], [-0.6, 0.0]])  # inside the obstacle area
    team = chain.copy()
    team[2, 1] += 0.3  # R1 0.3 m beside its slot behind L1
    team[4] = team[3] + [-0.32, 0.0]  # R2 straight behind L2, 0.08 m short of the chain spacing (no contact)

    def rewards(w, speed, offset=(0.0, 0.0)):
        cfg = EnvConfig(num_obstacles=1)
        cfg.reward = RewardConfig(follower_chain_slot=w, leader_distance=0.0, follower_error=0.0)
        env = FormationEnv(1, config=cfg, seed=0)
        env.set_world_state(positions=[(team + offset).tolist()], velocities=[[(speed, 0.0)] * 5], goal=[(3.2, 3.2)],
                            obstacle_centers=[FAR], obstacle_radii=[(0.5,)])
        td = TensorDict({("agents", "action"): torch.zeros(1, 5, 2)}, batch_size=[1])
        return env.step(td)["next", "agents", "reward"][0, :, 0].double().numpy()

    moved = team + [0.05, 0.0]  # where the step leaves them, flying along +x at 0.5 m/s
    behind = moved[[0, 0, 1, 2, 3]] - [0.4, 0.0]
    expected = -2.0 * np.linalg.norm(moved - behind, axis=-1)
    expected[0] = 0.0
    np.testing.assert_allclose(rewards(2.0, 0.5) - rewards(0.0, 0.5), expected, atol=1e-4)
    at_rest = -2.0 * np.abs(np.linalg.norm(team - team[[0, 0, 1, 2, 3]], axis=-1) - 0.4)  # the chain errors
    at_rest[0] = 0.0
    np.testing.assert_allclose(rewards(2.0, 0.0) - rewards(0.0, 0.0), at_rest, atol=1e-4)
    outside = (-3.0, -3.0)  # the V is active: no term
    np.testing.assert_allclose(rewards(2.0, 0.5, outside), rewards(0.0, 0.5, outside), atol=1e-6)
    with pytest.raises(ValueError, match=r"env.reward.follower_chain_slot = 1.0 is invalid"):
        EnvConfig(reward=RewardConfig(variant="fixed", follower_chain_slot=1.0)).validate()

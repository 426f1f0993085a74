"""The classical reference controller (algo=apf): decentralized, bounded, and it does the task."""

import json
import subprocess
import sys
from pathlib import Path

import pytest
import torch
from tensordict.nn import TensorDictModule

import formation_rl
from formation_rl.envs import EnvConfig, FormationEnv
from formation_rl.evaluation.evaluate import evaluate_policy
from formation_rl.evaluation.policy import classical_policy
from formation_rl.models.controller import APFController

ROOT = Path(__file__).resolve().parents[2]


def test_actions_bounded_and_each_robot_reads_only_its_own_observation():
    cfg = EnvConfig()
    ctrl = APFController(cfg)
    obs = FormationEnv(16, config=cfg, seed=0).reset()["agents", "observation"]
    act = ctrl(obs)
    assert act.shape == (16, cfg.num_robots, 2) and act.abs().max() <= 1.0
    for j in range(cfg.num_robots):
        changed = obs.clone()
        changed[:, j] += torch.randn_like(changed[:, j])
        moved = (ctrl(changed) - act).abs().amax((0, 2)) > 0
        assert moved[j] and not moved[torch.arange(cfg.num_robots) != j].any()


def test_apf_acts_the_same_on_relative_positions():
    """The classical controller reads env.relative_positions and drives the same team either way."""
    actions = []
    for rel in (False, True):
        cfg = EnvConfig(relative_positions=rel)
        env = FormationEnv(8, config=cfg, seed=3)
        actions.append(env.rollout(150, classical_policy(cfg).module)["agents", "action"])
    assert (actions[0] - actions[1]).abs().max() < 1e-2


def test_load_policy_apf_maps_observations_to_actions():
    policy = formation_rl.load_policy("apf")
    assert policy.algo == "apf"
    obs = FormationEnv(3, seed=1).reset()["agents", "observation"]
    assert policy(obs).shape == (3, 5, 2)
    assert policy(obs.numpy()).shape == (3, 5, 2)


def test_apf_reaches_the_goal_and_succeeds_on_held_out_episodes():
    """What docs/RESULTS.md reports for the reference row, on 200 of the held-out episodes."""
    cfg = EnvConfig()
    per = evaluate_policy(classical_policy(cfg).module, cfg, 200, 200, progress=False)
    assert per["UDBLT"].median() <= cfg.goal_radius  # the leader stops at the goal in most episodes
    assert per["success"].mean() >= 0.5  # 59.6% on the 1,000 (58.5% on these 200); 41.9% before the braking
    assert per["CBRO"].mean() <= 1.2  # 0.56% on the 1,000, 1.31% before the braking


def test_apf_adapts_to_other_worlds():
    cfg = EnvConfig.from_dict({"num_robots": 7, "num_obstacles": 2, "formation": {"shape": "v", "spacing": 0.6}})
    per = evaluate_policy(classical_policy(cfg).module, cfg, 50, 50, progress=False)
    assert per["UDBLT"].median() <= 0.2


@pytest.mark.integration
def test_make_eval_apf_writes_metrics(tmp_path):
    run = subprocess.run([sys.executable, "-m", "formation_rl.apps.evaluate", "ckpt=apf", "episodes=20",
                          f"out={tmp_path}"], cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    result = json.loads((tmp_path / "metrics.json").read_text())
    assert result["eval"]["algo"] == "apf" and 0 <= result["success"] <= 1


def test_apf_with_the_fixed_reward_ignores_the_area_flag():
    """With reward=fixed there is no chain: the followers' targets do not depend on the area flag."""
    cfg = EnvConfig.from_dict({"reward": {"variant": "fixed"}})
    ctrl = APFController(cfg)
    obs = FormationEnv(8, config=cfg, seed=2).reset()["agents", "observation"]
    flipped = obs.clone()
    flipped[..., -1] = 1.0 - flipped[..., -1]
    # the leader slows inside the area by its own position, not the flag: nothing changes
    assert torch.equal(ctrl(obs), ctrl(flipped))


def test_controller_brakes_with_the_box_corner_when_closing_on_an_obstacle():
    """A robot sensing an obstacle it closes on faster than obstacle_brake gets the full outward corner action."""
    cfg = EnvConfig()
    ctrl = APFController(cfg)
    n = cfg.num_robots
    obs = torch.zeros(1, n, cfg.obs_dim)
    obs[0, 0, 0:2] = torch.tensor([0.0, 0.0])
    obs[0, 0, 2:4] = torch.tensor([0.6, 0.3])  # moving towards +x, +y
    obs[0, 0, 4:6] = torch.tensor([-3.0, -3.0])  # p - p_g: goal ahead
    first = 4 + 2 * (n - 1)
    obs[0, 0, first:first + 3] = torch.tensor([-0.7, -0.2, 1.0])  # p - c: obstacle ahead, sensed
    assert torch.equal(ctrl(obs)[0, 0], torch.tensor([-1.0, -1.0]))
    slow = obs.clone()
    slow[0, 0, 2:4] = torch.tensor([0.1, 0.0])  # closing at < 0.2 m/s: the usual field, not the corner
    assert not torch.equal(ctrl(slow)[0, 0], torch.tensor([-1.0, -1.0]))
    assert not torch.equal(APFController(cfg, obstacle_brake=None)(obs)[0, 0], torch.tensor([-1.0, -1.0]))


def test_load_policy_apf_reads_the_layout_of_the_world_it_is_given():
    """load_policy("apf") without a world reads absolute positions; with env_config=cfg it reads cfg's layout
    (relative positions) and acts as on absolute ones. A checkpoint refuses a layout it was not trained on."""
    rel = EnvConfig(relative_positions=True)
    td = FormationEnv(8, config=rel, seed=3).reset()
    absolute = FormationEnv(8, seed=3).reset()["agents", "observation"]
    expected = formation_rl.load_policy("apf")(absolute)
    torch.testing.assert_close(formation_rl.load_policy("apf", env_config=rel)(td["agents", "observation"]), expected)
    assert not torch.allclose(formation_rl.load_policy("apf")(td["agents", "observation"]), expected)
    with pytest.raises(ValueError, match=r"^env.relative_positions = False is invalid: the policy reads the "
                                         r"observation layout of relative_positions=True$"):
        formation_rl.load_policy(ROOT / "pretrained" / "per_matd3_fast.pt", env_config=EnvConfig())


def test_controller_reads_the_layout_with_observed_velocities():
    """env.observe_velocities and observe_distance_errors move the obstacle block back: the controller's actions
    stay the same."""
    paths = []
    for vel, gaps in ((False, False), (True, False), (True, True)):
        cfg = EnvConfig(relative_positions=True, observe_velocities=vel, observe_distance_errors=gaps)
        env = FormationEnv(16, config=cfg, seed=3)
        policy = TensorDictModule(APFController(cfg), [("agents", "observation")], [("agents", "action")])
        with torch.no_grad():
            ro = env.rollout(100, policy=policy)
        paths.append(ro["next", "state", "positions"])
        sensed = ro["agents", "observation"][..., 4 + cfg.role_width + 2::3]
    assert sensed.any()  # obstacles were in view: the shifted block was read
    torch.testing.assert_close(paths[0], paths[1])
    torch.testing.assert_close(paths[0], paths[2])

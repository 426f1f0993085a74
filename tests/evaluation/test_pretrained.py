"""The shipped policies (pretrained/per_matd3.pt, per_matd3_fast.pt, per_matd3_hindsight.pt): load without
arguments and keep what docs/RESULTS.md claims."""

from pathlib import Path

import torch

import formation_rl
from formation_rl.evaluation.evaluate import evaluate_policy

ROOT = Path(__file__).resolve().parents[2]
CLAIMED_SUCCESS = 0.153  # docs/RESULTS.md: 1,000 held-out episodes
TOLERANCE = 0.10  # 50 episodes: the binomial standard deviation at 15% is 0.05


def test_pretrained_policy_loads_and_keeps_its_success_on_50_held_out_episodes():
    policy = formation_rl.load_policy(ROOT / "pretrained" / "per_matd3.pt")
    assert policy.algo == "per_matd3"
    obs = torch.zeros(3, policy.env_config.num_robots, policy.env_config.obs_dim)
    assert policy(obs).shape == (3, policy.env_config.num_robots, 2)
    per = evaluate_policy(policy.module, policy.env_config, 50, 50, progress=False)
    assert abs(per["success"].mean().item() - CLAIMED_SUCCESS) <= TOLERANCE
    assert per["CBRO"].mean() < 2.37  # the paper's PER-MATD3 row, which it beats on obstacle collisions


FAST_CLAIMED_SUCCESS = 0.500  # docs/RESULTS.md, `make train-fast` (fast_residual_seed0): 1,000 held-out episodes
FAST_TOLERANCE = 0.14  # 50 episodes: the binomial standard deviation at 50% is 0.071


def test_fast_policy_loads_with_its_world_and_keeps_its_success_on_50_held_out_episodes():
    """pretrained/per_matd3_fast.pt corrects the classical controller and reads relative positions: its
    config says so, load_policy rebuilds both, and evaluation uses them."""
    from formation_rl.models.networks import ResidualActor

    policy = formation_rl.load_policy(ROOT / "pretrained" / "per_matd3_fast.pt")
    assert policy.algo == "per_matd3" and policy.env_config.relative_positions
    assert isinstance(policy.module.module, ResidualActor)
    per = evaluate_policy(policy.module, policy.env_config, 50, 50, progress=False)
    assert abs(per["success"].mean().item() - FAST_CLAIMED_SUCCESS) <= FAST_TOLERANCE
    assert per["CBRO"].mean() < 2.37


HINDSIGHT_CLAIMED_SUCCESS = 0.408  # RESULTS.md: recipe=hindsight, 9M frames, best validation, seed 0; 1,000 held-out
HINDSIGHT_TOLERANCE = 0.14  # 50 episodes: the binomial standard deviation at 41% is 0.070


def test_hindsight_policy_loads_with_its_world_and_keeps_its_success_on_50_held_out_episodes():
    """pretrained/per_matd3_hindsight.pt, the from-scratch recipe's team: plain actors (no controller inside)
    reading relative positions, with the reward it learned from in its config."""
    from formation_rl.models.networks import ResidualActor

    policy = formation_rl.load_policy(ROOT / "pretrained" / "per_matd3_hindsight.pt")
    assert policy.algo == "per_matd3" and policy.env_config.relative_positions
    assert not isinstance(policy.module.module, ResidualActor)
    assert policy.env_config.reward.follower_error == 2.0 and policy.env_config.reward.robot_collision == -50.0
    per = evaluate_policy(policy.module, policy.env_config, 50, 50, progress=False)
    assert abs(per["success"].mean().item() - HINDSIGHT_CLAIMED_SUCCESS) <= HINDSIGHT_TOLERANCE
    assert per["CBRO"].mean() < 2.37


def test_loaded_policy_is_a_torchrl_policy_and_rolls_outside_no_grad():
    """The issue's `env.rollout(150, policy=policy.module)` outside no_grad crashed in the world; the Policy
    itself is a TorchRL policy too, and says what it is."""
    from formation_rl.envs import FormationEnv

    policy = formation_rl.load_policy(ROOT / "pretrained" / "per_matd3_fast.pt")
    assert policy.label == "per_matd3 residual=apf"
    itself = FormationEnv(2, config=policy.env_config, seed=0).rollout(150, policy=policy)
    module = FormationEnv(2, config=policy.env_config, seed=0).rollout(150, policy=policy.module)
    assert module["agents", "action"].requires_grad  # the actor's graph, which the environment detached
    assert itself["agents", "action"].shape == (2, 150, 5, 2)
    torch.testing.assert_close(itself["agents", "action"], module["agents", "action"].detach())
    assert formation_rl.load_policy(ROOT / "pretrained" / "per_matd3.pt").label == "per_matd3"

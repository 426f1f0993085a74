"""formation_rl.evaluation.policy: load_policy, the Policy as a TorchRL module, its world check, output dirs."""

from pathlib import Path

import pytest
import torch
from helpers import tiny
from tensordict import TensorDict
from tensordict.nn import TensorDictModuleBase

import formation_rl
from formation_rl.envs import EnvConfig, FormationEnv
from formation_rl.evaluation.policy import load_policy, output_dir
from formation_rl.training.trainer import Trainer

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    run = tmp_path_factory.mktemp("run")
    trainer = Trainer(tiny("per_matd3", frames=800), run)
    trainer.train()
    return trainer


def test_load_policy_without_optimiser_state(trained):
    policy = formation_rl.load_policy(trained.run_dir)
    obs = torch.randn(7, 3, trained.cfg.env.obs_dim)
    expected = trained.actor(TensorDict({("agents", "observation"): obs}, [7]))["agents", "action"]
    torch.testing.assert_close(policy(obs), expected)
    assert policy(obs.numpy()).shape == (7, 3, 2)
    with pytest.raises(ValueError, match=r"expects \[..., 3, "):
        policy(torch.randn(2, 4, 5))


def test_a_checkpoint_naming_a_removed_critic_option_still_loads(trained, tmp_path):
    """model.critic_trunk (measured, removed): the actors it saved load as they were."""
    state = torch.load(trained.run_dir / "checkpoints" / "policy.pt", weights_only=False)
    state["model"]["critic_trunk"] = "followers"
    torch.save(state, tmp_path / "policy.pt")
    obs = torch.randn(4, 3, trained.cfg.env.obs_dim)
    torch.testing.assert_close(load_policy(tmp_path / "policy.pt")(obs), load_policy(trained.run_dir)(obs))


def test_policy_is_a_torchrl_module_of_the_actor_keys(trained):
    policy = load_policy(trained.run_dir / "checkpoints" / "last.pt")  # the policy.pt beside it
    assert isinstance(policy, TensorDictModuleBase) and policy.label == "per_matd3"
    assert policy.in_keys == [("agents", "observation")] and policy.out_keys == [("agents", "action")]
    rollout = FormationEnv(3, config=policy.env_config, seed=0).rollout(5, policy=policy)
    torch.testing.assert_close(rollout["agents", "action"], policy(rollout["agents", "observation"]))
    assert not rollout["agents", "action"].requires_grad  # no gradients: an evaluation policy


def test_a_world_the_policy_cannot_read_is_one_clear_error(trained):
    policy = load_policy(trained.run_dir)
    world = policy.env_config
    policy.check_world(EnvConfig(num_robots=3, num_obstacles=1, max_steps=50))  # another episode length reads fine
    for change, message in (({"num_robots": 4}, "env.num_robots = 4 is invalid: the policy was trained with 3 robots"),
                            ({"num_obstacles": 2}, "env.num_obstacles = 2 is invalid: the policy reads 1 obstacle"),
                            ({"relative_positions": True}, "env.relative_positions = True is invalid")):
        other = EnvConfig(**{"num_robots": world.num_robots, "num_obstacles": world.num_obstacles, **change})
        with pytest.raises(ValueError, match=f"^{message}"):
            load_policy(trained.run_dir, env_config=other)


def test_corrupt_or_foreign_checkpoint_is_one_clear_error(tmp_path):
    (tmp_path / "policy.pt").write_bytes(b"\x00garbage")
    with pytest.raises(ValueError, match="cannot be read .*: it is truncated or corrupt"):
        load_policy(tmp_path)
    torch.save({"format": 99, "version": "9.9"}, tmp_path / "policy.pt")
    with pytest.raises(ValueError, match=r"has format 99 \(formation_rl 9.9\); this formation_rl .* reads format 1"):
        load_policy(tmp_path)
    with pytest.raises(ValueError, match=r"^ckpt = '.*nowhere/run' is invalid: no policy.pt at"):
        load_policy(tmp_path / "nowhere" / "run")


def test_default_output_directory_names_the_checkpoint_or_run(tmp_path):
    run = tmp_path / "2026-01-01_00-00-00_seed0"
    (run / "checkpoints").mkdir(parents=True)
    (run / "checkpoints" / "policy.pt").touch()
    assert output_dir("eval", run) == Path("outputs/eval/2026-01-01_00-00-00_seed0")
    assert output_dir("render", run / "checkpoints" / "last.pt") == Path("outputs/render/2026-01-01_00-00-00_seed0")
    assert output_dir("eval", ROOT / "pretrained" / "per_matd3.pt") == Path("outputs/eval/per_matd3")
    assert output_dir("render", "apf") == Path("outputs/render/apf")

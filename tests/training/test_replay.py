"""formation_rl.training.replay: TorchRL's uniform and prioritized buffers, collector batches as transitions."""

import torch
from algorithms.conftest import D, N, make_batch
from helpers import tiny

from formation_rl.algorithms import WEIGHT_KEY, make_algorithm
from formation_rl.algorithms.config import AlgoConfig
from formation_rl.envs import EnvConfig, FormationEnv
from formation_rl.models import make_actor, make_critic
from formation_rl.training.replay import make_replay_buffer, priority_tree_device, to_transitions
from formation_rl.training.trainer import Trainer


def test_uniform_and_prioritized_buffers_keep_buffer_size_frames_and_draw_batch_size():
    uniform = make_replay_buffer(AlgoConfig(name="matd3", prioritized=False, batch_size=4, buffer_size=10))
    uniform.extend(make_batch(16))  # past capacity: the oldest six are overwritten
    assert len(uniform) == 10 and uniform.sample().shape == (4,) and WEIGHT_KEY not in uniform.sample().keys()
    per = make_replay_buffer(AlgoConfig(name="per_matd3", prioritized=True, batch_size=4, buffer_size=10))
    per.extend(make_batch(6))
    batch = per.sample()
    assert batch.shape == (4,) and batch[WEIGHT_KEY].shape == (4,) and set(batch["index"].tolist()) <= set(range(6))
    assert priority_tree_device("cpu") == torch.device("cpu")  # the priorities themselves: algorithms/test_per.py


def test_truncated_episode_keeps_its_bootstrap_in_the_replay_buffer():
    """An episode ends by truncation only (reference.md, World): its last transition is stored done but not terminated,
    per robot, so the TD target still bootstraps from the next observation (1 - terminated = 1)."""
    cfg = tiny()
    env = FormationEnv(2, config=cfg.env, seed=0)
    rollout = env.rollout(cfg.env.max_steps, break_when_any_done=False)  # [2, T]
    stored = to_transitions(rollout)
    n = cfg.env.num_robots
    assert stored.shape == (2 * cfg.env.max_steps,) and stored["next", "agents", "done"].shape[1:] == (n, 1)
    last = stored.reshape(2, -1)[:, -1]
    assert last["next", "agents", "done"].all() and not last["next", "agents", "terminated"].any()
    algo = make_algorithm(make_actor(n, cfg.env.obs_dim, (16, 16)), make_critic(n, cfg.env.obs_dim, (16, 16)), cfg.algo)
    batch = stored.reshape(2, -1)[:, -4:].reshape(-1).clone()  # the last steps, the truncated one among them
    batch["next", "agents", "reward"].zero_()
    with torch.no_grad():
        target = algo.loss.value_estimator.value_estimate(
            batch.set(("next", "agents", "state_action_value"), torch.ones_like(batch["next", "agents", "reward"])))
    torch.testing.assert_close(target, torch.full_like(target, cfg.algo.gamma))  # r + gamma * (1 - terminated) * 1


def test_n_step_transitions_carry_the_steps_they_look_ahead(tmp_path):
    cfg = tiny("matd3", frames=480)
    cfg.algo.n_steps, cfg.algo.gamma = 3, 0.9
    trainer = Trainer(cfg, tmp_path)
    trainer.train()
    stored = trainer.buffer[:]
    steps = stored["steps_to_next_obs"]
    assert stored.shape == (480,) and steps.shape == (480, 3, 1) and set(steps.unique().tolist()) == {1, 2, 3}
    # each collector batch is [8 copies, 20 steps]: the last two steps of a batch look ahead fewer steps
    assert (steps.view(-1, 8, 20, 3)[:, :, :18] == 3).all()


def test_transitions_keep_only_what_the_losses_read():
    env = FormationEnv(2, config=EnvConfig(num_robots=N, num_obstacles=1), seed=0)
    stored = to_transitions(env.rollout(3, break_when_any_done=False))
    assert stored["agents", "observation"].shape == (6, N, D) and "state" not in stored.keys()
    assert sorted(stored.keys(True, True)) == sorted([("agents", "observation"), ("agents", "action"),
                                                      ("next", "agents", "observation"), ("next", "agents", "reward"),
                                                      ("next", "agents", "done"), ("next", "agents", "terminated")])

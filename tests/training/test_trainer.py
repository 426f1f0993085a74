"""formation_rl.training.trainer: a tiny run end to end, TensorBoard tags, checkpoints, learning, residual
actors, exploration."""

import pytest
import torch
from helpers import scalars, tiny

import formation_rl
from formation_rl.envs import EnvConfig, FormationEnv
from formation_rl.models.controller import APFController
from formation_rl.training.checkpoint import CHECKPOINT, POLICY
from formation_rl.training.config import TrainConfig
from formation_rl.training.trainer import Trainer


@pytest.mark.parametrize("algo", ["maddpg", "matd3", "per_matd3"])
def test_tiny_run_logs_checkpoints_and_evaluates(tmp_path, algo):
    trainer = Trainer(tiny(algo), tmp_path)
    metrics = trainer.train()
    assert trainer.frames == 2400 and trainer.episodes == 8 * 2400 // (8 * 20)
    # one gradient step per update_every frames, counted from the collector batch (160 frames) that
    # brings the buffer to warmup_frames = 320, i.e. the 2nd
    assert trainer.algo.critic_steps == (2400 - 160) // 20
    assert set(metrics) >= {"episode_reward", "CBRS", "CBRO", "UDBLT", "RFSE", "success"}
    tags = scalars(tmp_path)
    for tag in ("train/episode_reward", "train/leader_reward", "train/follower_reward", "train/CBRS", "train/CBRO",
                "train/UDBLT", "train/RFSE", "train/success", "train_by_episode/episode_reward", "eval/CBRO",
                "eval/success", "loss/loss_critic", "loss/loss_actor", "algo/q_value", "perf/frames_per_s",
                "perf/grad_steps_per_s", "perf/episodes"):
        assert tag in tags, tag
    assert ("algo/priority_mean" in tags) == (algo == "per_matd3")
    # where the wall time went: every section of the loop timed, the shares logged
    split = trainer.timings.split()
    assert {"env", "policy", "buffer_extend", "buffer_sample", "update", "evaluation", "checkpoint"} <= set(split)
    assert ("priority" in split) == (algo == "per_matd3")
    assert all(v > 0 for v in split.values()) and sum(split.values()) == pytest.approx(1.0)
    assert "perf/share_update" in tags and "perf/share_env" in tags
    assert [s for s, _ in tags["eval/success"]] == [0, 1600, 2400]  # untrained, every eval_interval, the end
    assert (tmp_path / CHECKPOINT).is_file() and (tmp_path / POLICY).is_file()
    assert not list((tmp_path / "checkpoints").glob("*.tmp"))



def test_deploy_target_saves_and_evaluates_the_target_actors_and_trains_the_actors(tmp_path):
    cfg = tiny("per_matd3")
    cfg.algo.deploy = "target"
    trainer = Trainer(cfg, tmp_path)
    trainer.train()
    saved = torch.load(tmp_path / POLICY, weights_only=False)["actor"]
    target = trainer.algo.loss.target_actor_network_params
    own = trainer.algo.loss.actor_network_params
    for key, value in saved.items():
        assert torch.equal(value, target.get(tuple(key.split("."))))
        assert not torch.equal(value, own.get(tuple(key.split("."))))  # the trained actors differ from them ...
    assert trainer.actor.module[0].weights[0] is own.get(("module", "0", "weights", "0"))  # ... and are back
    policy = formation_rl.load_policy(tmp_path)
    assert trainer.evaluate() == pytest.approx(_validation(trainer, policy.module))  # eval/* scores the target


def _validation(trainer, module):
    from torchrl.envs.utils import ExplorationType, set_exploration_type

    from formation_rl.envs.metrics import episode_metrics, summarize
    trainer.eval_env.set_seed(trainer.cfg.eval_seed)
    with torch.no_grad(), set_exploration_type(ExplorationType.DETERMINISTIC):
        rollout = trainer.eval_env.rollout(trainer.cfg.env.max_steps, module, break_when_any_done=False)
    return summarize(episode_metrics(rollout, trainer.cfg.env.goal_radius))


def test_learns_to_reach_the_goal(tmp_path):
    """Learning check: two robots, no obstacles; the leader learns to approach the goal (random: ~9 m)."""
    cfg = TrainConfig(env=EnvConfig(num_robots=2, num_obstacles=0), total_frames=24000, num_envs=32,
                      steps_per_batch=25, eval_interval=24000, eval_episodes=50, checkpoint_interval=24000,
                      progress=False)
    cfg.algo.name, cfg.algo.num_critics, cfg.algo.policy_delay, cfg.algo.policy_noise = "maddpg", 1, 1, 0.0
    cfg.algo.prioritized, cfg.algo.update_every, cfg.algo.warmup_frames, cfg.algo.batch_size = False, 10, 2000, 256
    metrics = Trainer(cfg, tmp_path).train()
    assert metrics["UDBLT"] < 2.5, metrics


def test_residual_actors_start_as_the_controller_learn_corrections_and_reload(tmp_path):
    """model.residual=apf: before any update the actors act as the classical controller (targets too);
    training moves only the correction, within residual_scale; policy.pt rebuilds the same actors."""
    cfg = tiny("per_matd3", frames=640)
    cfg.model.residual, cfg.model.residual_scale = "apf", 0.3
    cfg.algo.warmup_frames, cfg.algo.lr_actor = 0, 1e-2
    trainer = Trainer(cfg, tmp_path)
    obs = FormationEnv(16, config=cfg.env, seed=4).reset()
    apf = APFController(cfg.env)(obs["agents", "observation"])
    with torch.no_grad():
        assert torch.equal(trainer.actor(obs.clone())["agents", "action"], apf)
    trainer.train()
    with torch.no_grad():
        trained = trainer.actor(obs.clone())["agents", "action"]
    assert not torch.equal(trained, apf)
    assert ((trained - apf).abs() <= 0.3 + 1e-6).all()
    policy = formation_rl.load_policy(tmp_path)
    assert torch.allclose(policy(obs["agents", "observation"]), trained, atol=1e-6)



@pytest.mark.parametrize("field, value, allowed", [("residual", "pid", "none or apf"),
                                                   ("critic_layer_norm", "all", "none or leader")])  # all: removed
def test_model_rejects_unknown_choices_before_any_work(field, value, allowed, tmp_path):
    cfg = tiny()
    setattr(cfg.model, field, value)
    with pytest.raises(ValueError, match=f"model.{field} = '{value}' is invalid: must be {allowed}"):
        Trainer(cfg, tmp_path / "run")
    assert not (tmp_path / "run").exists()



def test_critic_hidden_sizes_the_critics_and_leaves_the_actors(tmp_path):
    cfg = tiny()
    cfg.model.critic_hidden = [8, 6]
    trainer = Trainer(cfg, tmp_path / "run")
    critic = trainer.algo.loss.qvalue_network.module.mlp
    assert [w.shape[-1] for w in critic.weights] == [8, 6, 1]
    assert [w.shape[-1] for w in trainer.actor.module[0].weights] == [32, 32, 2]
    cfg.model.critic_hidden = [0]
    with pytest.raises(ValueError, match=r"model.critic_hidden = \[0\] is invalid: must be null or a non-empty list "
                                         "of positive layer sizes"):
        Trainer(cfg, tmp_path / "refused")
    assert not (tmp_path / "refused").exists()


def test_exploration_eps_replaces_actions_with_uniform_ones_during_collection_only(tmp_path):
    from torchrl.envs.utils import ExplorationType, set_exploration_type

    cfg = tiny()
    cfg.algo.exploration_eps, cfg.algo.exploration_sigma, cfg.algo.exploration_sigma_end = 0.5, 0.0, 0.0
    trainer = Trainer(cfg, tmp_path)
    td = trainer.env.reset()
    with torch.no_grad(), set_exploration_type(ExplorationType.RANDOM):
        noisy = trainer.explore(td.clone())["agents", "action"]
    with torch.no_grad():
        clean = trainer.actor(td.clone())["agents", "action"]
    replaced = (noisy != clean).any(-1).float().mean().item()  # per robot
    assert 0.2 < replaced < 0.8 and noisy.abs().max() <= 1
    with torch.no_grad(), set_exploration_type(ExplorationType.DETERMINISTIC):  # evaluation: the actors alone
        assert torch.equal(trainer.explore(td.clone())["agents", "action"], clean)
    cfg.algo.exploration_eps = 1.5
    with pytest.raises(ValueError, match=r"^algo.exploration_eps = 1.5 is invalid: must be in \[0, 1\]"):
        Trainer(cfg, tmp_path / "bad")


def test_her_stores_hindsight_copies_of_the_chosen_env_copies(tmp_path):
    cfg = tiny(frames=320)
    cfg.algo.her = 1.0
    trainer = Trainer(cfg, tmp_path)
    trainer.train()
    assert len(trainer.buffer) == 2 * 320  # every copy twice: as collected and with a hindsight goal
    stored = trainer.buffer.storage.get(torch.arange(len(trainer.buffer)))
    real, hindsight = stored[:160], stored[160:320]  # the first collector batch, then its relabelled copy
    torch.testing.assert_close(real.get(("agents", "action")), hindsight.get(("agents", "action")))
    leader_to_goal = [part.get(("agents", "observation"))[:, 0, 4:6] for part in (real, hindsight)]
    assert not torch.equal(*leader_to_goal)
    cfg.algo.her = -0.1
    with pytest.raises(ValueError, match=r"^algo.her = -0.1 is invalid: must be in \[0, 1\]"):
        Trainer(cfg, tmp_path / "bad")

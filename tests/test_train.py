"""The training job: a tiny run end to end, TensorBoard tags, checkpoints, resume, policy loading, CLI."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import torch
from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

import formation_rl
from formation_rl.envs import EnvConfig, FormationEnv
from formation_rl.models.controller import APFController
from formation_rl.training.checkpoint import CHECKPOINT, POLICY
from formation_rl.training.config import TrainConfig
from formation_rl.training.trainer import Trainer, to_train_config

ROOT = Path(__file__).resolve().parents[1]


def tiny(algo="per_matd3", frames=2400, **kw) -> TrainConfig:
    cfg = TrainConfig(env=EnvConfig(num_robots=3, num_obstacles=1, max_steps=20), total_frames=frames, num_envs=8,
                      steps_per_batch=20, eval_interval=1600, eval_episodes=4, checkpoint_interval=1600,
                      progress=False, **kw)
    cfg.algo.name = algo
    if algo == "maddpg":
        cfg.algo.num_critics, cfg.algo.policy_delay, cfg.algo.policy_noise, cfg.algo.prioritized = 1, 1, 0.0, False
    if algo == "matd3":
        cfg.algo.prioritized = False
    cfg.algo.batch_size, cfg.algo.warmup_frames, cfg.algo.update_every = 64, 320, 20
    cfg.model.hidden = [32, 32]
    return cfg


def scalars(run_dir: Path) -> dict[str, list]:
    """Every scalar of a run, over all its event files (a resumed run adds one)."""
    out: dict[str, list] = {}
    for events in sorted((run_dir / "tb").glob("events*")):
        ea = EventAccumulator(str(events))
        ea.Reload()
        for tag in ea.Tags()["scalars"]:
            out.setdefault(tag, []).extend((e.step, e.value) for e in ea.Scalars(tag))
    return out


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


def test_learns_to_reach_the_goal(tmp_path):
    """Learning check: two robots, no obstacles; the leader learns to approach the goal (random: ~9 m)."""
    cfg = TrainConfig(env=EnvConfig(num_robots=2, num_obstacles=0), total_frames=24000, num_envs=32,
                      steps_per_batch=25, eval_interval=24000, eval_episodes=50, checkpoint_interval=24000,
                      progress=False)
    cfg.algo.name, cfg.algo.num_critics, cfg.algo.policy_delay, cfg.algo.policy_noise = "maddpg", 1, 1, 0.0
    cfg.algo.prioritized, cfg.algo.update_every, cfg.algo.warmup_frames, cfg.algo.batch_size = False, 10, 2000, 256
    metrics = Trainer(cfg, tmp_path).train()
    assert metrics["UDBLT"] < 2.5, metrics


def _cli(*args):
    return subprocess.run([sys.executable, "-m", "formation_rl.apps.train", *args], cwd=ROOT, capture_output=True,
                          text=True, timeout=600)


def test_cli_tiny_run_and_errors(tmp_path):
    out = _cli("algo=maddpg", "total_frames=1000", "num_envs=4", "steps_per_batch=25", "algo.warmup_frames=200",
               "algo.batch_size=32", "eval_episodes=2", "env.max_steps=25", "model.hidden=[16,16]",
               f"hydra.run.dir={tmp_path}")
    assert out.returncode == 0, out.stderr[-2000:]
    assert "final evaluation" in out.stdout and json.loads((tmp_path / "metrics.json").read_text())["length"] == 25
    log = (tmp_path / "train.log").read_text()  # was empty: the summary is logged, not printed
    assert "final evaluation" in log and "run directory" in log
    bad = _cli("algo=ppo", f"hydra.run.dir={tmp_path}/x")
    assert bad.returncode != 0 and "maddpg" in bad.stderr and "per_matd3" in bad.stderr
    bad = _cli("algo.lr_actor=-1", f"hydra.run.dir={tmp_path}/y")
    assert bad.returncode == 2 and bad.stderr.strip() == "error: algo.lr_actor = -1.0 is invalid: must be > 0"
    bad = _cli("algo.batch_size=2048", "algo.buffer_size=1000", f"hydra.run.dir={tmp_path}/z")
    assert bad.returncode == 2 and "algo.buffer_size = 1000 is invalid: must be >= algo.batch_size (2048)" in bad.stderr
    bad = _cli("algo.lr_actr=0.1", f"hydra.run.dir={tmp_path}/w")
    assert bad.returncode != 0 and "lr_actr" in bad.stderr


@pytest.mark.parametrize("launcher", ["local", "slurm_local"])
def test_two_job_multirun(tmp_path, launcher):
    out = _cli("-m", f"hydra/launcher={launcher}", f"hydra.sweep.dir={tmp_path}",
               "algo=maddpg,matd3", "total_frames=400", "num_envs=4", "steps_per_batch=20",
               "algo.warmup_frames=160", "algo.batch_size=32", "eval_episodes=2", "env.max_steps=20",
               "model.hidden=[16,16]", "threads=1", "progress=false")
    assert out.returncode == 0, out.stderr[-3000:]
    for algo in ("maddpg", "matd3"):
        assert (tmp_path / f"{algo}_seed0" / "metrics.json").is_file()
        assert list((tmp_path / f"{algo}_seed0" / "tb").glob("events*"))


@pytest.mark.parametrize("module, args", [("formation_rl.apps.train", ["algo=apf"]),
                                          ("formation_rl.apps.evaluate", ["ckpt=nonexistent.pt"]),
                                          ("formation_rl.apps.render", []),
                                          ("formation_rl.apps.demo", ["episodes=0"])])
def test_refused_calls_leave_no_run_directory(module, args, tmp_path):
    """A refused call left an empty timestamped run directory (outputs/train/apf/<date>/ for algo=apf)."""
    out = subprocess.run([sys.executable, "-m", module, *args], cwd=tmp_path, capture_output=True, text=True,
                         timeout=300, env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert out.returncode == 2 and out.stderr.startswith("error: "), out.stderr[-2000:]
    assert not (tmp_path / "outputs").exists(), sorted(map(str, tmp_path.rglob("*")))


@pytest.mark.slow
def test_default_budget_learning_check(tmp_path):
    """`make train` (PER-MATD3, default budget): evaluation against the untrained policy's (frame 0)."""
    from hydra import compose, initialize_config_dir

    import formation_rl.apps.train  # noqa: F401  (registers the schema)

    with initialize_config_dir(config_dir=str(ROOT / "formation_rl" / "conf"), version_base=None):
        cfg = compose(config_name="config", overrides=["progress=false"])
    trainer = Trainer(to_train_config(cfg), tmp_path)
    final = trainer.train()
    evals = scalars(tmp_path)
    untrained = {k.split("/")[1]: v[0][1] for k, v in evals.items() if k.startswith("eval/")}
    print("untrained:", untrained, "\nfinal:", final)
    assert final["episode_reward"] > untrained["episode_reward"]
    assert final["success"] > untrained["success"]


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


def test_residual_rejects_unknown_bases():
    cfg = tiny()
    cfg.model.residual = "pid"
    with pytest.raises(ValueError, match="model.residual = 'pid' is invalid: must be none or apf"):
        Trainer(cfg, "/tmp/never_written_residual")
    assert not Path("/tmp/never_written_residual").exists()


def test_fast_budget_composes_to_the_residual_recipe():
    """`make train-fast` (budget=fast): residual actors on apf, anchored, relative positions; valid as composed."""
    from hydra import compose, initialize_config_dir

    from formation_rl.training.config import register, validate
    from formation_rl.training.trainer import to_train_config

    register()
    with initialize_config_dir(str(Path(__file__).resolve().parents[1] / "formation_rl" / "conf"), version_base=None):
        cfg = to_train_config(compose("config", overrides=["budget=fast"]))
    validate(cfg)
    assert cfg.model.residual == "apf" and cfg.algo.bc_weight > 0
    assert cfg.env.relative_positions and cfg.total_frames == 60_000


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

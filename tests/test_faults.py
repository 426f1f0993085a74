"""Nothing lost, nothing silent: kill -9, non-finite values, unwritable paths, bad input, reproducibility."""

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import torch
from helpers import tiny
from hydra import compose, initialize_config_dir

from formation_rl.algorithms import NonFiniteError
from formation_rl.apps.cli import check_overrides
from formation_rl.training.checkpoint import CHECKPOINT, load_checkpoint_file
from formation_rl.training.config import TrainConfig
from formation_rl.training.trainer import Trainer, to_train_config

ROOT = Path(__file__).resolve().parents[1]
TINY = ["total_frames=3200", "num_envs=8", "steps_per_batch=20", "algo.warmup_frames=320", "algo.batch_size=64",
        "eval_episodes=4", "eval_interval=1600", "checkpoint_interval=320", "env.num_robots=3", "env.num_obstacles=1",
        "env.max_steps=20", "model.hidden=[32,32]", "progress=false"]


def _train(run: Path, *extra: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "formation_rl.apps.train", *TINY, f"hydra.run.dir={run}", *extra],
                            cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)


@pytest.mark.parametrize("delay", [0.0, 0.4, 1.2])
def test_sigkill_keeps_last_checkpoint_and_resume_continues(tmp_path, delay):
    proc = _train(tmp_path)
    ckpt = tmp_path / CHECKPOINT
    deadline = time.time() + 180
    while not ckpt.exists() and proc.poll() is None and time.time() < deadline:
        time.sleep(0.02)
    time.sleep(delay)  # somewhere in collecting, updating, logging or writing the next checkpoint
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    state = load_checkpoint_file(ckpt)  # complete, whatever the moment of the kill
    frames = state["counters"]["frames"]
    assert frames >= 320 and state["algo"]["critic_steps"] >= 0
    resumed = _train(tmp_path, "resume=auto")
    _, err = resumed.communicate(timeout=300)
    assert resumed.returncode == 0, err[-2000:]
    final = load_checkpoint_file(ckpt)
    assert final["counters"]["frames"] == 3200
    if frames < 3200:  # killed mid-run: the resumed run trained on from the checkpoint
        assert final["algo"]["critic_steps"] > state["algo"]["critic_steps"]
    else:  # on a fast machine the run may end before the kill: resuming a finished run adds nothing
        assert final["algo"]["critic_steps"] == state["algo"]["critic_steps"]
    assert (tmp_path / "metrics.json").exists()


def test_non_finite_loss_stops_with_one_line_and_keeps_checkpoint(tmp_path):
    cfg = tiny("matd3", frames=3200)
    cfg.checkpoint_interval = 800
    trainer = Trainer(cfg, tmp_path)
    original = trainer.algo._critic_loss
    calls = {"n": 0}

    def poisoned(batch):
        calls["n"] += 1
        loss, meta = original(batch)
        return (loss * float("nan") if calls["n"] > 60 else loss), meta

    trainer.algo._critic_loss = poisoned
    with pytest.raises(NonFiniteError) as err:
        trainer.train()
    msg = str(err.value)
    assert "\n" not in msg and "the critic loss went non-finite" in msg and "at frame" in msg
    assert "gradient step 61" in msg
    state = load_checkpoint_file(tmp_path / CHECKPOINT)  # the last good one, from before the NaN
    assert state["algo"]["critic_steps"] <= 60
    assert all(torch.isfinite(v).all() for v in state["algo"]["loss"].values() if v.is_floating_point())


def test_non_finite_observation_stops_training(tmp_path):
    trainer = Trainer(tiny("maddpg", frames=1600), tmp_path)
    advance = trainer.env._advance

    def broken(*args):
        pos, vel, measured = advance(*args)
        measured["observation"] = measured["observation"].clone()
        measured["observation"][0, 0, 0] = float("inf")
        return pos, vel, measured

    trainer.env._advance = broken
    with pytest.raises(NonFiniteError, match=r"at frame 160: a non-finite observation came from the environment"):
        trainer.train()


def test_unwritable_run_directory_fails_before_compute(tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("not a directory")
    with pytest.raises(ValueError, match=r"run directory .*file/run is not writable"):
        Trainer(tiny(), blocker / "run")


def test_same_seed_same_run_different_seed_different_draws(tmp_path):
    a, b, c = (Trainer(tiny("per_matd3", frames=1600, seed=s), tmp_path / n) for s, n in ((5, "a"), (5, "b"), (6, "c")))
    ma, mb, mc = a.train(), b.train(), c.train()
    assert ma == mb and ma != mc
    sa, sb = (load_checkpoint_file(p / CHECKPOINT)["algo"]["loss"] for p in (tmp_path / "a", tmp_path / "b"))
    assert all(torch.equal(sa[k], sb[k]) for k in sa)
    assert not torch.equal(a.eval_env.world_state()["goal"], c.env.world_state()["goal"])


BAD_INPUT = [  # (entry point, arguments, the one line it must print)
    ("train", ["algo=ppo"], "algo = 'ppo' is invalid: must be one of maddpg, matd3, per_matd3"),
    ("train", ["algo=apf"], "algo = 'apf' is invalid: must be one of maddpg, matd3, per_matd3"),
    ("train", ["algo.bc_weight=-1"], "algo.bc_weight = -1.0 is invalid: must be >= 0"),
    ("train", ["env.observe_distance_errors=3"], "env.observe_distance_errors = 3 is invalid: must be true or false"),
    ("train", ["progress=yes"], "progress = 'yes' is invalid: must be true or false"),
    ("train", ["formation=star"], "formation = 'star' is invalid: must be one of chain, v"),
    ("train", ["reward=curvy"], "reward = 'curvy' is invalid: must be one of fixed, hybrid"),
    ("train", ["budget=huge"], "budget = 'huge' is invalid: must be one of default, fast, paper"),
    ("train", ["algo.lr_actr=0.1"], "algo.lr_actr: unknown key; allowed here: action_reg, alpha, batch_size"),
    ("train", ["num_envs=abc"], "num_envs = 'abc' is invalid: Value 'abc' of type 'str' could not be converted"),
    ("train", ["env.num_robots=1"], "env.num_robots = 1 is invalid: must be an integer >= 2"),
    ("train", ["num_envs=0"], "num_envs = 0 is invalid: must be an integer >= 1"),
    ("train", ["total_frames=0"], "total_frames = 0 is invalid: must be an integer >= 1"),
    ("train", ["algo.batch_size=2048", "algo.buffer_size=1000"], "algo.buffer_size = 1000 is invalid: must be >="),
    ("train", ["algo.lr_actor=-1"], "algo.lr_actor = -1.0 is invalid: must be > 0"),
    ("train", ["algo.tau=-0.1"], "algo.tau = -0.1 is invalid: must be in [0, 1]"),
    ("train", ["algo.deploy=ema"], "algo.deploy = 'ema' is invalid: must be actor or target"),
    ("train", ["algo.alpha=1.5"], "algo.alpha = 1.5 is invalid: must be in [0, 1]"),
    ("train", ["algo.beta=-0.5"], "algo.beta = -0.5 is invalid: must be in [0, 1]"),
    ("train", ["eval_episodes=0"], "eval_episodes = 0 is invalid: must be an integer >= 1"),
    ("train", ["device=tpu"], "device = 'tpu' is invalid: must be cpu, cuda or cuda:<index>"),
    ("train", ["cudagraphs=true"], "cudagraphs = True is invalid: must be false with device=cpu (CUDA graphs need"),
    ("train", ["env.max_speed=0"], "env.max_speed = 0.0 is invalid: must be a finite number > 0"),
    ("train", ["resume=/no/such/run"], "resume = '/no/such/run' is invalid: no checkpoint at /no/such/run"),
    ("formation_rl.apps.train", ["-m", "algo=maddpg,ppo"],
     "algo = 'ppo' is invalid: must be one of maddpg, matd3"),
    ("formation_rl.apps.evaluate", ["ckpt=/no/such/run"], "ckpt = '/no/such/run' is invalid: no policy.pt"),
    ("formation_rl.apps.evaluate", ["ckpt=x", "episodes=0"], "episodes = 0 is invalid: must be an integer >= 1"),
    ("formation_rl.apps.evaluate", ["ckpt=x", "num_envs=0"], "num_envs = 0 is invalid: must be an integer >= 1"),
    ("formation_rl.apps.evaluate", ["ckpt=x", "formation=star"],
     "formation = 'star' is invalid: must be one of chain, v"),
    ("formation_rl.apps.evaluate", ["ckpt=x", "env.num_robot=3"], "env.num_robot: unknown key; allowed here:"),
    ("formation_rl.apps.evaluate", ["ckpt=x", "episodes=many"], "episodes = 'many' is invalid: Value 'many'"),
    ("formation_rl.apps.render", ["ckpt=/no/such/run"], "ckpt = '/no/such/run' is invalid: no policy.pt"),
    ("formation_rl.apps.render", ["ckpt=x", "fps=fast"], "fps = 'fast' is invalid: Value 'fast'"),
    ("formation_rl.apps.demo", ["num_envs=0"], "num_envs = 0 is invalid: must be an integer >= 1"),
    ("formation_rl.apps.demo", ["episodes=0"], "episodes = 0 is invalid: must be an integer >= 1"),
    ("formation_rl.apps.demo", ["reward=curvy"], "reward = 'curvy' is invalid: must be one of fixed, hybrid"),
    ("formation_rl.apps.diagnose", [], "ckpt = None is invalid: must be a policy.pt, last.pt, run directory or apf"),
    ("formation_rl.apps.diagnose", ["ckpt=[apf,/no/such/run]"], "ckpt = '/no/such/run' is invalid: no policy.pt"),
    ("formation_rl.apps.diagnose", ["ckpt=apf", "episodes=0"], "episodes = 0 is invalid: must be an integer >= 1"),
    ("formation_rl.apps.ceiling", ["trials=0"], "trials = 0 is invalid: must be an integer >= 1"),
    ("formation_rl.apps.ceiling", ["ranges=[0.2,-1]"], "ranges = [0.2, -1.0] is invalid: must be a non-empty list"),
    ("formation_rl.apps.ceiling", ["ranges=[0.2,near]"], "ranges = [0.2, 'near'] is invalid: Value 'near'"),
    ("formation_rl.apps.report", ["runs=/no/such/dir"], "runs = '/no/such/dir' is invalid: no such directory"),
    ("formation_rl.apps.report", ["runs=[.]", "smooth=2"], "smooth = 2.0 is invalid: must be in [0, 1)"),
    ("formation_rl.apps.report", ["runs=.", "group=algo.name"], "group: unknown key; allowed here: by, out, runs"),
]


@pytest.mark.parametrize("entry,args,message", BAD_INPUT, ids=[f"{e.split('.')[-1]} {' '.join(a)}"
                                                               for e, a, _ in BAD_INPUT])
def test_bad_input_is_one_line_before_compute(tmp_path, capsys, entry, args, message):
    """`make train|eval|render|demo|diagnose|ceiling|compare|sweep` with bad input: one line naming field, value
    and what is allowed, exit code 2, nothing written. ``train`` rows run in process (override pre-check, then the
    typed config's validation, as the CLI does); the others run the real command."""
    if entry == "train":
        with pytest.raises((SystemExit, ValueError)) as err:
            check_overrides(TrainConfig, ("algo", "formation", "reward", "budget", "env"), args)
            import formation_rl.apps.train  # noqa: F401  (registers the schema)

            with initialize_config_dir(config_dir=str(ROOT / "formation_rl" / "conf"), version_base=None):
                cfg = compose(config_name="config", overrides=args)
            Trainer(to_train_config(cfg), tmp_path).load_checkpoint(cfg.resume)
        text = capsys.readouterr().err.strip() if err.type is SystemExit else f"error: {err.value}"
        code = 2 if err.type is ValueError else err.value.code
    else:
        hydra_dirs = [f"hydra.run.dir={tmp_path}", f"hydra.sweep.dir={tmp_path}"]
        out = subprocess.run([sys.executable, "-m", entry, *args, *hydra_dirs], cwd=tmp_path, capture_output=True,
                             text=True, timeout=300, env={**os.environ, "PYTHONPATH": str(ROOT)})
        text, code = out.stderr.strip(), out.returncode
    assert code == 2 and text.startswith("error: ") and "\n" not in text, text[-1500:]
    assert message in text
    assert not [p for p in tmp_path.rglob("*") if p.suffix in (".pt", ".json", ".csv", ".png", ".gif")]

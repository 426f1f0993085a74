"""The training loop: collect -> extend -> sample -> losses -> optimisers -> soft update -> priorities -> log.

One :class:`Trainer` per run directory; ``train()`` runs to ``total_frames``, evaluating and
checkpointing on the way. Everything a resume needs is one :meth:`Trainer.state_dict`, saved as
``checkpoints/last.pt``.
"""

from __future__ import annotations

import contextlib
import dataclasses
import random
import time
import warnings
from pathlib import Path

import numpy as np
import torch
from omegaconf import DictConfig, OmegaConf
from tensordict import TensorDictBase
from tensordict.nn import TensorDictSequential
from torchrl.collectors import Collector
from torchrl.data.postprocs import MultiStep
from torchrl.envs.utils import ExplorationType, set_exploration_type
from torchrl.modules import AdditiveGaussianModule, EGreedyModule
from torchrl.record.loggers.tensorboard import TensorboardLogger
from tqdm import tqdm

import formation_rl
from formation_rl.algorithms import PRIORITY_KEY, WEIGHT_KEY, NonFiniteError, make_algorithm
from formation_rl.envs import EnvConfig, FormationEnv
from formation_rl.envs.metrics import EpisodeTracker, episode_metrics, summarize
from formation_rl.models import make_actor, make_critic, set_precision
from formation_rl.models.controller import APFController, residual_base
from formation_rl.training.checkpoint import (
    BEST_POLICY,
    CHECKPOINT,
    FORMAT,
    POLICY,
    atomic_save,
    load_checkpoint_file,
    resolve_checkpoint,
)
from formation_rl.training.config import TrainConfig, resolve_precision, validate
from formation_rl.training.replay import make_replay_buffer, to_transitions
from formation_rl.training.timing import Timings


def to_train_config(cfg: DictConfig) -> TrainConfig:
    """The typed ``TrainConfig`` of Hydra's composed config (``EnvConfig.from_dict`` builds the world's part)."""
    cfg = OmegaConf.to_container(cfg, resolve=True)
    out = TrainConfig(**{k: v for k, v in cfg.items() if k not in ("env", "algo", "model")})
    out.env = EnvConfig.from_dict(cfg.get("env", {}))
    out.algo = dataclasses.replace(out.algo, **cfg.get("algo", {}))
    out.model = dataclasses.replace(out.model, **cfg.get("model", {}))
    return out


class Trainer:
    def __init__(self, cfg: TrainConfig, run_dir: str | Path):
        validate(cfg)
        cfg.env.validate()
        cfg = dataclasses.replace(cfg, precision=resolve_precision(cfg.precision, cfg.device))
        self.cfg, self.run_dir = cfg, Path(run_dir)
        _check_writable(self.run_dir)
        if cfg.threads:
            torch.set_num_threads(cfg.threads)
        a = cfg.algo
        self._seed_everything(cfg.seed)
        dev = torch.device(cfg.device)
        self.env = FormationEnv(cfg.num_envs, config=cfg.env, device=dev, seed=cfg.seed,
                                compile_physics=cfg.compile_env, start_anywhere=cfg.start_anywhere,
                                start_team=cfg.start_team)
        self.eval_env = FormationEnv(cfg.eval_episodes, config=cfg.env, device=dev, seed=cfg.eval_seed)
        n, d, hidden = cfg.env.num_robots, cfg.env.obs_dim, tuple(cfg.model.hidden)
        self.actor = make_actor(n, d, hidden, cfg.model.activation, base=residual_base(cfg.model, cfg.env),
                                residual_scale=cfg.model.residual_scale).to(dev)
        critic = make_critic(n, d, tuple(_critic_sizes(cfg.model.critic_hidden, hidden)), cfg.model.activation,
                             own_only=(0,) if cfg.model.leader_critic == "own" else (),
                             layer_norm=(0,) if cfg.model.critic_layer_norm == "leader" else ()).to(dev)
        set_precision(self.actor, cfg.precision)
        set_precision(critic, cfg.precision)
        self.algo = make_algorithm(self.actor, critic, a)
        if a.bc_weight > 0:  # the classical controller anchors the actor loss
            self.algo.anchor = APFController(cfg.env).to(dev)
        if cfg.cudagraphs:
            self.algo.enable_cudagraphs()
        # exploration noise on the collection policy only (evaluation and targets use self.actor)
        self.noise = AdditiveGaussianModule(
            spec=self.env.full_action_spec_unbatched[("agents", "action")].to(dev), sigma_init=a.exploration_sigma,
            sigma_end=a.exploration_sigma_end, annealing_num_steps=max(1, int(a.exploration_anneal * cfg.total_frames)),
            action_key=("agents", "action"), safe=True, device=dev,
        )
        self.explore = TensorDictSequential(self.actor, self.noise)
        if a.exploration_eps > 0:  # uniform random actions now and then, per robot (constant chance)
            self.explore.append(EGreedyModule(
                self.env.full_action_spec_unbatched[("agents", "action")].to(dev), eps_init=a.exploration_eps,
                eps_end=a.exploration_eps, action_key=("agents", "action"), device=dev))
        self.timings = Timings()  # wall time per section of the loop (train.log, perf/share_*)
        self.timings.watch_policy(self.explore)
        self.buffer = make_replay_buffer(a, dev)
        self.multistep = None
        if a.n_steps > 1:  # n-step TD targets: rewards summed and "next" shifted within each collector batch
            self.multistep = MultiStep(a.gamma, a.n_steps).to(dev)
            self.multistep.reward_keys = (("agents", "reward"),)
        self.tracker = EpisodeTracker(cfg.num_envs, cfg.env.goal_radius, dev)
        self.frames = self.episodes = 0
        self._resumed_frames = 0  # frames already done when this process started (for frames/s)
        self.next_eval, self.next_checkpoint = cfg.eval_interval, cfg.checkpoint_interval
        self.last_eval: dict[str, float] = {}
        self.eval_frame = -1  # frames at the last evaluation
        self.best: dict | None = None  # best validation so far: frames, success, RFSE (BEST_POLICY: its actors)
        self.logger: TensorboardLogger | None = None
        self.on_evaluate: list = []  # callables (frames, metrics) run after every evaluation
        self._rng = _rng_state()  # train() starts from here, whatever ran in between (or the checkpoint's)

    # ------------------------------------------------------------------ the loop
    def train(self) -> dict[str, float]:
        """Train to ``total_frames``; return the final evaluation's metrics."""
        cfg, a = self.cfg, self.cfg.algo
        _set_rng_state(self._rng)
        setup = time.perf_counter()
        self.logger = TensorboardLogger(exp_name="tb", log_dir=str(self.run_dir))
        remaining = cfg.total_frames - self.frames
        per_batch = cfg.num_envs * cfg.steps_per_batch
        learn_from = max(a.batch_size, a.warmup_frames)  # no update before the buffer holds this much
        batches = -(-max(remaining, 1) // per_batch)  # whole collector batches (the last one may overshoot)
        warmup_batches = -(-max(0, a.warmup_frames - self.frames) // per_batch)
        collector = Collector(
            self.env, self.explore, frames_per_batch=per_batch, total_frames=batches * per_batch,
            init_random_frames=warmup_batches * per_batch, device=cfg.device,
            auto_register_policy_transforms=False,
        )
        self.timings.add("setup", time.perf_counter() - setup)
        bar = tqdm(total=cfg.total_frames, initial=self.frames, unit="frame", unit_scale=True,
                   disable=not cfg.progress, desc=a.name, dynamic_ncols=True)
        if self.frames == 0:
            self.evaluate()  # the untrained policy: the baseline every curve starts from
        credit, start, steps0 = 0, time.perf_counter(), self.algo.critic_steps
        latest: dict[str, float] = {}
        timings, waited_from, policy_seconds = self.timings, time.perf_counter(), self.timings.seconds["policy"]
        try:
            for data in collector:
                # the collector's wait is env stepping plus the policy's forward passes (timed by hooks)
                timings.add("env", time.perf_counter() - waited_from - (timings.seconds["policy"] - policy_seconds))
                if self.frames >= cfg.total_frames:
                    break
                self.frames += data.numel()
                with timings("metrics"):
                    _check_inputs(data, self.frames)
                    finished = self.tracker.update(data)
                    self.episodes += finished["length"].numel()
                with timings("buffer_extend"):
                    self._extend(data)
                # one gradient step (every robot at once) per update_every collected frames
                credit = credit + data.numel() if len(self.buffer) >= learn_from else 0
                losses = []
                while credit >= a.update_every:
                    credit -= a.update_every
                    try:
                        losses.append(self._gradient_step())
                    except NonFiniteError as err:
                        raise NonFiniteError(f"training stopped at frame {self.frames:,} (gradient step "
                                             f"{self.algo.critic_steps + 1}): {err}; the last good checkpoint "
                                             f"{self.run_dir / CHECKPOINT} is kept") from None
                self.noise.step(data.numel())
                with timings("logging"):
                    latest = self._log_train(finished, losses, latest, start, steps0)
                if self.frames >= self.next_eval:
                    self.evaluate()
                    self.next_eval += cfg.eval_interval
                if self.frames >= self.next_checkpoint:
                    self.save_checkpoint()
                    self.next_checkpoint += cfg.checkpoint_interval
                with timings("logging"):
                    bar.update(data.numel())
                    bar.set_postfix(self._postfix(latest, start), refresh=False)
                waited_from, policy_seconds = time.perf_counter(), timings.seconds["policy"]
        finally:
            collector.shutdown()
            bar.close()
        final = self.last_eval if self.eval_frame == self.frames else self.evaluate()
        self.save_checkpoint()
        self.logger.experiment.flush()
        return final

    def _extend(self, data: TensorDictBase) -> None:
        """Store a collector batch ``[B, T]`` as transitions, and with ``algo.her`` its hindsight copies."""
        batches = [data]
        if self.cfg.algo.her > 0:  # one hindsight goal per chosen copy: the leader's position after a random step
            rows = (torch.rand(data.shape[0], device=data.device) < self.cfg.algo.her).nonzero().squeeze(-1)
            if rows.numel():
                steps = torch.randint(data.shape[1], (rows.numel(),), device=data.device)
                goal = data.get(("next", "state", "positions"))[rows, steps, 0]  # [R, 2]
                part = data[rows]
                batches.append(self.env.relabel_goal(part, goal[:, None].expand(-1, data.shape[1], 2)))
        for batch in batches:
            self.buffer.extend(to_transitions(batch if self.multistep is None else self.multistep(batch)))

    def _gradient_step(self) -> dict[str, torch.Tensor]:
        with self.timings("buffer_sample"):
            batch = self.buffer.sample()
        with self.timings("update"):
            out = self.algo.update(batch)  # writes |delta| [B, N] at PRIORITY_KEY
        if self.cfg.algo.prioritized:
            with self.timings("priority"):
                self.buffer.update_tensordict_priority(batch)  # reduction max over robots (eq. 17)
            out["priority_mean"] = batch.get(PRIORITY_KEY).amax(-1).mean()
            out["priority_max"] = batch.get(PRIORITY_KEY).max()
            out["weight_mean"] = batch.get(WEIGHT_KEY).mean()
        return out

    # ------------------------------------------------------------------ evaluation
    @torch.no_grad()
    def evaluate(self) -> dict[str, float]:
        """Deterministic actors on the fixed validation set (``eval_episodes`` copies, ``eval_seed``)."""
        self.eval_env.set_seed(self.cfg.eval_seed)
        with self.timings("evaluation"), set_exploration_type(ExplorationType.DETERMINISTIC), self.deployed():
            rollout = self.eval_env.rollout(self.cfg.env.max_steps, self.actor, break_when_any_done=False)
            metrics = summarize(episode_metrics(rollout, self.cfg.env.goal_radius))
        if self.logger is not None:
            for k, v in metrics.items():
                self.logger.log_scalar(f"eval/{k}", v, step=self.frames)
        self.last_eval, self.eval_frame = metrics, self.frames
        if self.frames > 0 and _better(metrics, self.best):
            self.best = {"frames": self.frames, "success": metrics["success"], "RFSE": metrics["RFSE"]}
            with self.timings("checkpoint"):
                atomic_save({**self.policy_state(), "validation": dict(self.best)}, self.run_dir / BEST_POLICY)
        for hook in self.on_evaluate:  # e.g. a tuning study's pruner (it may raise to stop the run)
            hook(self.frames, metrics)
        return metrics

    # ------------------------------------------------------------------ logging
    def _log_train(self, finished, losses, latest, start, steps0) -> dict[str, float]:
        log = self.logger.log_scalar
        if finished["length"].numel():
            latest = summarize(finished)
            for k, v in latest.items():
                log(f"train/{k}", v, step=self.frames)
            log("train_by_episode/episode_reward", latest["episode_reward"], step=self.episodes)
            log("train_by_episode/success", latest["success"], step=self.episodes)
        if losses:
            for k in losses[-1]:
                values = [o[k] for o in losses if k in o]
                log(f"loss/{k}" if k.startswith("loss") else f"algo/{k}", torch.stack(values).mean().item(),
                    step=self.frames)
        elapsed = max(time.perf_counter() - start, 1e-9)
        log("perf/episodes", self.episodes, step=self.frames)
        log("perf/frames_per_s", self._session_frames() / elapsed, step=self.frames)
        log("perf/grad_steps_per_s", (self.algo.critic_steps - steps0) / elapsed, step=self.frames)
        log("train/exploration_sigma", self.noise.sigma.item(), step=self.frames)
        for k, v in self.timings.split().items():
            log(f"perf/share_{k}", v, step=self.frames)
        return latest

    def _session_frames(self) -> int:
        return self.frames - self._resumed_frames

    def _postfix(self, latest: dict[str, float], start: float) -> dict[str, str]:
        fps = self._session_frames() / max(time.perf_counter() - start, 1e-9)
        out = {"fps": f"{fps:,.0f}", "steps": str(self.algo.critic_steps)}
        if latest:
            out.update(reward=f"{latest['episode_reward']:.0f}", success=f"{latest['success']:.2f}",
                       CBRO=f"{latest['CBRO']:.1f}")
        return out

    # ------------------------------------------------------------------ checkpoints
    def state_dict(self) -> dict:
        """Everything a resume needs: actors, critics and their targets, optimisers and step counts, the
        exploration noise's schedule, the frame and episode counters, every random generator (the training
        world's scenario generator too) and, with ``save_buffer``, the replay buffer with its priorities."""
        return {
            "format": FORMAT,
            "version": formation_rl.__version__,
            "config": dataclasses.asdict(self.cfg),
            "algo": self.algo.state_dict(),
            "noise": self.noise.state_dict(),
            "counters": {"frames": self.frames, "episodes": self.episodes, "next_eval": self.next_eval,
                         "next_checkpoint": self.next_checkpoint, "best": self.best},
            "rng": {**_rng_state(), "env": self.env.rng_state()},
            "buffer": self.buffer.state_dict() if self.cfg.save_buffer else None,
        }

    def load_state_dict(self, state: dict) -> None:
        """Continue from a :meth:`state_dict`; the algorithm, team and network sizes must be this run's. The
        random generators are restored now, and ``train()`` starts from them."""
        saved = state["config"]
        for name, now, then in (
            ("algo.name", self.cfg.algo.name, saved["algo"]["name"]),
            ("env.num_robots", self.cfg.env.num_robots, saved["env"]["num_robots"]),
            ("env.num_obstacles", self.cfg.env.num_obstacles, saved["env"]["num_obstacles"]),
            ("model.hidden", list(self.cfg.model.hidden), list(saved["model"]["hidden"])),
            ("model.leader_critic", self.cfg.model.leader_critic, saved["model"].get("leader_critic", "joint")),
            ("model.critic_hidden", _critic_sizes(self.cfg.model.critic_hidden, self.cfg.model.hidden),
             _critic_sizes(saved["model"].get("critic_hidden"), saved["model"]["hidden"])),
        ):
            if now != then:
                raise ValueError(f"resume: {name} = {now!r} but the checkpoint has {then!r}; they must match")
        self.algo.load_state_dict(state["algo"])
        self.noise.load_state_dict(state["noise"])
        c = state["counters"]
        self.frames, self.episodes = c["frames"], c["episodes"]
        self.next_eval, self.next_checkpoint = c["next_eval"], c["next_checkpoint"]
        self.best = c.get("best")  # absent in checkpoints written before best_policy.pt existed
        self._resumed_frames = self.frames
        self.env.set_rng_state(state["rng"]["env"])
        self._rng = state["rng"]
        _set_rng_state(self._rng)
        if state.get("buffer") is not None:
            self.buffer.load_state_dict(state["buffer"])
        elif self.cfg.save_buffer:
            warnings.warn("resume: the checkpoint holds no replay buffer (saved with save_buffer=false, or by a "
                          "formation_rl that kept it in checkpoints/buffer/): the buffer starts empty and refills",
                          stacklevel=2)

    def save_checkpoint(self) -> Path:
        """:meth:`state_dict` to ``checkpoints/last.pt`` and the actors alone to ``checkpoints/policy.pt``, each
        written atomically (a crash leaves the previous file)."""
        path = self.run_dir / CHECKPOINT
        with self.timings("checkpoint"):
            atomic_save(self.state_dict(), path)
            atomic_save(self.policy_state(), self.run_dir / POLICY)
        return path

    def load_checkpoint(self, path: str | Path) -> None:
        """Resume from a ``last.pt``, a run directory, or ``auto`` (this run's own ``last.pt``)."""
        path = resolve_checkpoint(path, self.run_dir)
        state = load_checkpoint_file(path)  # its errors name the file already
        try:
            self.load_state_dict(state)
        except ValueError as err:
            raise ValueError(f"{err} ({path})") from None

    def policy_state(self) -> dict:
        """What :func:`formation_rl.load_policy` reads: the actors (``algo.deploy``'s), their world and network
        config."""
        with self.deployed():
            actor = {k: v.detach().clone() for k, v in self.actor.state_dict().items()}
        return {"format": FORMAT, "version": formation_rl.__version__, "algo": self.cfg.algo.name,
                "env": dataclasses.asdict(self.cfg.env), "model": dataclasses.asdict(self.cfg.model),
                "actor": actor}

    def deployed(self):
        """Inside it ``self.actor`` holds the deployed parameters: its own, or with ``algo.deploy=target`` the
        loss's target actors (their Polyak average), swapped in and back by tensordict's ``to_module``."""
        if self.cfg.algo.deploy == "target":
            return self.algo.loss.target_actor_network_params.to_module(self.actor)
        return contextlib.nullcontext()

    @staticmethod
    def _seed_everything(seed: int) -> None:
        torch.manual_seed(seed)
        np.random.seed(seed % 2**32)
        random.seed(seed)


def _better(metrics: dict[str, float], best: dict | None) -> bool:
    """Validation success first, then the lower RFSE (so before any success, the tightest formation)."""
    return best is None or (metrics["success"], -metrics["RFSE"]) > (best["success"], -best["RFSE"])


def _rng_state() -> dict:
    return {"torch": torch.get_rng_state(), "numpy": np.random.get_state(), "python": random.getstate(),
            "cuda": torch.cuda.get_rng_state_all() if torch.cuda.is_available() else None}


def _set_rng_state(state: dict) -> None:
    torch.set_rng_state(state["torch"])
    np.random.set_state(state["numpy"])
    random.setstate(state["python"])
    if state.get("cuda") is not None and torch.cuda.is_available():
        torch.cuda.set_rng_state_all(state["cuda"])


def _check_inputs(data, frames: int) -> None:
    """Stop on a NaN or infinite observation or reward before it reaches the replay buffer."""
    for key in (("next", "agents", "observation"), ("next", "agents", "reward")):
        if not torch.isfinite(data.get(key)).all():
            raise NonFiniteError(f"training stopped at frame {frames:,}: a non-finite {key[-1]} came from the "
                                 "environment; the last good checkpoint is kept")


def _critic_sizes(critic_hidden, hidden) -> list[int]:
    """The critics' hidden layer sizes, a plain list: ``model.critic_hidden``, or ``model.hidden`` where null."""
    return [int(h) for h in (critic_hidden or hidden)]


def _check_writable(run_dir: Path) -> None:
    """Fail before any compute when the run directory cannot take checkpoints and logs."""
    try:
        (run_dir / "checkpoints").mkdir(parents=True, exist_ok=True)
        probe = run_dir / "checkpoints" / ".write_test"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as err:
        raise ValueError(f"run directory {run_dir} is not writable: {err.strerror or err}") from None

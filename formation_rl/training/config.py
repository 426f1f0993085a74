"""Typed training configuration (Hydra ConfigStore schema). Defaults: reference.md, Algorithms, unless marked choice.

``conf/config.yaml`` and the ``conf/algo/`` and ``conf/budget/`` groups fill these; a misspelt key
or a wrong type fails at start with Hydra's message, an out-of-range value with ``validate``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from hydra.core.config_store import ConfigStore

from formation_rl.algorithms.config import AlgoConfig
from formation_rl.envs.config import EnvConfig
from formation_rl.models.config import ModelConfig

ALGORITHMS = ("maddpg", "matd3", "per_matd3")
__all__ = ["ALGORITHMS", "AlgoConfig", "ModelConfig", "TrainConfig", "register", "validate"]


@dataclass
class TrainConfig:
    env: EnvConfig = field(default_factory=EnvConfig)
    algo: AlgoConfig = field(default_factory=AlgoConfig)
    model: ModelConfig = field(default_factory=ModelConfig)
    seed: int = 0  # training seed: networks, exploration and training scenarios
    start_anywhere: float = 0.0  # share of training episodes whose robots start anywhere in the arena (exploring
    #                              starts, ours); evaluation always starts in the default square
    start_team: bool = False  # those starts move the start square, team and all, anywhere in the arena; false: each
    #                           robot anywhere on its own (ours)
    total_frames: int = 300_000  # frames = transitions of one env copy (reference.md, Algorithms); paper: 9,000,000
    num_envs: int = 64  # env copies stepped together by the collector
    steps_per_batch: int = 25  # collector batch = num_envs x steps_per_batch frames
    device: str = "cpu"  # cpu | cuda | cuda:0 ...
    compile_env: bool = False  # torch.compile the env's step program (faster at large num_envs)
    cudagraphs: bool = False  # replay each gradient step from CUDA graphs (device=cuda; the policy is not graphed)
    eval_interval: int = 100_000  # frames between deterministic evaluations (and at the end)
    eval_episodes: int = 100  # validation episodes per evaluation (eval_seed, not make eval's test set), batched
    eval_seed: int = 1_000_000_007  # scenario seed of the validation set, disjoint from training and test seeds
    checkpoint_interval: int = 100_000  # frames between checkpoints (and at the end)
    save_buffer: bool = False  # also checkpoint the replay buffer, inside last.pt (large: ~1 kB per frame)
    resume: str | None = None  # a checkpoint file or run directory to continue from; "auto": this run's
    progress: bool = True  # progress bar
    threads: int | None = None  # torch intra-op threads (None: torch's default; sweeps set 1 per job)
    precision: str = "fp32"  # fp32 | bf16: the update's forward and backward in bf16 (hidden layers; fp32 weights,
    #                          optimiser, output layers, TD targets and priorities) | bf16_targets: the TD targets'
    #                          hidden layers in bf16 too (their output layers, arithmetic and the priorities fp32);
    #                          both need a CPU with AVX512-BF16/AMX or a GPU with bf16 | auto: bf16_targets where the
    #                          device has native bf16, else fp32 (the run's checkpoints and log record which)


def register() -> None:
    ConfigStore.instance().store(name="train_schema", node=TrainConfig)


BF16_MIN_SPEEDUP = 1.2  # auto takes bf16 from this speedup (square matmuls: AMD EPYCs 2.3-4.5x, an Intel Xeon 0.55x)


def resolve_precision(precision: str, device: str) -> str:
    """``auto`` -> ``bf16_targets`` where the device runs bf16 GEMMs at least 1.2x faster than fp32, measured
    (:func:`~formation_rl.models.bf16_speedup`; the learning A/B: docs/RESULTS.md, Precision), else ``fp32``;
    any other value as it is."""
    if precision != "auto":
        return precision
    from formation_rl.models import bf16_speedup

    return "bf16_targets" if bf16_speedup(device) >= BF16_MIN_SPEEDUP else "fp32"


def validate(cfg: TrainConfig) -> None:
    """One ``ValueError`` per bad value, naming the field, the value and what is allowed."""
    a = cfg.algo

    def check(ok: bool, name: str, value, allowed: str) -> None:
        if not ok:
            raise ValueError(f"{name} = {value!r} is invalid: must be {allowed}")

    check(a.name in ALGORITHMS, "algo.name", a.name, f"one of {', '.join(ALGORITHMS)}")
    check(a.num_critics in (1, 2), "algo.num_critics", a.num_critics, "1 or 2")
    for name in ("lr_actor", "lr_critic"):
        check(getattr(a, name) > 0, f"algo.{name}", getattr(a, name), "> 0")
    for name in ("gamma", "tau", "alpha", "beta"):
        check(0 <= getattr(a, name) <= 1, f"algo.{name}", getattr(a, name), "in [0, 1]")
    check(a.priority_eps > 0, "algo.priority_eps", a.priority_eps, "> 0")
    check(a.policy_noise >= 0 and a.noise_clip >= 0, "algo.policy_noise", a.policy_noise, ">= 0 (noise_clip too)")
    check(a.policy_delay >= 1, "algo.policy_delay", a.policy_delay, "an integer >= 1")
    check(a.batch_size >= 1, "algo.batch_size", a.batch_size, "an integer >= 1")
    check(a.buffer_size >= a.batch_size, "algo.buffer_size", a.buffer_size, f">= algo.batch_size ({a.batch_size})")
    check(a.update_every >= 1, "algo.update_every", a.update_every, "an integer >= 1")
    check(a.n_steps >= 1, "algo.n_steps", a.n_steps, "an integer >= 1")
    check(a.action_reg >= 0, "algo.action_reg", a.action_reg, ">= 0")
    check(a.warmup_frames >= 0, "algo.warmup_frames", a.warmup_frames, ">= 0")
    check(a.critic_warmup_steps >= 0, "algo.critic_warmup_steps", a.critic_warmup_steps, "an integer >= 0")
    check(a.bc_weight >= 0, "algo.bc_weight", a.bc_weight, ">= 0")
    check(a.exploration_sigma >= a.exploration_sigma_end >= 0, "algo.exploration_sigma", a.exploration_sigma,
          f">= exploration_sigma_end ({a.exploration_sigma_end}) >= 0")
    check(a.deploy in ("actor", "target"), "algo.deploy", a.deploy, "actor or target")
    check(0 < a.exploration_anneal <= 1, "algo.exploration_anneal", a.exploration_anneal, "in (0, 1]")
    check(0 <= a.exploration_eps <= 1, "algo.exploration_eps", a.exploration_eps, "in [0, 1]")
    check(0 <= a.her <= 1, "algo.her", a.her, "in [0, 1]")
    def layer_sizes(sizes) -> bool:
        return len(sizes) >= 1 and all(h >= 1 for h in sizes)

    check(layer_sizes(cfg.model.hidden), "model.hidden", cfg.model.hidden, "a non-empty list of positive layer sizes")
    check(cfg.model.critic_hidden is None or layer_sizes(cfg.model.critic_hidden), "model.critic_hidden",
          cfg.model.critic_hidden, "null or a non-empty list of positive layer sizes")
    check(cfg.model.residual in ("none", "apf"), "model.residual", cfg.model.residual, "none or apf")
    check(cfg.model.residual_scale > 0, "model.residual_scale", cfg.model.residual_scale, "> 0")
    check(cfg.model.leader_critic in ("joint", "own"), "model.leader_critic", cfg.model.leader_critic, "joint or own")
    check(cfg.model.critic_layer_norm in ("none", "leader"), "model.critic_layer_norm",
          cfg.model.critic_layer_norm, "none or leader")
    check(0 <= cfg.start_anywhere <= 1, "start_anywhere", cfg.start_anywhere, "in [0, 1]")
    check(cfg.total_frames >= 1, "total_frames", cfg.total_frames, "an integer >= 1")
    check(cfg.num_envs >= 1, "num_envs", cfg.num_envs, "an integer >= 1")
    check(cfg.steps_per_batch >= 1, "steps_per_batch", cfg.steps_per_batch, "an integer >= 1")
    for name in ("eval_interval", "checkpoint_interval", "eval_episodes"):
        check(getattr(cfg, name) >= 1, name, getattr(cfg, name), "an integer >= 1")
    check(cfg.threads is None or cfg.threads >= 1, "threads", cfg.threads, "null or an integer >= 1")
    from formation_rl.utils import check_device  # the check make eval, render and demo make too

    check_device(cfg.device)
    from formation_rl.models import bf16_supported
    from formation_rl.models.networks import PRECISIONS

    allowed = (*PRECISIONS, "auto")
    check(cfg.precision in allowed, "precision", cfg.precision, " or ".join(allowed))
    if cfg.precision not in ("fp32", "auto"):

        check(bf16_supported(cfg.device), "precision", cfg.precision,
              f"fp32 on this {cfg.device}: it has no native bf16 (CPU: AVX512-BF16 or AMX; GPU: bf16 support), "
              "where bf16 would run slower, not faster")
    check(not cfg.cudagraphs or cfg.device.startswith("cuda"), "cudagraphs", cfg.cudagraphs,
          f"false with device={cfg.device} (CUDA graphs need device=cuda)")

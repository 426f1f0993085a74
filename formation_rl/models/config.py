"""The actors' architecture, as a checkpoint records it: part of the training schema
(:class:`~formation_rl.training.config.TrainConfig`), read back by :func:`~formation_rl.load_policy`."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass
class ModelConfig:
    hidden: list[int] = field(default_factory=lambda: [128, 128])  # actor and critic hidden layers (paper)
    critic_hidden: list[int] | None = None  # the critics' hidden layers where they differ from the actors' (None:
    #                                         `hidden`); the actors keep `hidden`
    activation: str = "relu"  # (paper)
    residual: str = "none"  # none: the paper's actors | apf: each actor outputs a correction to the classical
    # controller, clip(apf(o) + residual_scale * tanh(mu(o)), -1, 1), starting at zero (ours, not the paper's)
    residual_scale: float = 0.5  # model.residual=apf: the largest correction per action component
    leader_critic: str = "joint"  # joint: the paper's centralized critic for every robot | own: the leader's critic
    #                               reads its own observation and action only (ours; for rewards where the leader
    #                               answers for nothing the followers do, env.reward.leader_robot_collision=0)
    critic_layer_norm: str = "none"  # leader: layer normalisation (no affine) before every hidden ReLU of the leader's
    #                                  critic | none (every critic: not kept, docs/RESULTS.md "Layer normalisation ...")

"""The algorithm's settings (the ``algo`` part of the training schema,
:class:`~formation_rl.training.config.TrainConfig`; ``conf/algo/*.yaml``).
Defaults: reference.md, Algorithms, unless marked choice."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class AlgoConfig:
    name: str = "per_matd3"  # maddpg | matd3 | per_matd3
    num_critics: int = 2  # twin critics, target = min of the two (eq. 7); 1 for MADDPG
    policy_noise: float = 0.2  # target policy smoothing N(0, lambda) (eq. 8, paper lambda = 0.2); 0 for MADDPG
    noise_clip: float = 0.5  # clip of that noise (eq. 8)
    policy_delay: int = 2  # d: actor and target update every d critic steps
    prioritized: bool = True  # PER (section 3.3)
    alpha: float = 0.6  # priority exponent (paper)
    beta: float = 0.5  # importance-sampling exponent (paper)
    priority_eps: float = 1e-6  # p = (max |delta| + eps)^alpha (choice)
    lr_actor: float = 1e-3  # (paper)
    lr_critic: float = 1e-3  # (paper)
    deploy: str = "actor"  # the actors that are evaluated, selected and saved as the policy: "actor", the trained
    #                        ones (the paper's), or "target", their Polyak average that TD3/DDPG keep for the TD
    #                        targets (tau per actor step; choice)
    gamma: float = 0.95  # (paper)
    tau: float = 0.01  # soft target update (choice)
    batch_size: int = 1024  # (paper)
    buffer_size: int = 1_000_000  # (paper)
    update_every: int = 100  # collected frames per gradient step (paper: update every 100 steps)
    n_steps: int = 1  # TD target over n steps (TorchRL's MultiStep on each collector batch); 1: the paper's
    #                   one-step target (eq. 7); episodes and collector batches cut it short
    action_reg: float = 1e-3  # actor loss += action_reg * mean(pre-tanh^2), against tanh saturation (choice:
    #                           the MADDPG reference implementation's value; 0 turns it off)
    warmup_frames: int = 10_000  # frames collected before the first update (choice)
    bc_weight: float = 0.0  # > 0: the actor loss becomes -Q / mean|Q| + bc_weight * mean((a - apf(o))^2) on every
    #                         batch (TD3+BC's form, the classical controller as the anchor); 0: the paper's -Q
    critic_warmup_steps: int = 0  # first gradient steps that train the critics only (targets still follow):
    #                               the critics learn the initial actors' value before the actors move (choice)
    exploration_sigma: float = 0.3  # Gaussian exploration noise on the collection policy, start (choice)
    exploration_sigma_end: float = 0.05  # ... end (choice)
    exploration_anneal: float = 0.5  # fraction of total_frames over which sigma anneals (choice)
    exploration_eps: float = 0.0  # per robot and step, the chance that a uniform random action replaces the noisy
    #                               one (TorchRL's EGreedyModule; ours: lets a robot pinned at a wall try moving off)
    her: float = 0.0  # hindsight goals (ours): this share of each collector batch's env copies is stored a second
    #                   time with the leader's goal moved to where the leader is at a random step of that batch
    #                   (observations and rewards measured again from the stored world states); 0: off

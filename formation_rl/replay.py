"""Replay: TorchRL's uniform and prioritized buffers, and collector batches turned into transitions."""

from __future__ import annotations

import torch
from tensordict import TensorDictBase
from torchrl.data import LazyTensorStorage, TensorDictPrioritizedReplayBuffer, TensorDictReplayBuffer

from formation_rl.algorithms import PRIORITY_KEY
from formation_rl.config import AlgoConfig

# what a transition keeps: the world state and diagnostics stay out of the buffer (~1 kB per frame)
TRANSITION_KEYS = [
    ("agents", "observation"),
    ("agents", "action"),
    ("next", "agents", "observation"),
    ("next", "agents", "reward"),
    ("next", "agents", "done"),
    ("next", "agents", "terminated"),
]


def make_replay_buffer(cfg: AlgoConfig, device: torch.device | str = "cpu"):
    """Uniform (MADDPG, MATD3) or prioritized (PER-MATD3) TorchRL buffer of ``cfg.buffer_size`` frames."""
    storage = LazyTensorStorage(cfg.buffer_size, device=device)
    if cfg.prioritized:
        # priority p = (max over robots of |delta| + eps)^alpha (eq. 17); weights (p / p_min)^-beta (eq. 20)
        return TensorDictPrioritizedReplayBuffer(
            alpha=cfg.alpha, beta=cfg.beta, eps=cfg.priority_eps, storage=storage, batch_size=cfg.batch_size,
            priority_key=PRIORITY_KEY, reduction="max",
        )
    return TensorDictReplayBuffer(storage=storage, batch_size=cfg.batch_size)


def to_transitions(batch: TensorDictBase) -> TensorDictBase:
    """A collector batch ``[B, T]`` as ``[B*T]`` transitions, done flags copied per robot ``[.., N, 1]``."""
    nxt = batch.get("next")
    shape = nxt.get(("agents", "reward")).shape  # [B, T, N, 1]
    for key in ("done", "terminated"):
        nxt.set(("agents", key), nxt.get(key).unsqueeze(-2).expand(shape))
    return batch.select(*TRANSITION_KEYS).reshape(-1)

"""Replay: TorchRL's uniform and prioritized buffers, and collector batches turned into transitions."""

from __future__ import annotations

import torch
from tensordict import TensorDictBase
from torchrl.data import LazyTensorStorage, TensorDictPrioritizedReplayBuffer, TensorDictReplayBuffer

from formation_rl.algorithms import PRIORITY_KEY
from formation_rl.algorithms.config import AlgoConfig

# what a transition keeps: the world state and diagnostics stay out of the buffer (~1 kB per frame)
TRANSITION_KEYS = [
    ("agents", "observation"),
    ("agents", "action"),
    ("next", "agents", "observation"),
    ("next", "agents", "reward"),
    ("next", "agents", "done"),
    ("next", "agents", "terminated"),
]


def priority_tree_device(device: torch.device | str) -> torch.device:
    """Where PER's sum and min trees live: beside a CUDA storage when the installed TorchRL extension has
    CUDA trees, else on the CPU (TorchRL wheels built without CUDA refuse a CUDA tree)."""
    device = torch.device(device)
    if device.type == "cuda":
        from torchrl.data.replay_buffers.samplers import prioritized

        if prioritized.CudaSumSegmentTreeFp32 is not None:
            return device
    return torch.device("cpu")


def make_replay_buffer(cfg: AlgoConfig, device: torch.device | str = "cpu"):
    """Uniform (MADDPG, MATD3) or prioritized (PER-MATD3) TorchRL buffer of ``cfg.buffer_size`` frames,
    its transitions stored on ``device``."""
    storage = LazyTensorStorage(cfg.buffer_size, device=device)
    if cfg.prioritized:
        # priority p = (max over robots of |delta| + eps)^alpha (eq. 17); weights (p / p_min)^-beta (eq. 20)
        return TensorDictPrioritizedReplayBuffer(
            alpha=cfg.alpha, beta=cfg.beta, eps=cfg.priority_eps, storage=storage, batch_size=cfg.batch_size,
            priority_key=PRIORITY_KEY, reduction="max", sampler_device=priority_tree_device(device),
        )
    return TensorDictReplayBuffer(storage=storage, batch_size=cfg.batch_size)


def to_transitions(batch: TensorDictBase) -> TensorDictBase:
    """A collector batch ``[B, T]`` as ``[B*T]`` transitions, done flags copied per robot ``[.., N, 1]``.

    After TorchRL's ``MultiStep`` (``algo.n_steps > 1``) the batch also carries ``steps_to_next_obs``
    ``[B, T]``, which the TD(0) estimator turns into ``gamma ** steps``; it is kept, per robot.
    """
    nxt = batch.get("next")
    shape = nxt.get(("agents", "reward")).shape  # [B, T, N, 1]
    for key in ("done", "terminated"):
        nxt.set(("agents", key), nxt.get(key).unsqueeze(-2).expand(shape))
    keys = list(TRANSITION_KEYS)
    steps = batch.get("steps_to_next_obs", None)
    if steps is not None:
        batch.set("steps_to_next_obs", steps.reshape(*shape[:2], 1, 1).expand(shape))
        keys.append("steps_to_next_obs")
    return batch.select(*keys).reshape(-1)

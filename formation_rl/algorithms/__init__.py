"""MADDPG, MATD3 and PER-MATD3 built from TorchRL's losses (docs/reference.md, Algorithms)."""

from __future__ import annotations

from formation_rl.algorithms.base import PRIORITY_KEY, WEIGHT_KEY, Algorithm, NonFiniteError
from formation_rl.algorithms.config import AlgoConfig
from formation_rl.algorithms.maddpg import MADDPG
from formation_rl.algorithms.matd3 import MATD3


def make_algorithm(actor, critic, cfg: AlgoConfig) -> Algorithm:
    """MADDPG for ``maddpg``; MATD3 for ``matd3`` and ``per_matd3`` (PER is in the replay buffer)."""
    if cfg.name == "maddpg":
        return MADDPG(actor, critic, cfg)
    return MATD3(actor, critic, cfg)


__all__ = ["Algorithm", "MADDPG", "MATD3", "NonFiniteError", "PRIORITY_KEY", "WEIGHT_KEY", "make_algorithm"]

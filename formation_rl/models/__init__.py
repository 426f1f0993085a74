"""Per-robot actors and centralized critics (docs/reference.md, Algorithms)."""

from formation_rl.models.networks import (
    CentralizedCritic,
    PerRobotMLP,
    bf16_speedup,
    bf16_supported,
    make_actor,
    make_critic,
    set_precision,
)

__all__ = [
    "CentralizedCritic",
    "PerRobotMLP",
    "bf16_speedup",
    "bf16_supported",
    "make_actor",
    "make_critic",
    "set_precision",
]

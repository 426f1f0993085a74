"""Per-robot actors and centralized critics (SPEC §5)."""

from formation_rl.models.networks import CentralizedCritic, PerRobotMLP, make_actor, make_critic

__all__ = ["CentralizedCritic", "PerRobotMLP", "make_actor", "make_critic"]

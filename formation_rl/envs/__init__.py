"""The formation world: TorchRL env, PettingZoo face, metrics and rendering."""

from formation_rl.envs import formation_v0
from formation_rl.envs.config import EnvConfig, FormationConfig, RewardConfig
from formation_rl.envs.formation_env import FormationEnv

__all__ = ["EnvConfig", "FormationConfig", "RewardConfig", "FormationEnv", "formation_v0"]

"""MADDPG (paper §3.1): TorchRL's DDPGLoss over per-robot centralized critics."""

from __future__ import annotations

from tensordict.nn import TensorDictModule
from torchrl.objectives import DDPGLoss

from formation_rl.algorithms.base import Algorithm
from formation_rl.algorithms.config import AlgoConfig


class MADDPG(Algorithm):
    critic_params_name = "value_network_params"

    def __init__(self, actor: TensorDictModule, critic: TensorDictModule, cfg: AlgoConfig):
        # target actor and target critic (delay_*), plain squared TD error
        self.loss = DDPGLoss(actor, critic, loss_function="l2", delay_actor=True, delay_value=True,
                             reduction="none", use_prioritized_weights=False)
        super().__init__(cfg)

    def _critic_loss(self, batch):
        return self.loss.loss_value(batch)  # DDPGLoss's name for TD3Loss's value_loss

    def _actor_critic(self):
        return self.loss.value_network, self.loss.value_network_params.detach()  # public: no private cache

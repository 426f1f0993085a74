"""MATD3 and PER-MATD3 (paper §3.2-3.3): TorchRL's TD3Loss over per-robot twin centralized critics.

TD3Loss gives the twin critics with the min target (eq. 7) and the clipped target-policy noise
(eq. 8); the actor delay (d) lives in :meth:`Algorithm.update`, since TD3Loss does not delay for
you. PER differs only in the replay buffer and the importance weights the batch carries.
"""

from __future__ import annotations

from tensordict.nn import TensorDictModule
from torchrl.objectives import TD3Loss

from formation_rl.algorithms.base import Algorithm
from formation_rl.algorithms.config import AlgoConfig


class MATD3(Algorithm):
    critic_params_name = "qvalue_network_params"

    def __init__(self, actor: TensorDictModule, critic: TensorDictModule, cfg: AlgoConfig):
        self.loss = TD3Loss(
            actor,
            critic,
            bounds=(-1.0, 1.0),
            num_qvalue_nets=cfg.num_critics,
            policy_noise=cfg.policy_noise,  # eq. 8: N(0, lambda) on the target action ...
            noise_clip=cfg.noise_clip,  # ... clipped to [-c, c]
            loss_function="l2",
            delay_actor=True,
            delay_qvalue=True,
            reduction="none",
            use_prioritized_weights=False,
        )
        super().__init__(cfg)

    def _actor_critic(self):
        return self.loss.qvalue_network, self.loss.qvalue_network_params[0].detach()  # Q1 (TD3); public attributes only

"""Training: the :class:`Trainer` loop, its replay buffer, checkpoint I/O, timings and the typed config.

Only the training apps (``formation_rl.apps.train``, ``formation_rl.apps.tune``), the benchmarks and
the tests import this package; loading and evaluating a policy (:mod:`formation_rl.evaluation`) never does.
"""

from formation_rl.training.config import AlgoConfig, ModelConfig, TrainConfig, validate
from formation_rl.training.trainer import Trainer, to_train_config

__all__ = ["AlgoConfig", "ModelConfig", "TrainConfig", "Trainer", "to_train_config", "validate"]

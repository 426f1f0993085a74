"""The command-line apps, one thin module per command: ``python -m formation_rl.apps.<name> [key=value ...]``
(train, evaluate, render, demo, report, diagnose, ceiling, tune; ``make help`` lists them). Each is a Hydra app:
a typed schema (a dataclass in the module; train's is :class:`formation_rl.training.config.TrainConfig`) and a
config in ``conf/<name>.yaml`` (train: ``config.yaml``, demo: ``rollout.yaml``).
No app imports another; what two apps share lives in the library (or in :mod:`formation_rl.apps.cli`)."""

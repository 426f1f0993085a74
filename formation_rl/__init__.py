"""formation_rl: multi-robot formation control with MADDPG / MATD3 / PER-MATD3 on TorchRL."""

__version__ = "0.1.0"


def load_policy(path, device="cpu", env_config=None):
    """A trained policy (callable from observations [..., N, D] to actions [..., N, 2], and a TorchRL policy);
    ``"apf"``: the classical controller for ``env_config`` (the world it acts in);
    see formation_rl.evaluation.policy."""
    from formation_rl.evaluation.policy import load_policy as _load

    return _load(path, device, env_config)

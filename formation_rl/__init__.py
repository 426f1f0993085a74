"""formation_rl: multi-robot formation control with MADDPG / MATD3 / PER-MATD3 on TorchRL."""

__version__ = "0.1.0"

"""Reading checkpoint and policy files: the file format and the one-line error for a file that is not one.

Written by :mod:`formation_rl.training.checkpoint`; read here, so that loading a policy needs no training code.
"""

from __future__ import annotations

from pathlib import Path

import torch

import formation_rl

POLICY = "checkpoints/policy.pt"
BEST_POLICY = "checkpoints/best_policy.pt"  # the actors of the run's best validation evaluation
FORMAT = 1  # checkpoint format version


def load_checkpoint_file(path: Path) -> dict:
    """Load a checkpoint or policy file, with one clear error for a corrupt or foreign one."""
    try:
        state = torch.load(path, map_location="cpu", weights_only=False)
    except Exception as err:  # truncated, corrupted, not a torch file
        kind = type(err).__name__
        raise ValueError(f"checkpoint {path} cannot be read ({kind}): it is truncated or corrupt") from None
    if not isinstance(state, dict) or "format" not in state:
        raise ValueError(f"checkpoint {path} is not a formation_rl checkpoint")
    if state["format"] != FORMAT:
        raise ValueError(f"checkpoint {path} has format {state['format']} (formation_rl {state.get('version')}); "
                         f"this formation_rl {formation_rl.__version__} reads format {FORMAT}")
    return state

"""Checkpoint I/O of a run: ``checkpoints/last.pt`` (the trainer's ``state_dict``: everything a resume needs),
``checkpoints/policy.pt`` (the actors alone) and ``checkpoints/best_policy.pt`` (the actors of the best
validation evaluation so far, success then RFSE, with its ``validation`` numbers), each written so that a
crash never leaves a half-written one.

The file format and its reader live in :mod:`formation_rl.evaluation.checkpoint` (loading a policy needs them).
"""

from __future__ import annotations

import os
from pathlib import Path

import torch

from formation_rl.evaluation.checkpoint import BEST_POLICY, FORMAT, POLICY, load_checkpoint_file

__all__ = ["BEST_POLICY", "CHECKPOINT", "FORMAT", "POLICY", "atomic_save", "load_checkpoint_file", "resolve_checkpoint"]

CHECKPOINT = "checkpoints/last.pt"


def atomic_save(obj, path: Path) -> None:
    """``torch.save`` to a temporary file, then rename: a crash never leaves a half-written file."""
    tmp = path.with_name(path.name + ".tmp")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        torch.save(obj, tmp)
        os.replace(tmp, path)
    except OSError as err:
        raise ValueError(f"cannot write {path}: {err.strerror or err}; the previous file there is unchanged") from None


def resolve_checkpoint(path: str | Path, run_dir: Path) -> Path:
    """``auto`` -> this run's last checkpoint; a run directory -> its last checkpoint; else the file."""
    p = run_dir / CHECKPOINT if str(path) in ("auto", "true", "True") else Path(path)
    if p.is_dir():
        p = p / CHECKPOINT
    if not p.is_file():
        raise ValueError(f"resume = {str(path)!r} is invalid: no checkpoint at {p}")
    return p

"""Checkpoint I/O of a run: ``checkpoints/last.pt`` (everything a resume needs), ``checkpoints/policy.pt``
(the actors alone) and the replay buffer dump, each written so that a crash never leaves a half-written one.

The file format and its reader live in :mod:`formation_rl.evaluation.checkpoint` (loading a policy needs them).
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import torch

from formation_rl.evaluation.checkpoint import FORMAT, POLICY, load_checkpoint_file

__all__ = ["BUFFER_DIR", "CHECKPOINT", "FORMAT", "POLICY", "atomic_save", "buffer_dump_to_load", "dump_buffer",
           "load_checkpoint_file", "resolve_checkpoint"]

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


BUFFER_DIR = "buffer"  # beside last.pt, with save_buffer=true
_COMPLETE = "COMPLETE"  # marker written into a buffer dump once every file of it is on disk


def dump_buffer(buffer, directory: Path) -> None:
    """``buffer.dumps`` into ``directory`` without ever leaving only a half-written dump.

    The dump goes to ``<dir>.tmp``, gets a completion marker, then replaces ``<dir>`` by two
    renames; :func:`buffer_dump_to_load` finds the complete dump whichever step a crash hit.
    """
    tmp, old = directory.with_name(directory.name + ".tmp"), directory.with_name(directory.name + ".old")
    try:
        if not directory.exists() and (tmp / _COMPLETE).is_file():  # a crash between the renames: keep that dump
            os.replace(tmp, directory)
        shutil.rmtree(tmp, ignore_errors=True)
        buffer.dumps(tmp)
        (tmp / _COMPLETE).touch()
        if directory.exists():
            shutil.rmtree(old, ignore_errors=True)
            os.replace(directory, old)
        os.replace(tmp, directory)
        shutil.rmtree(old, ignore_errors=True)
    except OSError as err:
        raise ValueError(f"cannot write the replay buffer to {directory}: {err.strerror or err}") from None


def buffer_dump_to_load(directory: Path) -> Path | None:
    """The newest complete dump of :func:`dump_buffer` (a crash may have stopped it between renames)."""
    for candidate in (directory, *(directory.with_name(directory.name + ext) for ext in (".tmp", ".old"))):
        if (candidate / _COMPLETE).is_file():
            return candidate
    return None


def resolve_checkpoint(path: str | Path, run_dir: Path) -> Path:
    """``auto`` -> this run's last checkpoint; a run directory -> its last checkpoint; else the file."""
    p = run_dir / CHECKPOINT if str(path) in ("auto", "true", "True") else Path(path)
    if p.is_dir():
        p = p / CHECKPOINT
    if not p.is_file():
        raise ValueError(f"resume = {str(path)!r} is invalid: no checkpoint at {p}")
    return p

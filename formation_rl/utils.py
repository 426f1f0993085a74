"""Small checks shared by the library and the apps."""

from __future__ import annotations

import re


def check_device(device: str) -> None:
    """Raise a one-line ``ValueError`` unless ``device`` is ``cpu`` or a CUDA device this machine has.

    Every entry point calls it before any compute (training through ``formation_rl.training.config.validate``)."""
    device = str(device)
    if device == "cpu":
        return
    if not re.fullmatch(r"cuda(:\d+)?", device):
        raise ValueError(f"device = {device!r} is invalid: must be cpu, cuda or cuda:<index>")
    import torch

    if not torch.cuda.is_available():
        raise ValueError(f"device = {device!r} is invalid: must be cpu here: CUDA is not available on this machine")
    count = torch.cuda.device_count()
    if ":" in device and int(device.split(":")[1]) >= count:
        raise ValueError(f"device = {device!r} is invalid: must be cpu, cuda or cuda:<index> with index < {count} "
                         f"here ({count} CUDA device{'s' if count > 1 else ''})")

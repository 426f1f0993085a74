"""Small checks shared by the library and the apps."""

from __future__ import annotations

import re
from collections.abc import Mapping
from typing import Any


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


# Config fields of earlier versions, removed after they were measured and not kept (docs/departures.md), with their off
# value and the commit that has them: a checkpoint that names one at its off value still loads (None: any value, the
# field only qualified a removed one, or it shaped the critics alone and the actors load as they were); at another value
# the error names the commit.
RETIRED = {
    "env.sort_obstacles": (False, "a971392"),
    "env.reward.leader_speed_cost": (0.0, "415502c"),
    "env.reward.leader_speed_limit": (None, "415502c"),
    "env.reward.leader_speed_floor": (0.0, "415502c"),
    "env.reward.obstacle_closing": (0.0, "40a14df"),
    "env.reward.robot_closing": (0.0, "40a14df"),
    "env.reward.closing_limit": (None, "40a14df"),
    "env.reward.closing_range": (None, "40a14df"),
    "model.critic_trunk": (None, "2aacd5c"),
}


def drop_retired(value: Mapping[str, Any], where: str) -> dict:
    """A copy of ``value`` (a config section named ``where``, e.g. ``"env.reward"``) without its RETIRED fields; a
    one-line ``ValueError`` for one at a value other than its off value."""
    for name in [k for k in value if f"{where}.{k}" in RETIRED]:
        off, commit = RETIRED[f"{where}.{name}"]
        if off is not None and value[name] != off:
            raise ValueError(f"{where}.{name} = {value[name]!r}: this option was removed (measured, not kept); "
                             f"formation_rl at commit {commit} has it")
    return {k: v for k, v in value.items() if f"{where}.{k}" not in RETIRED}

"""Formation geometry (docs/reference.md, Formations): slots -> desired distances d*_ij and constrained pairs."""

from __future__ import annotations

import math

import torch

from formation_rl.envs.config import FormationConfig


def slots(formation: FormationConfig, num_robots: int) -> torch.Tensor:
    """Slot positions in the formation frame, leader at the origin facing +x. ``[N, 2]``."""
    i = torch.arange(num_robots, dtype=torch.float64)
    if formation.shape == "chain":
        # order leader, L1, R1, L2, R2, ... is index order; one file behind the leader
        return torch.stack([-i * formation.spacing, torch.zeros_like(i)], dim=-1)
    # V: L_k at (-k s cos phi, +k s sin phi) for odd i, R_k at (-k s cos phi, -k s sin phi) for even i
    k = torch.div(i + 1, 2, rounding_mode="floor")
    side = torch.where(i % 2 == 1, 1.0, -1.0)
    phi = math.radians(formation.angle_deg)
    out = torch.stack([-k * formation.spacing * math.cos(phi), side * k * formation.spacing * math.sin(phi)], dim=-1)
    out[0] = 0.0
    return out


def constraints(formation: FormationConfig, num_robots: int) -> torch.Tensor:
    """``A[i, j]`` is True when follower ``i`` must keep ``d*_ij`` to robot ``j``. ``[N, N]`` bool."""
    i = torch.arange(num_robots)
    if formation.shape == "chain":
        return (i[:, None] >= 1) & (i[None, :] == i[:, None] - 1)  # each follower to its predecessor
    return (i[:, None] >= 1) & (i[:, None] != i[None, :])  # V: every other robot


def desired_distances(formation: FormationConfig, num_robots: int) -> torch.Tensor:
    """``d*_ij`` between every pair of slots. ``[N, N]``."""
    s = slots(formation, num_robots)
    return torch.cdist(s, s)


def pair_mask(formation: FormationConfig, num_robots: int) -> torch.Tensor:
    """Unordered constrained pairs ``(i < j)``, as used by RFSE. ``[N, N]`` bool, upper triangle."""
    a = constraints(formation, num_robots)
    return torch.triu(a | a.T, diagonal=1)

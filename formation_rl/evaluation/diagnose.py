"""Why episodes fail: success split into its parts, and the time of each episode's first collision
(``make diagnose``: :mod:`formation_rl.apps.diagnose`; also the metrics of ``make ceiling``)."""

from __future__ import annotations

import torch
from tensordict import TensorDictBase

from formation_rl.envs.metrics import episode_metrics

PARTS = ("success", "at_goal", "no_robot_collision", "no_obstacle_collision")
# first-collision windows, in steps after the reset (each step 0.1 s at the default dt)
BINS = ((1, 5), (6, 10), (11, 20), (21, 50), (51, 100), (101, 150))


def first_step(flags: torch.Tensor) -> torch.Tensor:
    """Per row of ``[B, T]`` flags, the 1-based step of the first ``True``; 0 where there is none."""
    hit = flags.any(1)
    return torch.where(hit, flags.float().argmax(1) + 1, torch.zeros_like(hit, dtype=torch.long))


def last_step(flags: torch.Tensor) -> torch.Tensor:
    """Per row of ``[B, T]`` flags, the 1-based step of the last ``True``; 0 where there is none."""
    last = flags.shape[1] + 1 - first_step(flags.flip(1))
    return torch.where(flags.any(1), last, torch.zeros_like(last))


def failure_metrics(rollout: TensorDictBase, goal_radius: float) -> dict[str, torch.Tensor]:
    """:func:`episode_metrics` of a from-reset ``[B, T]`` rollout plus the steps of each episode's first
    robot-robot and robot-obstacle collision and of its last robot-robot collision (0: none)."""
    robot, obstacle = rollout["next", "robot_collision"][..., 0], rollout["next", "obstacle_collision"][..., 0]
    return {
        **episode_metrics(rollout, goal_radius),
        "first_robot_collision": first_step(robot).double(),
        "last_robot_collision": last_step(robot).double(),
        "first_obstacle_collision": first_step(obstacle).double(),
    }


def breakdown(per_episode: dict[str, torch.Tensor]) -> dict[str, float]:
    """Fractions of episodes: the parts of success, and first robot-robot collision per window of steps."""
    out = {k: per_episode[k].mean().item() for k in PARTS}
    first = per_episode["first_robot_collision"]
    for lo, hi in BINS:
        out[f"first_robot_collision_{lo}_{hi}"] = ((first >= lo) & (first <= hi)).double().mean().item()
    last = per_episode["last_robot_collision"]
    out["robot_collision_only_in_first_20"] = ((first >= 1) & (last <= 20)).double().mean().item()
    return out

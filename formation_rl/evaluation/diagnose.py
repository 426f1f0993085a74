"""Why episodes fail: success split into its parts, and the time of each episode's first collision
(``make diagnose``: :mod:`formation_rl.apps.diagnose`; also the metrics of ``make ceiling``)."""

from __future__ import annotations

import torch
from tensordict import TensorDictBase

from formation_rl.envs import EnvConfig
from formation_rl.envs.metrics import episode_metrics

PARTS = ("success", "at_goal", "no_robot_collision", "no_obstacle_collision", "leader_at_wall", "saturated_actions")
WALL = 0.05  # m: a leader whose centre ends this close to the arena's edge ends at a wall
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


def failure_metrics(rollout: TensorDictBase, goal_radius: float, edge: float | None = None) -> dict[str, torch.Tensor]:
    """:func:`episode_metrics` of a from-reset ``[B, T]`` rollout plus the steps of each episode's first
    robot-robot and robot-obstacle collision and of its last robot-robot collision (0: none), whether the
    leader ends at a wall (within ``WALL`` of ``edge``, the farthest a centre goes: arena_half_size -
    robot_radius, the default world's if None), the share of saturated action components (|a| > 0.99), the
    followers' mean distance to the leader at the last step (m), the share of steps with the leader
    inside the obstacle area (where the hybrid reward asks for the chain), whether it enters that area at
    all, and the per-step curves ``[B, T]`` of the formation error (RFSE's per-step sum) and of the
    leader's being inside the area."""
    robot, obstacle = rollout["next", "robot_collision"][..., 0], rollout["next", "obstacle_collision"][..., 0]
    final = rollout["next", "state", "positions"][:, -1]  # [B, N, 2] at the last step
    leader = final[:, 0]
    in_area = rollout["next", "in_obstacle_area"][..., 0].double()  # [B, T]
    if edge is None:
        spec = EnvConfig()
        edge = spec.arena_half_size - spec.robot_radius
    return {
        **episode_metrics(rollout, goal_radius),
        # where deterministic policies get stuck: pushing into a wall zeroes the velocity (reference.md, World)
        "leader_at_wall": (leader.abs().amax(-1) >= edge - WALL).double(),
        "saturated_actions": (rollout["agents", "action"].abs() > 0.99).double().mean((1, 2, 3)),
        "first_robot_collision": first_step(robot).double(),
        "last_robot_collision": last_step(robot).double(),
        "first_obstacle_collision": first_step(obstacle).double(),
        # a team that stays together, and one that crosses the obstacle area (the chain formation's steps)
        "follower_distance_end": (final[:, 1:] - final[:, :1]).norm(dim=-1).mean(-1).double(),
        "leader_in_area_steps": in_area.mean(1),
        "leader_enters_area": in_area.amax(1),
        "formation_error_per_step": rollout["next", "formation_error"][..., 0].double(),  # [B, T]
        "in_area_per_step": in_area,  # [B, T]
    }


def breakdown(per_episode: dict[str, torch.Tensor]) -> dict[str, float]:
    """Fractions of episodes: the parts of success, and first robot-robot collision per window of steps;
    then the means of the followers' final distance to the leader (m), of the leader's obstacle-area steps and
    of the episodes whose leader enters that area."""
    out = {k: per_episode[k].mean().item() for k in PARTS}
    first = per_episode["first_robot_collision"]
    for lo, hi in BINS:
        out[f"first_robot_collision_{lo}_{hi}"] = ((first >= lo) & (first <= hi)).double().mean().item()
    last = per_episode["last_robot_collision"]
    out["robot_collision_only_in_first_20"] = ((first >= 1) & (last <= 20)).double().mean().item()
    out["follower_distance_end"] = per_episode["follower_distance_end"].mean().item()
    out["leader_in_area_steps"] = per_episode["leader_in_area_steps"].mean().item()
    out["leader_enters_area"] = per_episode["leader_enters_area"].mean().item()
    return out

"""Episode metrics of docs/reference.md, Metrics (paper §5.3): the one implementation used by training logs,
evaluation and plots.

Works on TorchRL rollout/collector tensordicts (``[B, T]`` or ``[B]``) through the per-step
diagnostics the environment reports under ``"next"``; episodes may span several batches.
"""

from __future__ import annotations

import torch
from tensordict import TensorDictBase

# per-step features summed over an episode, in this order
_FEATURES = ("reward", "leader", "followers", "robot_collision", "obstacle_collision", "any_collision",
             "formation_error", "steps")


class EpisodeTracker:
    """Accumulates per-copy partial sums over consecutive batches and returns finished episodes."""

    def __init__(self, num_envs: int, goal_radius: float, device: torch.device | str = "cpu"):
        self.num_envs = num_envs
        self.goal_radius = goal_radius
        self._carry = torch.zeros(num_envs, len(_FEATURES), dtype=torch.float64, device=device)

    def reset(self) -> None:
        """Forget unfinished episodes (after the env was reset by hand)."""
        self._carry.zero_()

    def update(self, batch: TensorDictBase) -> dict[str, torch.Tensor]:
        """Feed a ``[B, T]`` (or ``[B]``) batch; return ``{metric: [E]}`` for the E episodes that ended in it."""
        if batch.batch_dims == 1:
            batch = batch.unsqueeze(1)
        if batch.batch_dims != 2 or batch.shape[0] != self.num_envs:
            raise ValueError(
                f"EpisodeTracker.update: batch shape {tuple(batch.shape)} is invalid: must be "
                f"[num_envs={self.num_envs}, T] or [num_envs]"
            )
        nxt = batch.get("next")
        reward = nxt.get(("agents", "reward"))[..., 0].double()  # [B, T, N]
        robot = nxt.get("robot_collision")[..., 0]
        obstacle = nxt.get("obstacle_collision")[..., 0]
        feats = torch.stack(
            [
                reward.mean(-1),
                reward[..., 0],
                reward[..., 1:].mean(-1),
                robot.double(),
                obstacle.double(),
                (robot | obstacle).double(),
                nxt.get("formation_error")[..., 0].double(),
                torch.ones_like(robot, dtype=torch.float64),
            ],
            -1,
        )  # [B, T, K]
        csum = feats.cumsum(1) + self._carry[:, None]  # running sums since each copy's episode start
        rows, steps = nxt.get("done")[..., 0].nonzero(as_tuple=True)  # row-major: sorted by copy, then time
        ends = csum[rows, steps]  # [E, K] cumulative sums at each episode end
        same_row = rows[1:] == rows[:-1]
        before = torch.zeros_like(ends)
        before[1:][same_row] = ends[:-1][same_row]  # previous episode end of the same copy
        sums = ends - before  # [E, K]
        last = torch.ones_like(rows, dtype=torch.bool)
        last[:-1] = ~same_row
        consumed = torch.zeros_like(self._carry)
        consumed[rows[last]] = ends[last]
        self._carry = csum[:, -1] - consumed
        udblt = nxt.get("goal_distance")[..., 0][rows, steps].double()
        return _finish(sums, udblt, self.goal_radius)


def _finish(sums: torch.Tensor, udblt: torch.Tensor, goal_radius: float) -> dict[str, torch.Tensor]:
    f = {name: sums[:, i] for i, name in enumerate(_FEATURES)}
    t = f["steps"]
    return {
        "episode_reward": f["reward"],  # sum over steps of the mean reward over robots
        "leader_reward": f["leader"],
        "follower_reward": f["followers"],
        "CBRS": 100.0 * f["robot_collision"] / t,  # % of steps with a robot-robot collision
        "CBRO": 100.0 * f["obstacle_collision"] / t,  # % of steps with a robot-obstacle collision
        "UDBLT": udblt,  # leader-to-goal distance at the last step (m)
        "RFSE": f["formation_error"] / t,  # mean over steps of sum_pairs |d_ij - d*_ij| (m)
        "success": ((udblt <= goal_radius) & (f["any_collision"] == 0)).double(),
        # success = the product of these three: which part fails (1 or 0 per episode)
        "at_goal": (udblt <= goal_radius).double(),  # leader within goal_radius at the last step
        "no_robot_collision": (f["robot_collision"] == 0).double(),
        "no_obstacle_collision": (f["obstacle_collision"] == 0).double(),
        "length": t,
    }


def episode_metrics(rollout: TensorDictBase, goal_radius: float) -> dict[str, torch.Tensor]:
    """Metrics of every episode that starts and ends inside ``rollout`` (``[B, T]``, from a reset)."""
    if rollout.batch_dims == 1:  # a single copy's [T] rollout
        rollout = rollout.unsqueeze(0)
    return EpisodeTracker(rollout.shape[0], goal_radius, rollout.device or "cpu").update(rollout)


def summarize(metrics: dict[str, torch.Tensor]) -> dict[str, float]:
    """Mean of each metric over episodes (NaN when there are none)."""
    return {k: (v.mean().item() if v.numel() else float("nan")) for k, v in metrics.items()}

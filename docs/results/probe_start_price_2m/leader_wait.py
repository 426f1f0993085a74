"""Has the leader time to wait for its team? The leader held at rest (zero force) for its first k steps, the
followers as learned; 200 validation episodes (seed 1,000,000,007) per row.

    python docs/results/probe_start_price_2m/leader_wait.py CKPT [CKPT ...]     # run dirs or policy files
"""
import sys

import torch

from formation_rl import load_policy
from formation_rl.evaluation.evaluate import evaluate_policy
from formation_rl.training.config import TrainConfig

WAITS = (0, 3, 5, 10)


def held(policy, k):
    """The policy with the leader's force zeroed in steps 1..k (one evaluation round: a call counter is the step)."""
    step = iter(range(10**9))

    def act(td):
        td = policy(td)
        if next(step) < k:
            a = td["agents", "action"].clone()
            a[:, 0] = 0.0
            td["agents", "action"] = a
        return td

    return act


def metrics(rollout, goal_radius):
    err = rollout["next", "formation_error"].reshape(rollout.shape)
    robot = rollout["next", "robot_collision"].reshape(rollout.shape)
    obstacle = rollout["next", "obstacle_collision"].reshape(rollout.shape)
    at_goal = rollout["next", "goal_distance"].reshape(rollout.shape)[:, -1] <= goal_radius
    return {"rfse": err.mean(1), "early": err[:, 10:30].mean(1), "robot": robot.any(1), "robot6": robot[:, :6].any(1),
            "at_goal": at_goal, "success": at_goal & ~robot.any(1) & ~obstacle.any(1)}


torch.set_num_threads(2)
print("| policy | leader at rest, steps | RFSE (m) | error, steps 11-30 | robot contact | in steps 1-6 | leader at goal "
      "| success |\n|---|---|---|---|---|---|---|---|")
for ckpt in sys.argv[1:]:
    policy = load_policy(ckpt)
    for k in WAITS:
        m = evaluate_policy(held(policy, k), policy.env_config, 200, seed=TrainConfig.eval_seed, progress=False,
                            metrics=metrics)
        print(f"| {ckpt} | {k} | {m['rfse'].mean():.2f} | {m['early'].mean():.2f} | {m['robot'].float().mean():.0%} | "
              f"{m['robot6'].float().mean():.0%} | {m['at_goal'].float().mean():.0%} | {m['success'].float().mean():.1%} |")

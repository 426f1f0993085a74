"""What the followers' own choices cost the formation: one policy on 100 validation episodes (seed 1,000,000,007),
as it flies and with its followers' actions changed, printing the followers' discounted return (gamma 0.95) from
step 20, RFSE, the formation error by phase and the share of episodes with a robot or an obstacle contact.

    python docs/results/probe_assembly_2m/followers_counterfactual.py CKPT

Changes: "forward": + beta x the leader's heading (unit vector) added to each follower's action in steps lo..hi;
"match": + k (v_lea - v_i) / v_max added from step 3 (a velocity-matching push); "copy": each follower takes the
leader's action from step 3, so the team moves as one rigid body (the start's distances kept).
"""
import sys

import torch

from formation_rl import load_policy
from formation_rl.evaluation.evaluate import evaluate_policy
from formation_rl.training.config import TrainConfig

EPISODES = 100
CHANGES = (("as it flies", None, 0.0, 0, 0), ("forward 0.3, steps 20-59", "forward", 0.3, 20, 60),
           ("forward 1.0, steps 20-59", "forward", 1.0, 20, 60), ("forward 1.0, steps 20-129", "forward", 1.0, 20, 130),
           ("match k = 2", "match", 2.0, 3, 150), ("match k = 5", "match", 5.0, 3, 150), ("copy", "copy", 0.0, 3, 150))


def changed(policy, kind, w, lo, hi, max_speed):
    """The policy with its followers' actions changed in steps lo..hi-1 (one evaluation round: every copy steps
    together, so a call counter is the step)."""
    step = iter(range(10**9))

    def act(td):
        td, t = policy(td), next(step)
        if kind and lo <= t < hi:
            a, v = td["agents", "action"].clone(), td["state", "velocities"]
            if kind == "forward":
                heading = v[:, 0] / v[:, 0].norm(dim=-1, keepdim=True).clamp_min(1e-6)
                a[:, 1:] += w * heading[:, None]
            elif kind == "match":
                a[:, 1:] += w * (v[:, :1] - v[:, 1:]) / max_speed
            else:
                a[:, 1:] = a[:, :1]
            td["agents", "action"] = a.clamp(-1, 1)
        return td

    return act


def metrics(rollout, goal_radius):
    reward = rollout["next", "agents", "reward"][:, 20:, 1:, 0]  # [B, T - 20, N - 1]
    discount = 0.95 ** torch.arange(reward.shape[1], dtype=reward.dtype)
    err = rollout["next", "formation_error"].reshape(rollout.shape)  # [B, T]
    return {"return": (reward * discount[:, None]).sum(1).mean(-1), "rfse": err.mean(1),
            "early": err[:, 20:60].mean(1), "late": err[:, 60:].mean(1),
            "robot": rollout["next", "robot_collision"].reshape(rollout.shape).any(1),
            "obstacle": rollout["next", "obstacle_collision"].reshape(rollout.shape).any(1)}


if len(sys.argv) != 2:
    sys.exit("usage: python docs/results/probe_assembly_2m/followers_counterfactual.py CKPT")
torch.set_num_threads(1)
policy = load_policy(sys.argv[1])
cfg = policy.env_config
print(f"{sys.argv[1]}\n| followers' actions | followers' return from step 20 | RFSE (m) | error, steps 20-59 | "
      "error, steps 60-149 | robot contact | obstacle contact |\n|---|---|---|---|---|---|---|")
for name, kind, w, lo, hi in CHANGES:
    m = evaluate_policy(changed(policy, kind, w, lo, hi, cfg.max_speed), cfg, EPISODES, seed=TrainConfig.eval_seed,
                        progress=False, metrics=metrics)
    print(f"| {name} | {m['return'].mean():.2f} | {m['rfse'].mean():.2f} | {m['early'].mean():.2f} | "
          f"{m['late'].mean():.2f} | {m['robot'].float().mean():.2f} | {m['obstacle'].float().mean():.2f} |")

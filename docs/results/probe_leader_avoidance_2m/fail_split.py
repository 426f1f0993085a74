"""Why episodes fail, on 400 validation scenarios (seed 1,000,000,007, never the test seed): the share of episodes
with each cause (they overlap), and the share that fail by that cause alone. Contacts are measured from the world
state with the metrics' margins (reference.md, Metrics).

    python docs/results/probe_leader_avoidance_2m/fail_split.py CKPT [CKPT ...]   # a policy file, or apf
"""

import sys

import torch
from leader_encounters import rollout  # the same 400 validation episodes (this folder is on sys.path)


def main(ckpt: str) -> None:
    td, cfg = rollout(ckpt)
    s = td["next", "state"]
    P = s["positions"]
    C = s["obstacle_centers"][:, 0]
    R = s["obstacle_radii"][:, 0]
    r = cfg.robot_radius
    ogap = (P[:, :, :, None] - C[:, None, None]).norm(dim=-1) - r - R[:, None, None]
    ohit = (ogap < cfg.obstacle_collision_margin).any(-1)  # [B,T,N]
    d = (P[:, :, :, None] - P[:, :, None]).norm(dim=-1) - 2 * r
    N = P.shape[2]
    d = d + torch.eye(N) * 100
    rhit = d < cfg.robot_collision_margin  # [B,T,N,N]
    at_goal = td["next", "goal_distance"][:, -1, 0] <= cfg.goal_radius
    causes = {
        "leader not at goal": ~at_goal,
        "leader-obstacle": ohit[:, :, 0].any(1),
        "follower-obstacle": ohit[:, :, 1:].any(-1).any(1),
        "robot contact steps 1-5": rhit[:, :5].flatten(2).any(-1).any(1),
        "robot contact after step 5": rhit[:, 5:].flatten(2).any(-1).any(1),
    }
    allc = torch.stack(list(causes.values()), 0)
    succ = ~allc.any(0)
    print(ckpt, f"success {succ.float().mean():.1%}")
    for k, v in causes.items():
        only = v & (allc.sum(0) == 1)
        print(f"  {k:28s} {v.float().mean():6.1%}   only cause {only.float().mean():6.1%}")


if __name__ == "__main__":
    for path in sys.argv[1:]:
        main(path)

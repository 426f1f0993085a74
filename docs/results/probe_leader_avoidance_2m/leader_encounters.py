"""The leader's obstacle encounters on 400 validation scenarios (seed 1,000,000,007, never the test seed): for each
obstacle the leader senses in an episode, its speed and closing speed at the first step it senses it, and whether a
contact with that obstacle follows; and the leader's mean speed inside the obstacle area. 0.53 m/s: the closing speed
above which a robot that first sees an obstacle head-on cannot always stop short of contact (docs/RESULTS.md, "What
the sensing range allows").

    python docs/results/probe_leader_avoidance_2m/leader_encounters.py CKPT [CKPT ...]   # a policy file, or apf
"""

import sys

import torch

import formation_rl
from formation_rl.envs import FormationEnv


def rollout(ckpt: str):
    """The policy ``ckpt`` on the 400 validation scenarios: (rollout tensordict [B, T], env config)."""
    pol = formation_rl.load_policy(ckpt)
    cfg = pol.env_config
    env = FormationEnv(400, config=cfg, seed=1_000_000_007)
    with torch.no_grad():
        return env.rollout(cfg.max_steps, policy=pol, break_when_any_done=False), cfg


def main(ckpt: str) -> None:
    td, cfg = rollout(ckpt)
    s = td["next", "state"]
    P = s["positions"][:, :, 0]
    V = s["velocities"][:, :, 0]  # [B,T,2]
    C = s["obstacle_centers"][:, 0]
    R = s["obstacle_radii"][:, 0]
    off = P[:, :, None] - C[:, None]  # [B,T,M,2]
    gap = off.norm(dim=-1) - cfg.robot_radius - R[:, None]  # [B,T,M]
    sensed = gap <= cfg.sensing_range
    hit = gap < cfg.obstacle_collision_margin
    enc = sensed.any(1)  # [B,M]
    t0 = sensed.float().argmax(1)  # [B,M]
    b, m = enc.nonzero(as_tuple=True)
    t = t0[b, m].long()
    v = V[b, t]
    speed = v.norm(dim=-1)
    u = off[b, t, m] / off[b, t, m].norm(dim=-1, keepdim=True)
    closing = -(v * u).sum(-1)
    touched = hit[b, :, m].any(1)
    inside = td["next", "in_obstacle_area"][..., 0]
    sp = V.norm(dim=-1)[inside]
    fast = closing > 0.53
    print(ckpt)
    print(
        f"  encounters {len(b)} ({len(b) / 400:.2f} per episode), touched after {touched.float().mean():.1%}; "
        f"speed at sensing median {speed.median():.2f}, closing {closing.median():.2f} m/s; "
        f"touched when closing > 0.53: {touched[fast].float().mean():.1%} of {fast.float().mean():.1%}, "
        f"<= 0.53: {touched[~fast].float().mean():.1%}"
    )
    steps = inside.float().sum(1).mean()
    print(f"  leader speed inside the area: mean {sp.mean():.2f} m/s; steps inside per episode {steps:.1f}")


if __name__ == "__main__":
    for path in sys.argv[1:]:
        main(path)

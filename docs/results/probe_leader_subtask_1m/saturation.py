"""How often the actors' outputs sit in tanh saturation (|a| > 0.99, where the policy gradient through tanh is under
2% of its value at 0), over all steps and over the steps where the leader senses an obstacle, on 200 validation
scenarios (seed 1,000,000,007, never the test seed).

    python docs/results/probe_leader_subtask_1m/saturation.py CKPT [CKPT ...]
"""

import sys

import torch

import formation_rl
from formation_rl.envs import FormationEnv


def main(ckpt: str) -> None:
    pol = formation_rl.load_policy(ckpt)
    cfg = pol.env_config
    env = FormationEnv(200, config=cfg, seed=1_000_000_007)
    with torch.no_grad():
        td = env.rollout(cfg.max_steps, policy=pol, break_when_any_done=False)
    a = td["agents", "action"]  # [B, T, N, 2]
    s = td["next", "state"]
    pos, centers, radii = s["positions"][:, :, 0], s["obstacle_centers"][:, 0], s["obstacle_radii"][:, 0]
    gap = (pos[:, :, None] - centers[:, None]).norm(dim=-1) - cfg.robot_radius - radii[:, None]  # [B, T, M]
    sensed = (gap <= cfg.sensing_range).any(-1)  # [B, T]: the leader senses an obstacle
    lead = a[:, :, 0]
    sat = (lead.abs() > 0.99).float()
    print(ckpt, f"leader components |a|>0.99: all {sat.mean():.2f}, sensed steps {sat[sensed].mean():.2f}; "
          f"|a| mean {lead.abs().mean():.2f} followers {(a[:, :, 1:].abs() > 0.99).float().mean():.2f}")


if __name__ == "__main__":
    for path in sys.argv[1:]:
        main(path)

"""Which robots touch the obstacles: per robot, the share of episodes with an obstacle contact, of steps in contact,
and the median step of its first contact, on 400 validation scenarios (seed 1,000,000,007, never the test seed).
A robot's contact is read from its reward: R4 (times the reward scale) replaces its step's reward on contact
(steps where a robot contact or the goal event coincides are not counted).

    python docs/results/recipe_hindsight_2m/obstacle_contacts_by_robot.py CKPT [CKPT ...]
"""

import sys

import torch

import formation_rl
from formation_rl.envs import FormationEnv


def main(ckpts: list[str]) -> None:
    for ckpt in ckpts:
        policy = formation_rl.load_policy(ckpt)
        cfg = policy.env_config
        env = FormationEnv(400, config=cfg, seed=1_000_000_007)
        with torch.no_grad():
            td = env.rollout(cfg.max_steps, policy=policy, break_when_any_done=False)
        hit = td["next", "agents", "reward"][..., 0] == cfg.reward.obstacle_collision * cfg.reward.scale  # [B, T, N]
        episodes = hit.any(1).float().mean(0)
        first = torch.where(hit.any(1), hit.float().argmax(1).float() + 1, torch.nan).nanmedian(0).values
        print(f"{ckpt}\n  any robot: {hit.any(2).any(1).float().mean():.1%} of the episodes")
        for i in range(cfg.num_robots):
            print(f"  {'leader' if i == 0 else f'follower {i}'}: {episodes[i]:.1%} of the episodes, "
                  f"{hit[..., i].float().mean():.2%} of the steps, first contact at step {first[i]:.0f} (median)")


if __name__ == "__main__":
    main(sys.argv[1:])

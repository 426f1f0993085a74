"""`python start_contacts.py CKPT...`: the first five steps of each policy on 500 validation episodes (seed
1,000,000,007): the share of episodes with a robot contact, split into leader-follower and follower-follower pairs,
and, for the leader-follower ones, whether the follower started ahead of the leader (toward the goal)."""
import sys

import torch
from torchrl.envs.utils import ExplorationType, set_exploration_type

from formation_rl.envs import FormationEnv
from formation_rl.evaluation.policy import load_policy

torch.set_num_threads(1)
B, CONTACT = 500, 0.3  # episodes; centre distance of a robot contact (2 r + rho_r)
for ck in sys.argv[1:]:
    p = load_policy(ck)
    env = FormationEnv(B, config=p.env_config, seed=1000000007)
    with torch.no_grad(), set_exploration_type(ExplorationType.DETERMINISTIC):
        ro = env.rollout(5, p.module, break_when_any_done=False)
    start = ro.get(("state", "positions"))[:, 0]  # [B, N, 2]
    pos = ro.get(("next", "state", "positions"))  # [B, 5, N, 2]
    n = pos.shape[2]
    far = torch.eye(n) * 9
    touched = ((pos[:, :, :, None] - pos[:, :, None]).norm(dim=-1) + far < CONTACT).any(1)  # [B, N, N]
    lf, ff = touched[:, 0, 1:], touched[:, 1:, 1:].flatten(1).any(1)
    to_goal = ro.get(("state", "goal"))[:, 0] - start[:, 0]
    ahead = ((start[:, 1:] - start[:, :1]) * to_goal[:, None]).sum(-1) > 0  # [B, N-1]
    speed = ro.get(("next", "state", "velocities")).norm(dim=-1)  # [B, 5, N]
    print(ck)
    print("  episodes with a robot contact in steps 1-5: %.1f%% (leader-follower %.1f%%, follower-follower %.1f%%)"
          % (100 * touched.flatten(1).any(1).float().mean(), 100 * lf.any(1).float().mean(), 100 * ff.float().mean()))
    print("  leader-follower pairs in contact: %d, the follower ahead of the leader at the start in %d "
          "(of all followers %.0f%% start ahead)" % (lf.sum(), (lf & ahead).sum(), 100 * ahead.float().mean()))
    print("  mean speed in steps 1-5, leader:", " ".join("%.2f" % v for v in speed[:, :, 0].mean(0).tolist()),
          "| followers:", " ".join("%.2f" % v for v in speed[:, :, 1:].mean((0, 2)).tolist()))

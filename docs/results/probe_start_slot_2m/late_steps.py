"""`python late_steps.py CKPT...`: where the formation error of the late episode comes from, on 200 validation
episodes (seed 1,000,000,007): the step the leader reaches the goal, and the leader's and followers' speeds, the
followers' distance to the leader and the formation error at a few steps."""
import sys

import torch
from torchrl.envs.utils import ExplorationType, set_exploration_type

from formation_rl.envs import FormationEnv
from formation_rl.evaluation.policy import load_policy

torch.set_num_threads(1)
B, T = 200, 150
for ck in sys.argv[1:]:
    p = load_policy(ck)
    env = FormationEnv(B, config=p.env_config, seed=1000000007)
    with torch.no_grad(), set_exploration_type(ExplorationType.DETERMINISTIC):
        ro = env.rollout(T, p.module, break_when_any_done=False)
    pos = ro.get(("next", "state", "positions"))  # [B, T, N, 2]
    speed = ro.get(("next", "state", "velocities")).norm(dim=-1)  # [B, T, N]
    error = ro.get(("next", "formation_error"))[..., 0]  # [B, T]
    to_goal = (pos[:, :, 0] - ro.get(("next", "state", "goal"))).norm(dim=-1)  # [B, T]
    there = to_goal <= p.env_config.goal_radius
    arrival = torch.where(there.any(1), there.float().argmax(1) + 1, torch.full((B,), T + 1))
    behind = (pos[:, :, 1:] - pos[:, :, :1]).norm(dim=-1)  # [B, T, N-1]
    q = arrival[arrival <= T].float().quantile(torch.tensor([0.25, 0.5, 0.75])).tolist()
    print(ck)
    print("  the leader first within rho_g of the goal at step %.0f / %.0f / %.0f (quartiles), never in %.1f%%"
          % (*q, 100 * (arrival > T).float().mean()))
    for t in (30, 60, 90, 110, 130, 150):
        print("  step %3d: formation error %.2f m, leader %.2f m/s and %.2f m from the goal, followers %.2f m/s and "
              "%.2f m from the leader (mean)" % (t, error[:, t - 1].mean(), speed[:, t - 1, 0].mean(),
                                                 to_goal[:, t - 1].mean(), speed[:, t - 1, 1:].mean(),
                                                 behind[:, t - 1].mean()))

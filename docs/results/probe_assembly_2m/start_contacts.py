"""Who touches whom while the team assembles: the share of 200 validation episodes (seed 1,000,000,007) with a
leader-follower and with a follower-follower contact (centre distance below 2r + rho_r) in steps 1-6, and the
followers' mean reward in those steps when no sparse event replaced their guided term (what a contact's R5
stands in for).

    python docs/results/probe_assembly_2m/start_contacts.py CKPT [CKPT ...]     # run dirs, policy files or apf
"""
import sys

import torch

from formation_rl import load_policy
from formation_rl.evaluation.evaluate import evaluate_policy
from formation_rl.training.config import TrainConfig

EPISODES, STEPS = 200, 6


def start_phase(cfg):
    """evaluate_policy's per-episode metrics of the first STEPS steps."""
    threshold = 2 * cfg.robot_radius + cfg.robot_collision_margin
    rw = cfg.reward
    # every sum of a follower's sparse terms (R2 or R3, R4, R5), scaled as the reward is
    terms = (rw.formation_open, rw.obstacle_collision, rw.robot_collision)
    events = torch.tensor([sum(t for t, on in zip(terms, mask, strict=True) if on) * rw.scale
                           for mask in ((1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 0), (1, 0, 1), (0, 1, 1), (1, 1, 1))])

    def metrics(rollout, goal_radius):
        p = rollout["next", "state", "positions"][:, :STEPS]  # [B, T, N, 2]
        d = (p[..., :, None, :] - p[..., None, :, :]).norm(dim=-1) + torch.eye(cfg.num_robots) * 1e3  # no self
        hit = d < threshold  # [B, T, N, N]
        r = rollout["next", "agents", "reward"][:, :STEPS, 1:, 0]  # [B, T, N-1]
        guided = (r[..., None] - events).abs().amin(-1) >= 1e-4  # no sum of sparse terms replaced the guided one
        return {"lead": hit[:, :, 0, 1:].flatten(1).any(-1), "follow": hit[:, :, 1:, 1:].flatten(1).any(-1),
                "guided_sum": (r * guided).sum((1, 2)), "guided_n": guided.sum((1, 2))}

    return metrics


if len(sys.argv) < 2:
    sys.exit("usage: python docs/results/probe_assembly_2m/start_contacts.py CKPT [CKPT ...]")
torch.set_num_threads(1)
print("| policy | leader-follower contact, steps 1-6 | follower-follower contact, steps 1-6 | followers' guided "
      "reward, steps 1-6 |\n|---|---|---|---|")
for ckpt in sys.argv[1:]:
    policy = load_policy(ckpt)
    m = evaluate_policy(policy, policy.env_config, EPISODES, seed=TrainConfig.eval_seed, progress=False,
                        metrics=start_phase(policy.env_config))
    print(f"| {ckpt} | {100 * m['lead'].float().mean():.1f}% | {100 * m['follow'].float().mean():.1f}% | "
          f"{m['guided_sum'].sum() / m['guided_n'].sum():.2f} |")

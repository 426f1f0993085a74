"""`python rfse_profile.py CKPT...`: the per-step formation error (RFSE's summand) of each policy on the 200 validation
episodes (seed 1,000,000,007), its mean in 10-step blocks, the chain's share of steps (rfse_profile.txt)."""
import sys, torch
from torchrl.envs.utils import ExplorationType, set_exploration_type
from formation_rl.evaluation.policy import load_policy
from formation_rl.envs import FormationEnv
torch.set_num_threads(1)
for ck in sys.argv[1:]:
    p = load_policy(ck)
    env = FormationEnv(200, config=p.env_config, seed=1000000007)
    with torch.no_grad(), set_exploration_type(ExplorationType.DETERMINISTIC):
        ro = env.rollout(150, p.module, break_when_any_done=False)
    fe = ro.get(("next", "formation_error"))[..., 0]  # [B, T]
    area = ro.get(("next", "in_obstacle_area"))[..., 0].float()
    blocks = fe.view(200, 15, 10).mean((0, 2))
    print(ck, "RFSE %.3f" % fe.mean().item(), "chain share %.3f" % area.mean().item(),
          "in-area err %.2f" % (fe[area.bool()].mean().item() if area.any() else float('nan')), "open err %.2f" % fe[~area.bool()].mean().item())
    print("  per 10 steps:", " ".join("%.2f" % v for v in blocks.tolist()))

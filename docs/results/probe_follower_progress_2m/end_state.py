"""Where the followers are at the last step: their distance to the leader, how many are far (> 1.5 m), how close
those are to an obstacle or a wall, their speed and median position relative to the leader; 200 validation episodes.

    python docs/results/probe_follower_progress_2m/end_state.py CKPT
"""
import sys, torch
from formation_rl import load_policy
from formation_rl.envs.formation_env import FormationEnv
from formation_rl.envs.config import EnvConfig
from formation_rl.evaluation.policy import policy_path
torch.set_num_threads(1)
ckpt = sys.argv[1]
pol = load_policy(ckpt)
cfg = EnvConfig.from_dict(torch.load(policy_path(ckpt), weights_only=False)["env"])
env = FormationEnv(200, config=cfg, seed=1_000_000_007)
with torch.no_grad():
    ro = env.rollout(cfg.max_steps, pol, break_when_any_done=False)
pos = ro["next", "state", "positions"]; vel = ro["next","state","velocities"]
c = ro["next","state","obstacle_centers"][:, -1]; r = ro["next","state","obstacle_radii"][:, -1]
p = pos[:, -1]  # [B,N,2]
d = (p[:, 1:] - p[:, :1]).norm(dim=-1)  # [B,4]
gap = ((p[:, 1:, None] - c[:, None]).norm(dim=-1) - r[:, None] - 0.1).amin(-1)  # [B,4]
edge = p[:, 1:].abs().amax(-1)
print("follower dist to leader at end: quartiles", d.flatten().quantile(torch.tensor([.25,.5,.75,.9])).tolist())
far = d > 1.5
print("share far (>1.5 m)", far.float().mean().item())
print("far followers: obstacle gap median", gap[far].median().item(), "share gap<0.3", (gap[far] < 0.3).float().mean().item(), "share at wall", (edge[far] > 3.85).float().mean().item())
print("far followers speed at end", vel[:, -1, 1:].norm(dim=-1)[far].median().item())
# where are far followers relative to leader: behind along leader->start?
rel = p[:, 1:] - p[:, :1]
print("far rel x,y median", rel[far].median(0).values.tolist())

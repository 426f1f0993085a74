# Can a follower always escape a leader that flies full force toward its goal from the first step? 2,000 start
# layouts of the default world (seed 5); each follower flees in the best of 24 fixed directions, other followers
# ignored. python docs/results/probe_team_no_obstacles_follower_contact_cost/escape_possible.py
import math, torch
from formation_rl.envs import EnvConfig
from formation_rl.envs import world
cfg = EnvConfig(); g = torch.Generator().manual_seed(5)
sc = world.sample_scenarios(2000, cfg, g, "cpu")
pos, goal = sc["positions"], sc["goal"]  # [B,N,2]
B, N = pos.shape[:2]
def run(lead_action, fol_action, steps=12):
    p = pos.clone(); v = torch.zeros_like(p); dmin = torch.full((B, N), 9.0)
    for t in range(steps):
        a = fol_action(p, v); a[:, 0] = lead_action(p, v)
        v = v + a.clamp(-1, 1) * 0.2
        sp = v.norm(dim=-1, keepdim=True); v = v * (0.85 / sp).clamp(max=1)
        p = p + v * 0.1
        d = (p[:, 1:] - p[:, :1]).norm(dim=-1)
        dmin[:, 1:] = torch.minimum(dmin[:, 1:], d)
    return dmin[:, 1:]
def lead(p, v):
    d = goal - p[:, 0]; return (d / d.abs().max(-1, keepdim=True).values)  # full force toward the goal (box corner)
best = torch.zeros(B, N - 1)
for ang in range(0, 360, 15):  # each follower flees in one fixed direction; keep its best
    th = math.radians(ang)
    def fol(p, v, th=th):
        a = torch.zeros_like(p); a[..., 0] = math.cos(th); a[..., 1] = math.sin(th)
        return a / a.abs().amax(-1, keepdim=True).clamp(min=1e-9)
    best = torch.maximum(best, run(lead, fol))
trapped = best < 0.3
print("episodes with a follower that no fixed escape saves from the leader:", trapped.any(1).float().mean().item())
def still(p, v): return torch.zeros_like(p)
print("episodes where a still follower is rammed:", (run(lead, still) < 0.3).any(1).float().mean().item())

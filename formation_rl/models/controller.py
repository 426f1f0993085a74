"""A classical, non-learned reference controller, ``apf`` (``make eval CKPT=apf``): the bar for what learning buys.

Each robot acts on its own observation (docs/reference.md) only (the information a learned actor has, so the
comparison is fair, decentralized execution included):

- **leader**: flies towards the goal with a braking speed profile (``sqrt(2 a d)``, capped by a
  cruise speed, lower while it is over the obstacle area: at v_max a robot cannot swerve round an
  obstacle it senses 0.2 m away), and an artificial potential field around every *sensed*
  obstacle: the velocity component into the obstacle is removed, a tangential term slides it
  round the side nearer its heading and a repulsive term pushes it out;
- **followers**: proportional tracking of their slot in the active formation (the same V/chain
  switch as the hybrid reward): V slots around the leader, oriented along the direction from the
  followers' centroid to the leader (a follower does not observe the leader's heading); chain:
  the point at ``s_chain`` from the predecessor on the line towards it; the same speed cap over
  the obstacle area; no approach to, and repulsion from, robots closer than ``robot_clearance``;
  the same obstacle field as the leader. The leader observes no other robot, so it is the
  followers who keep clear of it.

The desired velocity becomes a force through a one-step velocity tracking law, clipped to the
action box; a robot closing on a sensed obstacle faster than ``obstacle_brake`` brakes instead with
the action box's corner on the outward side (up to 2.8 N along the normal against 2 N axis-aligned:
with a 0.2 m sensing range and a 0.1 m collision margin, the braking distance decides most
obstacle contacts). All gains are constructor arguments, chosen on the training scenarios (a
random search over 80 gain sets on seed 0, confirmed on seed 1), not on the held-out evaluation set.
"""

from __future__ import annotations

import math

import torch
from tensordict.nn import TensorDictModule
from torch import nn

from formation_rl.envs.config import EnvConfig
from formation_rl.envs.formations import slots
from formation_rl.models.config import ModelConfig


def _unit(x: torch.Tensor, eps: float = 1e-6) -> tuple[torch.Tensor, torch.Tensor]:
    n = x.norm(dim=-1, keepdim=True)
    return x / n.clamp_min(eps), n


def _limit(v: torch.Tensor, vmax: float) -> torch.Tensor:
    n = v.norm(dim=-1, keepdim=True)
    return v * (vmax / n.clamp_min(vmax))


class APFController(nn.Module):
    """``forward(obs [..., N, D]) -> actions [..., N, 2]`` in [-1, 1] for the world ``cfg`` describes."""

    def __init__(self, cfg: EnvConfig, *, cruise: float = 0.85, area_cruise: float = 0.65, brake: float = 1.6,
                 follow_gain: float = 1.5, robot_clearance: float = 0.65, robot_push: float = 4.0,
                 obstacle_push: float = 0.2, slide: float = 0.6, area_margin: float = 0.2,
                 obstacle_brake: float | None = 0.2):
        super().__init__()
        self.cfg = cfg
        self.cruise, self.area_cruise, self.brake = cruise, area_cruise, brake
        self.follow_gain, self.robot_clearance, self.robot_push = follow_gain, robot_clearance, robot_push
        self.obstacle_push, self.slide, self.area_margin = obstacle_push, slide, area_margin
        self.obstacle_brake = obstacle_brake
        n = cfg.num_robots
        self.register_buffer("v_slots", slots(cfg.formation, n).float(), persistent=False)  # [N, 2]
        area = cfg.area_formation
        self.chain = area.shape == "chain"
        self.area_switch = cfg.reward.variant == "hybrid"
        self.area_spacing = area.spacing
        self.register_buffer("area_slots", slots(area, n).float(), persistent=False)
        # follower i sees the others in index order; this puts its own position back at index i
        order = [list(range(i)) + [n - 1] + list(range(i, n - 1)) for i in range(1, n)]
        self.register_buffer("order", torch.tensor(order), persistent=False)  # [N-1, N]

    # ------------------------------------------------------------------ observation layout (reference.md)
    def _split(self, obs: torch.Tensor):
        n, m, w = self.cfg.num_robots, self.cfg.num_obstacles, self.cfg.role_width
        p, v = obs[..., 0:2], obs[..., 2:4]
        role = obs[..., 4:4 + 2 * (n - 1)]  # (the others' velocities, if observed, follow: unused here)
        obst = obs[..., 4 + w:4 + w + 3 * m].unflatten(-1, (m, 3))  # [..., N, M, 3]
        flag = obs[..., -1:] > 0.5
        return p, v, role, obst, flag

    @staticmethod
    def _avoid(v_des: torch.Tensor, rel: torch.Tensor, active: torch.Tensor, closeness: torch.Tensor,
               push: float, slide: float, toward: torch.Tensor) -> torch.Tensor:
        """Bend ``v_des`` [..., 2] round hazards at ``rel`` = p - hazard [..., K, 2] where ``active`` [..., K, 1]:
        drop the velocity component towards each hazard, turn it into a slide along the tangent on the
        side of ``toward``, and push outwards by ``push * closeness``."""
        out_dir, _ = _unit(rel)
        into = (v_des[..., None, :] * out_dir).sum(-1, keepdim=True).clamp_max(0.0).neg()  # > 0: moving in
        tangent = torch.stack([-out_dir[..., 1], out_dir[..., 0]], dim=-1)
        tangent = tangent * torch.sign((tangent * toward[..., None, :]).sum(-1, keepdim=True) + 1e-3)
        correction = into * (out_dir + slide * tangent) + push * closeness * out_dir
        return v_des + (active * correction).sum(-2)

    def _obstacle_field(self, v_des: torch.Tensor, obst: torch.Tensor, toward: torch.Tensor) -> torch.Tensor:
        """``v_des`` bent round the sensed obstacles ``obst`` [..., M, 3] (``(p - c_j, 1)`` if sensed)."""
        rel, sensed = obst[..., :2], obst[..., 2:3]
        return self._avoid(v_des, rel, sensed, torch.ones_like(sensed), self.obstacle_push, self.slide, toward)

    def _speed_cap(self, p: torch.Tensor) -> torch.Tensor:
        """Top speed at positions ``p`` [..., 2]: ``area_cruise`` over the obstacle area (widened by
        ``area_margin``), v_max elsewhere."""
        cfg = self.cfg
        reach = self.area_margin
        (x0, x1), (y0, y1) = cfg.obstacle_area_x, cfg.obstacle_area_y
        x, y = p[..., 0:1], p[..., 1:2]
        near = (x > x0 - reach) & (x < x1 + reach) & (y > y0 - reach) & (y < y1 + reach)
        return torch.where(near, self.area_cruise, cfg.max_speed)

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        cfg = self.cfg
        n = cfg.num_robots
        p, v, role, obst, flag = self._split(obs)

        # leader: braking profile towards the goal, slower over the obstacle area
        to_goal = -role[..., 0, 0:2]  # p_g - p
        heading, d = _unit(to_goal)
        cruise = torch.minimum(self._speed_cap(p[..., 0, :]), torch.full_like(d, self.cruise))
        speed = torch.minimum(cruise, (2 * self.brake * d).sqrt())
        v_lead = self._obstacle_field(heading * speed, obst[..., 0, :, :], heading)

        # followers: the positions of every robot, from each follower's own observation
        others = role[..., 1:, :].unflatten(-1, (n - 1, 2))  # [..., N-1, N-1, 2], other robots in index order
        own = p[..., 1:, :]
        if cfg.relative_positions:  # p_j - p_i back to p_j
            others = others + own[..., None, :]
        idx = torch.arange(1, n, device=obs.device)
        # all positions as follower i sees them: insert its own position at index i
        full = torch.cat([others, own[..., None, :]], dim=-2)  # [..., N-1, N, 2], own last
        full = torch.gather(full, -2, self.order[..., None].expand(*full.shape[:-1], 2))  # index order
        leader = full[..., 0, :]  # [..., N-1, 2]
        centroid = full[..., 1:, :].mean(-2)
        axis, spread = _unit(leader - centroid)
        fallback = torch.tensor([1.0, 1.0], device=obs.device) / math.sqrt(2.0)
        axis = torch.where(spread > 1e-3, axis, fallback)
        normal = torch.stack([-axis[..., 1], axis[..., 0]], dim=-1)
        slot = self.v_slots[idx]  # [N-1, 2] in the formation frame (x forward, y left)
        v_target = leader + slot[..., 0:1] * axis + slot[..., 1:2] * normal
        if self.chain:
            pred = full[..., :-1, :].diagonal(dim1=-3, dim2=-2).transpose(-1, -2)  # predecessor i-1 of follower i
            along, _ = _unit(own - pred)
            c_target = pred + self.area_spacing * along
        else:
            c_target = leader + self.area_slots[idx, 0:1] * axis + self.area_slots[idx, 1:2] * normal
        # each follower's own flag: the leader is inside the obstacle area (the chain is active)
        use_area = flag[..., 1:, :] & self.area_switch
        target = torch.where(use_area, c_target, v_target)
        v_fol = self.follow_gain * (target - own)
        v_fol = v_fol * (self._speed_cap(own) / v_fol.norm(dim=-1, keepdim=True).clamp_min(1e-6)).clamp_max(1.0)
        # robots: no approach inside robot_clearance (centre distance), pushed apart when closer
        rel = own[..., None, :] - full  # [..., N-1, N, 2], zero for itself
        gap = rel.norm(dim=-1, keepdim=True)
        active = (gap < self.robot_clearance) & (gap > 1e-6)
        closeness = (self.robot_clearance - gap) / self.robot_clearance
        heading_f = _unit(v_fol)[0]
        v_fol = self._avoid(v_fol, rel, active, closeness, self.robot_push, self.slide, heading_f)
        v_fol = self._obstacle_field(v_fol, obst[..., 1:, :, :], heading_f)

        v_des = _limit(torch.cat([v_lead[..., None, :], v_fol], dim=-2), cfg.max_speed)
        force = (v_des - v) * (cfg.mass / cfg.dt)  # reach v_des in one step if the force allows
        action = (force / cfg.max_force).clamp(-1.0, 1.0)
        if self.obstacle_brake is not None:
            action = self._brake(action, v, obst)
        return action

    def _brake(self, action: torch.Tensor, v: torch.Tensor, obst: torch.Tensor) -> torch.Tensor:
        """A robot closing on a sensed obstacle faster than ``obstacle_brake`` (m/s, along the line to its
        centre) brakes as hard as the action box allows: the corner of the box on the outward side, whose
        force along the outward normal is 2-2.8 N against the 2 N of any axis-aligned action."""
        rel, sensed = obst[..., :2], obst[..., 2:3] > 0.5  # [..., N, M, 2], [..., N, M, 1]
        out_dir, _ = _unit(rel)
        closing = -(v[..., None, :] * out_dir).sum(-1, keepdim=True)  # [..., N, M, 1], > 0: approaching
        closing = torch.where(sensed, closing, torch.full_like(closing, -1.0))
        worst, j = closing.max(-2)  # [..., N, 1]
        normal = torch.gather(out_dir, -2, j[..., None].expand(*j.shape, 2)).squeeze(-2)  # [..., N, 2]
        brake = worst > self.obstacle_brake
        corner = torch.where(normal >= 0, 1.0, -1.0)
        return torch.where(brake, corner, action)


def apf_policy(cfg: EnvConfig, **gains) -> TensorDictModule:
    """The controller as a TorchRL policy: ``("agents", "observation")`` -> ``("agents", "action")``."""
    return TensorDictModule(APFController(cfg, **gains), in_keys=[("agents", "observation")],
                            out_keys=[("agents", "action")])


def residual_base(model: ModelConfig, env_cfg: EnvConfig) -> nn.Module | None:
    """The controller the actors correct (``model.residual``), or None for the paper's actors."""
    if model.residual == "apf":
        return APFController(env_cfg)
    return None

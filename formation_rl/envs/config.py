"""Typed configuration of the formation world (docs/reference.md, World to Rewards).

The defaults are written here only, each marked (paper) or (choice); ``conf/env/default.yaml`` sets
none (``tests/envs/test_config.py`` keeps it so), and the formation and reward groups choose variants.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from formation_rl.utils import drop_retired

FORMATION_SHAPES = ("v", "chain")
REWARD_VARIANTS = ("hybrid", "fixed")


@dataclass
class FormationConfig:
    """A formation: slot geometry and which robot pairs are constrained (reference.md, Formations)."""

    shape: str = "v"  # v | chain
    spacing: float = 0.5  # m, distance between consecutive slots (s, or s_chain for chain)
    angle_deg: float = 45.0  # V half-angle phi (90 = line abreast); ignored by chain


def _chain() -> FormationConfig:
    return FormationConfig(shape="chain", spacing=0.4)


@dataclass
class RewardConfig:
    """Reward variant and the sparse/guided magnitudes (reference.md, Rewards)."""

    variant: str = "hybrid"  # hybrid: area_formation inside the obstacle area; fixed: never switch
    area_formation: FormationConfig | None = field(default_factory=_chain)
    goal: float = 10.0  # R1, leader within goal_radius of the goal
    formation_open: float = 1.0  # R2, follower holds every constraint of the open-space formation
    formation_area: float = 1.0  # R3, follower holds its constraint of the obstacle-area formation
    obstacle_collision: float = -20.0  # R4
    robot_collision: float = -10.0  # R5
    tolerance: float = 0.05  # eps, m: a constraint is held when |d - d*| <= eps
    # guided-term weights (ours, for learning; the paper's guided terms are distance 1, error 1, the rest 0):
    leader_distance: float = 1.0  # leader guided += -leader_distance * |p_lea - p_g|
    leader_progress: float = 0.0  # leader guided += leader_progress * (d_prev - d) / (v_max dt): goal progress
    follower_error: float = 1.0  # follower guided += -follower_error * (its active-formation error)
    follower_progress: float = 0.0  # follower guided += follower_progress * (e_prev - e) / (v_max dt), e_prev under
    #                                 the formation active now
    follower_velocity: float = 0.0  # follower guided += -follower_velocity * |v_i - v_lea| / v_max: the leader's
    #                                 velocity matched (a team that translates rigidly keeps every distance; ours)
    leader_team: float = 0.0  # leader guided += -leader_team * mean follower formation error (waits for its team)
    follower_slot: float = 0.0  # follower guided += -follower_slot * |p_i - its slot|, the open-space formation's
    #                             slots placed at the leader, turned to its heading (from rest: toward the goal);
    #                             0 while the area formation is active (ours)
    slot_frame: str = "heading"  # how those slots turn: "heading", with the leader's heading as above; "course",
    #                              along the course from the start square's centre to the goal, a frame that does
    #                              not turn during the episode (ours)
    follower_chain_slot: float = 0.0  # follower guided += -w |p_i - (p_pred - s_chain u_pred)| while the chain is
    #                                   active: the point one chain spacing behind its predecessor along that robot's
    #                                   heading u_pred (from rest, slower than 5% of v_max: along the line from the
    #                                   follower to it, where the term is its chain error); a slot that follows the way
    #                                   the robot ahead went, not the leader's heading (ours)
    proximity: float = 0.0  # every robot's guided += -proximity * sum over robots and obstacles closer than
    #                         proximity_range to a collision of (1 - clearance / proximity_range) (ours)
    proximity_range: float = 0.2  # m, clearance (gap beyond the collision margin) where that penalty starts
    scale: float = 1.0  # every reward (guided and sparse) times this
    own_progress: bool = False  # follower_progress counts the follower's own move only: its error with the others
    #                             where they are now, from where it was to where it is (a difference reward, ours);
    #                             false: the change of its error, whoever moved
    leader_robot_collision: float = 1.0  # the leader's share of R5 (ours; 1: the paper). 0: followers alone answer
    #                                      for robot contacts, and a contact leaves the leader's guided term in place;
    #                                      it scales the robot part of the leader's proximity ramp too
    start_robot_collision: float | None = None  # R5 for a robot's contact while it is inside the start square, where
    #                                             the team assembles from discs 0.3 m apart (ours); None: R5 everywhere


@dataclass
class EnvConfig:
    """Every quantity of the world, with its default: the one place it is written (conf/env/default.yaml
    sets nothing). (paper) = Zhou et al. 2023; (choice) = ours where the paper is silent."""

    num_robots: int = 5  # N (paper); index 0 is the leader, odd = left followers, even = right
    num_obstacles: int = 4  # M (paper)
    arena_half_size: float = 4.0  # arena [-a, a]^2 (paper); centres kept in [-a + r, a - r], velocity into a wall
    #                               zeroed (choice)
    robot_radius: float = 0.1  # r (paper)
    mass: float = 1.0  # kg (choice)
    dt: float = 0.1  # s (choice)
    max_force: float = 2.0  # N, force = action * max_force (choice)
    max_speed: float = 0.85  # v_max, m/s (paper)
    obstacle_radius_min: float = 0.4  # obstacle radius uniform in (0.4, 0.6) m (paper)
    obstacle_radius_max: float = 0.6
    obstacle_min_gap: float = 0.5  # surface-to-surface gap between obstacles at placement (choice)
    obstacle_area_x: tuple[float, float] = (-3.0, 3.0)  # obstacle area (paper)
    obstacle_area_y: tuple[float, float] = (-2.0, 2.0)
    goal_low: float = 3.0  # goal uniform in [goal_low, goal_high]^2 (paper)
    goal_high: float = 3.5
    goal_radius: float = 0.05  # rho_g (paper)
    start_low: float = -3.8  # robots uniform in [start_low, start_high]^2, centre distances >= 2r + rho_r, clear of
    #                          obstacle collision, at rest (choice)
    start_high: float = -2.8
    max_steps: int = 150  # episode length, ended by truncation only (paper)
    robot_collision_margin: float = 0.1  # rho_r (paper)
    obstacle_collision_margin: float = 0.1  # rho_o (paper)
    sensing_range: float = 0.2  # rho_d, surface gap under which an obstacle is sensed (paper)
    placement_tries: int = 200  # rounds of rejection sampling before a layout is declared impossible (choice)
    relative_positions: bool = False  # followers see the others at p_j - p_i, not p_j (a departure, docs/departures.md)
    observe_velocities: bool = False  # followers also see the others' velocities after their positions (a departure)
    observe_distance_errors: bool = False  # ... and then d_ij - d*_ij to each other robot under the active formation,
    #                                        0 for a pair it does not keep (a departure)
    formation: FormationConfig = field(default_factory=FormationConfig)
    reward: RewardConfig = field(default_factory=RewardConfig)

    @property
    def obs_dim(self) -> int:
        """Per-robot observation width D = 4 + 2(N-1) + 3M + 1 (reference.md, Observations and actions);
        2(N-1) more with ``observe_velocities``."""
        return 4 + self.role_width + 3 * self.num_obstacles + 1

    @property
    def role_width(self) -> int:
        """Width of the role block: 2(N-1), twice that with ``observe_velocities``, N-1 more with
        ``observe_distance_errors``."""
        n = self.num_robots - 1
        return 2 * n * (2 if self.observe_velocities else 1) + (n if self.observe_distance_errors else 0)

    @property
    def area_formation(self) -> FormationConfig:
        """Formation required while the leader is inside the obstacle area."""
        if self.reward.variant == "hybrid" and self.reward.area_formation is not None:
            return self.reward.area_formation
        return self.formation

    @classmethod
    def from_dict(cls, cfg: Mapping[str, Any]) -> EnvConfig:
        """Build from a plain mapping or an OmegaConf node (the Hydra ``env`` group)."""
        if hasattr(cfg, "_metadata"):  # an OmegaConf DictConfig
            from omegaconf import OmegaConf

            cfg = OmegaConf.to_container(cfg, resolve=True)
        cfg = drop_retired(cfg, "env")
        known = {f.name for f in dataclasses.fields(cls)}
        unknown = sorted(set(cfg) - known)
        if unknown:
            raise ValueError(f"env.{unknown[0]}: unknown field; allowed: {', '.join(sorted(known))}")
        formation = cfg.pop("formation", None)
        reward = cfg.pop("reward", None)
        for key in ("obstacle_area_x", "obstacle_area_y"):
            if key in cfg:
                cfg[key] = tuple(cfg[key])
        out = cls(**cfg)
        if formation is not None:
            out.formation = _sub(FormationConfig, formation, "env.formation")
        if reward is not None:
            reward = dict(reward)
            area = reward.pop("area_formation", "keep")
            out.reward = _sub(RewardConfig, reward, "env.reward")
            if area is None:
                out.reward.area_formation = None
            elif area != "keep":
                out.reward.area_formation = _sub(FormationConfig, area, "env.reward.area_formation")
        return out

    def validate(self) -> None:
        """Raise one ``ValueError`` naming the field, the value and what is allowed."""
        _check(self.num_robots, "num_robots", lambda v: isinstance(v, int) and v >= 2, "an integer >= 2")
        _check(self.num_obstacles, "num_obstacles", lambda v: isinstance(v, int) and v >= 0, "an integer >= 0")
        _check(self.max_steps, "max_steps", lambda v: isinstance(v, int) and v >= 1, "an integer >= 1")
        _check(self.placement_tries, "placement_tries", lambda v: isinstance(v, int) and v >= 1, "an integer >= 1")
        for name in ("relative_positions", "observe_velocities", "observe_distance_errors"):
            _check(getattr(self, name), name, lambda v: isinstance(v, bool), "true or false")
        for name in ("arena_half_size", "robot_radius", "mass", "dt", "max_force", "max_speed", "goal_radius"):
            _check(getattr(self, name), name, _positive, "a finite number > 0")
        for name in ("obstacle_min_gap", "robot_collision_margin", "obstacle_collision_margin", "sensing_range"):
            _check(getattr(self, name), name, _non_negative, "a finite number >= 0")
        _check(self.obstacle_radius_min, "obstacle_radius_min", _positive, "a finite number > 0")
        _check(
            self.obstacle_radius_max,
            "obstacle_radius_max",
            lambda v: _positive(v) and v >= self.obstacle_radius_min,
            f"a finite number >= obstacle_radius_min ({self.obstacle_radius_min})",
        )
        inner = self.arena_half_size - self.robot_radius
        _check(inner, "robot_radius", _positive, f"smaller than arena_half_size ({self.arena_half_size})")
        a = self.arena_half_size
        for name in ("obstacle_area_x", "obstacle_area_y"):
            _check(
                getattr(self, name),
                name,
                lambda v: len(v) == 2 and all(map(_finite, v)) and -a <= v[0] < v[1] <= a,
                f"a pair (low, high) with -{a} <= low < high <= {a}",
            )
        for lo, hi in (("goal_low", "goal_high"), ("start_low", "start_high")):
            high = getattr(self, hi)
            _check(
                getattr(self, lo),
                lo,
                lambda v, high=high: _finite(v) and _finite(high) and -inner <= v <= high <= inner,
                f"low <= {hi} ({high}), both inside the arena [-{inner}, {inner}]",
            )
        _check_formation(self.formation, "formation")
        r = self.reward
        _check(r.variant, "reward.variant", lambda v: v in REWARD_VARIANTS, f"one of {', '.join(REWARD_VARIANTS)}")
        if r.area_formation is not None:
            _check_formation(r.area_formation, "reward.area_formation")
        for name in ("goal", "formation_open", "formation_area", "obstacle_collision", "robot_collision",
                     "leader_distance", "leader_progress", "follower_error", "follower_progress", "follower_velocity",
                     "leader_team", "follower_slot", "follower_chain_slot", "proximity"):
            _check(getattr(r, name), f"reward.{name}", _finite, "a finite number")
        _check(r.tolerance, "reward.tolerance", _non_negative, "a finite number >= 0")
        _check(r.scale, "reward.scale", _positive, "a finite number > 0")
        _check(r.follower_chain_slot, "reward.follower_chain_slot",
               lambda v: v == 0 or (r.variant == "hybrid" and self.area_formation.shape == "chain"),
               "0 unless reward.variant is hybrid with a chain as the area formation")
        _check(r.slot_frame, "reward.slot_frame", lambda v: v in ("heading", "course"), "heading or course")
        _check(r.own_progress, "reward.own_progress", lambda v: isinstance(v, bool), "true or false")
        _check(r.leader_robot_collision, "reward.leader_robot_collision", lambda v: _finite(v) and 0 <= v <= 1,
               "a number in [0, 1]")
        _check(r.proximity_range, "reward.proximity_range", _positive, "a finite number > 0")
        _check(r.start_robot_collision, "reward.start_robot_collision", lambda v: v is None or _finite(v),
               "a finite number or null")


def _sub(cls: type, value: Any, where: str) -> Any:
    if isinstance(value, cls):
        return value
    value = drop_retired(value, where)
    known = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(value) - known)
    if unknown:
        raise ValueError(f"{where}.{unknown[0]}: unknown field; allowed: {', '.join(sorted(known))}")
    return cls(**value)


def _finite(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def _positive(v: Any) -> bool:
    return _finite(v) and v > 0


def _non_negative(v: Any) -> bool:
    return _finite(v) and v >= 0


def _check(value: Any, name: str, ok, allowed: str) -> None:
    try:
        good = bool(ok(value))
    except TypeError:
        good = False
    if not good:
        raise ValueError(f"env.{name} = {value!r} is invalid: must be {allowed}")


def _check_formation(f: FormationConfig, name: str) -> None:
    _check(f.shape, f"{name}.shape", lambda v: v in FORMATION_SHAPES, f"one of {', '.join(FORMATION_SHAPES)}")
    _check(f.spacing, f"{name}.spacing", _positive, "a finite number > 0")
    _check(f.angle_deg, f"{name}.angle_deg", lambda v: _finite(v) and 0 < v <= 90, "a number in (0, 90]")

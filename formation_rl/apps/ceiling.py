"""What the obstacle sensing range allows a reactive team: ``python -m formation_rl.apps.ceiling [overrides]``.

A policy that acts on the observation of docs/reference.md sees an obstacle only once its surface is within
``sensing_range`` (rho_d, 0.2 m by default), and it collides 0.1 m later (rho_o). For each sensing
range this runs a random search over the classical controller's gains (``formation_rl.models.controller``)
on training scenarios (seed 0), then evaluates the best gain set on the held-out scenarios of
``make eval``, and reports the team's success with its parts and the leader's own share: the leader
at the goal at the last step without touching an obstacle (it sees no other robot, so nothing the
followers do can raise that share), also for the gain set that maximises that share. Writes
``ceiling.json``, ``ceiling.md`` and ``ceiling.png`` into ``out``.
"""

from __future__ import annotations

import json
import math
import random
from dataclasses import dataclass, field
from pathlib import Path

import hydra
import torch
from hydra.core.config_store import ConfigStore
from omegaconf import DictConfig, OmegaConf
from tensordict import TensorDictBase

from formation_rl.apps.cli import CONF, one_line_errors
from formation_rl.envs import EnvConfig
from formation_rl.evaluation.diagnose import failure_metrics
from formation_rl.evaluation.evaluate import EVAL_SEED, evaluate_policy, mean_ci
from formation_rl.models.controller import apf_policy

# the gains searched, each over a few values around the defaults (the defaults are in every list)
SPACE = {
    "area_cruise": (0.6, 0.65, 0.7, 0.75, 0.85),
    "area_margin": (0.0, 0.2),
    "brake": (1.2, 1.6, 2.0),
    "follow_gain": (1.5, 2.5, 4.0),
    "robot_clearance": (0.55, 0.65, 0.75),
    "robot_push": (2.0, 4.0),
    "obstacle_push": (0.2, 0.3, 0.5),
    "slide": (0.4, 0.6, 1.0),
    "obstacle_brake": (0.1, 0.2, 0.3),
}
REPORTED = ("success", "leader_ok", "at_goal", "no_robot_collision", "no_obstacle_collision", "CBRO", "UDBLT", "RFSE")


@dataclass
class CeilingConfig:
    ranges: list[float] = field(default_factory=lambda: [0.2, 0.3, 0.4, 0.6])  # sensing ranges rho_d tried (m)
    trials: int = 40  # gain sets tried per range (the defaults first)
    episodes: int = 500  # training scenarios (seed 0) per trial
    held_out: int = 1000  # held-out episodes for each range's best gain set
    out: str = "outputs/ceiling"  # where ceiling.json, ceiling.md and ceiling.png go


ConfigStore.instance().store(name="ceiling_schema", node=CeilingConfig)


def braking_limit(cfg: EnvConfig, corner: bool) -> float:
    """The largest closing speed (m/s, to 0.01) at which a robot that first senses an obstacle can
    always stop short of contact: it comes into view at a gap in ``(rho_d - v dt, rho_d]`` and must
    keep the gap >= rho_o while shedding ``max_force / mass * dt`` of speed per step (``sqrt(2)``
    times that with the action box's corner on a diagonal normal), moving after each speed update
    (semi-implicit Euler; reference.md, World)."""
    shed = cfg.max_force / cfg.mass * cfg.dt * (math.sqrt(2.0) if corner else 1.0)
    room = cfg.sensing_range - cfg.obstacle_collision_margin
    best = 0.0
    for k in range(1, 1 + round(cfg.max_speed * 100)):
        v, travel, speed = k / 100, 0.0, k / 100
        while speed > 0:
            speed = max(0.0, speed - shed)
            travel += speed * cfg.dt
        if travel <= room - v * cfg.dt:
            best = v
    return best


def safe_path_time(cfg: EnvConfig, band_speed: float) -> float:
    """Seconds from the centre of the start square to the centre of the goal square if the leader flies
    at v_max except where an obstacle may be met (the obstacle area grown by the largest contact
    distance, ``r_max + r + rho_o``), which it crosses at ``band_speed``: the faster of crossing that
    region (best entry and exit points on a 2.5 cm grid) and going round it along the arena's east
    wall. Acceleration from rest and braking at the goal are left out (they only add time)."""
    reach = cfg.obstacle_radius_max + cfg.robot_radius + cfg.obstacle_collision_margin
    lo, hi = cfg.obstacle_area_y[0] - reach, cfg.obstacle_area_y[1] + reach
    east = cfg.obstacle_area_x[1] + reach  # the region's east edge
    wall = cfg.arena_half_size - cfg.robot_radius
    s = (cfg.start_low + cfg.start_high) / 2
    g = (cfg.goal_low + cfg.goal_high) / 2
    v = cfg.max_speed
    grid = [s + 0.025 * i for i in range(round((wall - s) / 0.025) + 1)]
    through = min(math.hypot(x1 - s, lo - s) / v + math.hypot(x2 - x1, hi - lo) / band_speed
                  + math.hypot(g - x2, g - hi) / v for x1 in grid for x2 in grid if x2 >= x1)
    if wall > east:  # a strip along the east wall that no obstacle reaches
        x = (east + wall) / 2
        around = (math.hypot(x - s, lo - s) + (hi - lo) + math.hypot(g - x, g - hi)) / v
        through = min(through, around)
    return through


def team_metrics(rollout: TensorDictBase, goal_radius: float) -> dict[str, torch.Tensor]:
    """:func:`~formation_rl.evaluation.diagnose.failure_metrics` plus ``leader_ok``: the leader at the goal at the last
    step and never within the obstacle collision margin (from the world state the rollout carries)."""
    out = failure_metrics(rollout, goal_radius)
    state = rollout["next", "state"]
    leader = state["positions"][..., 0, :]  # [B, T, 2]
    gap = (leader[..., None, :] - state["obstacle_centers"]).norm(dim=-1) - state["obstacle_radii"]
    return {**out, "leader_obstacle_gap": gap.amin((-1, -2))}


def _summarise(per: dict[str, torch.Tensor], cfg: EnvConfig) -> dict[str, float]:
    touched = per.pop("leader_obstacle_gap") - cfg.robot_radius < cfg.obstacle_collision_margin
    per["leader_ok"] = per["at_goal"] * ~touched  # at_goal and the collision-free parts: episode_metrics'
    out = {}
    for k in REPORTED:
        mean, ci = mean_ci(per[k])
        out[k], out[f"{k}_ci95"] = mean, ci
    return out


def score(cfg: EnvConfig, gains: dict, episodes: int, seed: int) -> dict[str, float]:
    per = evaluate_policy(apf_policy(cfg, **gains), cfg, episodes, num_envs=episodes, seed=seed, progress=False,
                          metrics=team_metrics)
    return _summarise(per, cfg)


def search(cfg: EnvConfig, trials: int, episodes: int, rng: random.Random) -> dict[str, tuple[dict, dict]]:
    """Among the defaults and ``trials - 1`` random draws from :data:`SPACE`, the gain sets with the
    highest team success and the highest ``leader_ok`` on ``episodes`` training scenarios (seed 0)."""
    best: dict[str, tuple[dict, dict]] = {}
    for t in range(trials):
        gains = {} if t == 0 else {k: rng.choice(v) for k, v in SPACE.items()}
        result = score(cfg, gains, episodes, seed=0)
        for key in ("success", "leader_ok"):
            if key not in best or result[key] > best[key][1][key]:
                best[key] = (gains, result)
    return best


def plot(rows: list[dict], out: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ranges = [r["sensing_range"] for r in rows]
    fig, ax = plt.subplots(figsize=(5.5, 3.8))
    leader_label = "leader at goal, no obstacle contact (gains chosen for it)"
    for src, key, label in (("held_out_leader", "leader_ok", leader_label),
                            ("held_out", "success", "team success"),
                            ("held_out", "no_obstacle_collision", "no obstacle contact (team)")):
        y = [100 * r[src][key] for r in rows]
        e = [100 * r[src][f"{key}_ci95"] for r in rows]
        ax.errorbar(ranges, y, yerr=e, marker="o", capsize=3, label=label)
    ax.axhline(90, color="k", ls=":", lw=1, label="issue 6 target (90%)")
    ax.axvline(0.2, color="gray", ls="--", lw=1)
    ax.set_xlabel("obstacle sensing range rho_d (m); default: 0.2")
    ax.set_ylabel("held-out episodes (%)")
    ax.set_ylim(0, 100)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="lower right")
    ax.set_title("best classical controller per sensing range")
    fig.tight_layout()
    path = out / "ceiling.png"
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def run(cfg: CeilingConfig) -> list[Path]:
    """Search and evaluate each sensing range, print a line per range and the table; return the files written."""
    for name in ("trials", "episodes", "held_out"):
        if getattr(cfg, name) < 1:
            raise ValueError(f"{name} = {getattr(cfg, name)} is invalid: must be an integer >= 1")
    bad = [r for r in cfg.ranges if r <= 0]
    if not cfg.ranges or bad:
        raise ValueError(f"ranges = {list(cfg.ranges)} is invalid: must be a non-empty list of sensing ranges > 0 m")
    out = Path(cfg.out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise ValueError(f"out = {str(out)!r} is invalid: cannot write there: {err.strerror or err}") from None
    spec = EnvConfig()
    physics = {"braking_limit_axis": braking_limit(spec, corner=False),
               "braking_limit_corner": braking_limit(spec, corner=True),
               "free_path_time": safe_path_time(spec, spec.max_speed)}
    for key in ("axis", "corner"):
        physics[f"safe_path_time_{key}"] = safe_path_time(spec, physics[f"braking_limit_{key}"])
    print(f"Default world: an obstacle first sensed while closing faster than {physics['braking_limit_axis']:.2f} m/s "
          f"({physics['braking_limit_corner']:.2f} m/s braking with the corner on a diagonal) may not be avoided; "
          f"flying where obstacles may be at those speeds, start to goal takes {physics['safe_path_time_axis']:.1f} s "
          f"({physics['safe_path_time_corner']:.1f} s) on the mean scenario, against {physics['free_path_time']:.1f} s "
          f"at v_max and an episode of {spec.max_steps * spec.dt:.0f} s", flush=True)
    torch.set_num_threads(1)
    rng = random.Random(0)
    rows = []
    for rho in cfg.ranges:
        world = EnvConfig(sensing_range=rho)
        best = search(world, cfg.trials, cfg.episodes, rng)
        gains, train = best["success"]
        held = score(world, gains, cfg.held_out, seed=EVAL_SEED)
        leader_gains = best["leader_ok"][0]
        leader = score(world, leader_gains, cfg.held_out, seed=EVAL_SEED)
        rows.append({"sensing_range": rho, "gains": gains, "train": train, "held_out": held,
                     "leader_gains": leader_gains, "held_out_leader": leader})
        print(f"sensing {rho:.2f} m: success {100 * held['success']:.1f}% "
              f"(leader alone {100 * held['leader_ok']:.1f}%, "
              f"at goal {100 * held['at_goal']:.1f}%, no obstacle contact {100 * held['no_obstacle_collision']:.1f}%, "
              f"no robot contact {100 * held['no_robot_collision']:.1f}%) with {gains or 'the default gains'}; "
              f"leader alone at best {100 * leader['leader_ok']:.1f}% with {leader_gains or 'the default gains'}",
              flush=True)
    (out / "ceiling.json").write_text(json.dumps({"trials": cfg.trials, "episodes": cfg.episodes,
                                                  "held_out": cfg.held_out, "physics": physics, "rows": rows},
                                                 indent=2))
    lines = ["| sensing range (m) | success | leader at goal, no obstacle contact | leader at goal | "
             "no obstacle contact | no robot contact | CBRO (%) | UDBLT (m) | RFSE (m) | leader at goal, no obstacle "
             "contact, gains chosen for it |",
             "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        h = r["held_out"]
        pct = " | ".join(f"{100 * h[k]:.1f} ± {100 * h[k + '_ci95']:.1f}%"
                         for k in ("success", "leader_ok", "at_goal", "no_obstacle_collision", "no_robot_collision"))
        lead = r["held_out_leader"]
        lines.append(f"| {r['sensing_range']:.2f} | {pct} | {h['CBRO']:.2f} | {h['UDBLT']:.3f} | {h['RFSE']:.2f} | "
                     f"{100 * lead['leader_ok']:.1f} ± {100 * lead['leader_ok_ci95']:.1f}% |")
    (out / "ceiling.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return [out / "ceiling.json", out / "ceiling.md", plot(rows, out)]


@hydra.main(config_path=str(CONF), config_name="ceiling", version_base=None)
@one_line_errors
def main(cfg: DictConfig) -> None:
    written = run(OmegaConf.to_object(cfg))
    print(f"wrote {', '.join(map(str, written[:-1]))} and {written[-1]}")


if __name__ == "__main__":
    from formation_rl.apps.cli import check_overrides

    check_overrides(CeilingConfig, ())
    main()

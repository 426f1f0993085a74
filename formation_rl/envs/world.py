"""World and observations (docs/reference.md) as batched tensor functions: dynamics, scenario sampling, observations.

Every function works on a batch of environment copies at once (leading dim ``B``); none loops over
copies or robots.
"""

from __future__ import annotations

from collections.abc import Callable

import torch

from formation_rl.envs.config import EnvConfig

CANDIDATES = 32  # rejection-sampling candidates drawn per object and round
EXACT = "donot_use_mm_for_euclid_dist"


def integrate(pos: torch.Tensor, vel: torch.Tensor, action: torch.Tensor, cfg: EnvConfig):
    """One semi-implicit Euler step (reference.md, World; paper §2.1). All batch-last ``[2, N, B]``."""
    vel = vel + action * (cfg.max_force / cfg.mass * cfg.dt)
    speed = torch.hypot(vel[0], vel[1])  # [N, B]
    vel = vel * (cfg.max_speed / speed).clamp_(max=1.0)  # rescale only when |v| > v_max
    pos = pos + vel * cfg.dt
    lim = cfg.arena_half_size - cfg.robot_radius
    into_wall = ((pos <= -lim) & (vel < 0)) | ((pos >= lim) & (vel > 0))  # velocity into a wall is zeroed
    return pos.clamp_(-lim, lim), vel.masked_fill_(into_wall, 0.0)


def _uniform(shape: tuple[int, ...], low: float, high: float, gen: torch.Generator, device) -> torch.Tensor:
    return torch.rand(shape, generator=gen, device=device) * (high - low) + low


def place_discs(
    n: int,
    count: int,
    sample: Callable[[int], tuple[torch.Tensor, torch.Tensor]],
    min_gap: float,
    tries: int,
    device: torch.device | str,
    blockers: tuple[torch.Tensor, torch.Tensor, float] | None = None,
) -> tuple[torch.Tensor, torch.Tensor] | None:
    """Place ``count`` discs in each of ``n`` copies by sequential rejection sampling.

    ``sample(pending)`` draws ``CANDIDATES`` candidate discs for each pending copy (indices ``[P]``),
    ``([P, K, 2], [P, K])``.
    Surface gaps between placed discs are at least ``min_gap``; against ``blockers`` (centres
    ``[n, F, 2]``, radii ``[n, F]``, gap) at least that gap. A copy that jams is restarted; after
    ``tries`` rounds with copies still pending, returns ``None``.
    """
    dev = torch.device(device)
    centers = torch.zeros(n, count, 2, device=dev)
    radii = torch.zeros(n, count, device=dev)
    pending = torch.arange(n, device=dev)
    for _ in range(tries):
        if pending.numel() == 0 or count == 0:
            return centers, radii
        p = pending.numel()
        placed_ok = torch.ones(p, dtype=torch.bool, device=dev)
        rows = torch.arange(p, device=dev)
        for k in range(count):
            c, r = sample(pending)  # [P, K, 2], [P, K]
            ok = torch.ones(r.shape, dtype=torch.bool, device=dev)
            if k > 0:
                gap = torch.cdist(c, centers[pending, :k], compute_mode=EXACT) - r[..., None] - radii[pending, None, :k]
                ok &= (gap >= min_gap).all(-1)
            if blockers is not None and blockers[0].shape[1] > 0:
                bc, br, bgap = blockers
                gap = torch.cdist(c, bc[pending], compute_mode=EXACT) - r[..., None] - br[pending, None, :]
                ok &= (gap >= bgap).all(-1)
            pick = ok.to(torch.uint8).argmax(-1)  # first valid candidate (0 when none)
            placed_ok &= ok.any(-1)
            centers[pending, k] = c[rows, pick]
            radii[pending, k] = r[rows, pick]
        pending = pending[~placed_ok]
    return (centers, radii) if pending.numel() == 0 or count == 0 else None


def sample_scenarios(n: int, cfg: EnvConfig, gen: torch.Generator, device,
                     anywhere: float = 0.0, team: bool = False) -> dict[str, torch.Tensor]:
    """Goal, obstacles and start positions for ``n`` fresh episodes (reference.md, World).

    ``anywhere``: the share of episodes whose robots start anywhere in the arena instead of the default
    start square (each robot uniform, clear of the others and of obstacles): exploring starts for
    training only (``FormationEnv(start_anywhere=...)``); 0 is the default world. ``team``: those
    episodes keep the start square's size and move it, team and all, anywhere in the arena.
    """
    k = CANDIDATES
    (x0, x1), (y0, y1) = cfg.obstacle_area_x, cfg.obstacle_area_y
    inner = cfg.arena_half_size - cfg.robot_radius
    spread = torch.rand(n, generator=gen, device=device) < anywhere if anywhere > 0 else None
    if spread is not None and team:  # the square's lower corner, uniform where the square fits in the arena
        side = cfg.start_high - cfg.start_low
        corner = _uniform((n, 1, 2), -inner, inner - side, gen, device) - cfg.start_low

    def obstacle(pending: torch.Tensor):
        p = pending.numel()
        c = torch.stack([_uniform((p, k), x0, x1, gen, device), _uniform((p, k), y0, y1, gen, device)], -1)
        return c, _uniform((p, k), cfg.obstacle_radius_min, cfg.obstacle_radius_max, gen, device)

    placed = place_discs(n, cfg.num_obstacles, obstacle, cfg.obstacle_min_gap, cfg.placement_tries, device)
    if placed is None:
        raise ValueError(
            f"env.num_obstacles = {cfg.num_obstacles} is invalid: obstacles of radius "
            f"[{cfg.obstacle_radius_min}, {cfg.obstacle_radius_max}] cannot be placed in the obstacle area "
            f"x{list(cfg.obstacle_area_x)} y{list(cfg.obstacle_area_y)} with gaps >= obstacle_min_gap "
            f"({cfg.obstacle_min_gap}) after placement_tries ({cfg.placement_tries}) rounds; "
            "use fewer or smaller obstacles, a smaller gap or a larger area"
        )
    obstacle_centers, obstacle_radii = placed

    # robots: centre distances >= 2r + rho_r, i.e. discs of radius r + rho_r / 2 with zero gap;
    # clear of obstacle collision at t = 0 (choice: the default start square may touch an obstacle)
    exclusion = cfg.robot_radius + cfg.robot_collision_margin / 2

    calls = [0]

    def robot(pending: torch.Tensor):
        p = pending.numel()
        if spread is not None and team and calls[0] and calls[0] % cfg.num_robots == 0:
            # a new round of place_discs (one call per robot): copies that jammed get a new square
            corner[pending] = _uniform((p, 1, 2), -inner, inner - side, gen, device) - cfg.start_low
        calls[0] += 1
        c = _uniform((p, k, 2), cfg.start_low, cfg.start_high, gen, device)
        if spread is not None:
            moved = c + corner[pending] if team else _uniform((p, k, 2), -inner, inner, gen, device)
            c = torch.where(spread[pending, None, None], moved, c)
        return c, torch.full((p, k), exclusion, device=device)

    clearance = cfg.robot_collision_margin / 2 + cfg.obstacle_collision_margin  # |p-c| - R >= r + rho_o
    placed = place_discs(
        n, cfg.num_robots, robot, 0.0, cfg.placement_tries, device, (obstacle_centers, obstacle_radii, clearance)
    )
    if placed is None:
        raise ValueError(
            f"env.num_robots = {cfg.num_robots} is invalid: that many robots cannot start in the square "
            f"[start_low, start_high]^2 = [{cfg.start_low}, {cfg.start_high}]^2 with centre distances >= "
            f"2 robot_radius + robot_collision_margin ({2 * cfg.robot_radius + cfg.robot_collision_margin:g}) "
            f"and clear of obstacles after placement_tries ({cfg.placement_tries}) rounds; "
            "enlarge the start square or use fewer robots"
        )
    goal = _uniform((n, 2), cfg.goal_low, cfg.goal_high, gen, device)
    return {
        "positions": placed[0],
        "goal": goal,
        "obstacle_centers": obstacle_centers,
        "obstacle_radii": obstacle_radii,
    }


def _source_rows(n: int, m: int) -> tuple[int, ...]:
    """First row of each block of the source :func:`observe` builds, and its total height.

    Blocks: positions x (N), y (N); velocities x (N), y (N); p_lea - p_g (2); a zero (1);
    obstacle offsets x (N*M), y (N*M); sensed flags (N*M); obstacle-area flag (1); distance errors d_ij - d*_ij
    (N*N, row i*N + j; filled only with ``observe_distance_errors``).
    """
    P, V, G, Z = 0, 2 * n, 4 * n, 4 * n + 2
    OX, OY, S = Z + 1, Z + 1 + n * m, Z + 1 + 2 * n * m
    F = S + n * m
    E = F + 1
    return P, V, G, Z, OX, OY, S, F, E, E + n * n


def observation_index(n: int, m: int, device=None, velocities: bool = False,
                      distance_errors: bool = False) -> torch.Tensor:
    """Rows of the source built in :func:`observe` that make each robot's observation, ``[N * D]``;
    ``velocities``: the role block goes on with the other robots' velocities (zeros for the leader);
    ``distance_errors``: ... then with ``d_ij - d*_ij`` to each other robot j (zeros for the leader)."""
    P, V, G, Z, OX, OY, S, F, E, _ = _source_rows(n, m)
    rows = []
    for i in range(n):
        row = [P + i, P + n + i, V + i, V + n + i]  # own p, v
        if i == 0:  # p - p_g, then zeros
            zeros = 2 * (n - 2) + (2 * (n - 1) if velocities else 0) + (n - 1 if distance_errors else 0)
            row += [G, G + 1] + [Z] * zeros
        else:
            others = [j if j < i else j + 1 for j in range(n - 1)]  # other robots in index order
            for k in others:
                row += [P + k, P + n + k]
            for k in others if velocities else ():
                row += [V + k, V + n + k]
            row += [E + i * n + k for k in others] if distance_errors else []
        for j in range(m):
            row += [OX + i * m + j, OY + i * m + j, S + i * m + j]  # (p - c_j, 1) if sensed
        rows += row + [F]
    return torch.tensor(rows, dtype=torch.int64, device=device)


def observe(pos: torch.Tensor, vel: torch.Tensor, q: dict[str, torch.Tensor], index: torch.Tensor) -> torch.Tensor:
    """Per-robot observations (reference.md, Observations and actions), ``[B, N, D]`` with D = 4 + 2(N-1) + 3M + 1.

    ``pos``/``vel`` are batch-last ``[2, N, B]``, ``q`` the output of
    :func:`formation_rl.envs.rewards.step_quantities`, ``index`` from :func:`observation_index`.
    One gather of contiguous rows, then one transpose: no strided writes.
    """
    _, n, b = pos.shape
    P, V, G, Z, OX, OY, S, F, E, height = _source_rows(n, q["sensed"].shape[1])
    source = torch.empty(height, b, dtype=pos.dtype, device=pos.device)
    source[P:V] = pos.reshape(2 * n, b)
    source[V:G] = vel.reshape(2 * n, b)
    source[G:Z] = q["to_goal"]
    source[Z] = 0.0
    sensed = source[S:F].view_as(q["sensed"]).copy_(q["sensed"])  # [N, M, B] as 0/1
    ox, oy = q["to_obstacle"]
    torch.mul(ox, sensed, out=source[OX:OY].view_as(ox))  # (p - c_j, 1) if sensed, else zeros
    torch.mul(oy, sensed, out=source[OY:S].view_as(oy))
    source[F] = q["in_area"]
    if "distance_error" in q:
        source[E:] = q["distance_error"].reshape(n * n, b)
    return source.index_select(0, index).T.reshape(b, n, -1)


def make_relative(obs: torch.Tensor, velocities: bool = False) -> torch.Tensor:
    """Followers' role blocks of ``obs`` [B, N, D] as positions relative to their own: p_j - p_i, in place
    (and, with ``velocities``, the others' velocities relative to their own: v_j - v_i).

    ``EnvConfig.relative_positions`` (a choice; docs/departures.md): the same layout, translation-invariant.
    ``obs`` is the fresh tensor :func:`observe` returns.
    """
    n = obs.shape[-2]
    obs[..., 1:, 4:4 + 2 * (n - 1)].unflatten(-1, (n - 1, 2)).sub_(obs[..., 1:, None, 0:2])
    if velocities:
        start = 4 + 2 * (n - 1)
        obs[..., 1:, start:start + 2 * (n - 1)].unflatten(-1, (n - 1, 2)).sub_(obs[..., 1:, None, 2:4])
    return obs

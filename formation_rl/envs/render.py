"""Pictures of the world: one state to an RGB array, a rollout to a GIF (matplotlib, Agg)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import torch  # noqa: E402
from matplotlib.text import Text  # noqa: E402
from tensordict import TensorDictBase  # noqa: E402

from formation_rl.envs import formations  # noqa: E402
from formation_rl.envs.config import EnvConfig  # noqa: E402
from formation_rl.envs.rewards import Geometry, step_quantities  # noqa: E402

LEADER, LEFT, RIGHT = "#d62728", "#1f77b4", "#2ca02c"


def role_colors(n: int) -> list[str]:
    """Leader red, left followers (odd indices) blue, right followers (even) green."""
    return [LEADER] + [LEFT if i % 2 else RIGHT for i in range(1, n)]


def active_pairs(positions: torch.Tensor, cfg: EnvConfig) -> torch.Tensor:
    """Constrained pairs of the formation active in this state. ``[N, N]`` bool, upper triangle."""
    (x0, x1), (y0, y1) = cfg.obstacle_area_x, cfg.obstacle_area_y
    lx, ly = positions[0].tolist()
    inside = x0 < lx < x1 and y0 < ly < y1
    formation = cfg.area_formation if inside else cfg.formation
    return formations.pair_mask(formation, cfg.num_robots)


def draw_state(ax, state: TensorDictBase, cfg: EnvConfig, title: str | None = None) -> None:
    """Draw one copy's state (a TensorDict with the keys of ``("state", ...)``) on ``ax``."""
    a = cfg.arena_half_size
    pos = state["positions"].detach().cpu()
    n = pos.shape[0]
    ax.set_xlim(-a, a)
    ax.set_ylim(-a, a)
    ax.set_aspect("equal")
    ax.add_patch(plt.Rectangle((-a, -a), 2 * a, 2 * a, fill=False, lw=1.5, color="black"))
    (x0, x1), (y0, y1) = cfg.obstacle_area_x, cfg.obstacle_area_y
    ax.add_patch(plt.Rectangle((x0, y0), x1 - x0, y1 - y0, color="#f5deb3", alpha=0.5, lw=0))
    for c, r in zip(state["obstacle_centers"].cpu().tolist(), state["obstacle_radii"].cpu().tolist(), strict=True):
        ax.add_patch(plt.Circle(c, r, color="#555555"))
    g = state["goal"].cpu().tolist()
    ax.add_patch(plt.Circle(g, max(cfg.goal_radius, 0.08), color="gold", ec="black", lw=0.8, zorder=3))
    for i, j in torch.nonzero(active_pairs(pos, cfg)).tolist():
        ax.plot(*zip(pos[i].tolist(), pos[j].tolist(), strict=True), color="#888888", lw=1, zorder=4)
    colors = role_colors(n)
    for i in range(n):
        ax.add_patch(plt.Circle(pos[i].tolist(), cfg.robot_radius, color=colors[i], zorder=5))
    ax.set_xticks([])
    ax.set_yticks([])
    if title:
        ax.set_title(title, fontsize=9)


def _to_rgb(fig) -> np.ndarray:
    fig.canvas.draw()
    return np.asarray(fig.canvas.buffer_rgba())[..., :3].copy()


def render_state(state: TensorDictBase, cfg: EnvConfig, size: float = 4.0, dpi: int = 80,
                 title: str | None = None) -> np.ndarray:
    """RGB array ``[H, W, 3]`` (uint8) of one copy's state."""
    fig, ax = plt.subplots(figsize=(size, size), dpi=dpi)
    fig.subplots_adjust(0.02, 0.02, 0.98, 0.93 if title else 0.98)
    try:
        draw_state(ax, state, cfg, title)
        return _to_rgb(fig)
    finally:
        plt.close(fig)


def rollout_states(rollout: TensorDictBase, index: int = 0) -> list[TensorDictBase]:
    """The world states of copy ``index`` of a ``[B, T]`` rollout: the reset state, then each step."""
    td = rollout[index] if rollout.batch_dims == 2 else rollout
    return [td[0]["state"]] + [td[t]["next", "state"] for t in range(td.shape[0])]


def save_gif(rollout: TensorDictBase, path: str | Path, cfg: EnvConfig, index: int = 0, fps: int = 15,
             size: float = 4.0, dpi: int = 120) -> Path:
    """Write copy ``index`` of a rollout (``[B, T]`` or ``[T]``) to an animated GIF, ``size * dpi`` pixels
    square (480 by default)."""
    import imageio.v2 as imageio

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(figsize=(size, size), dpi=dpi)
    fig.subplots_adjust(0.02, 0.02, 0.98, 0.93)
    frames = []
    try:
        for t, state in enumerate(rollout_states(rollout, index)):
            ax.clear()
            draw_state(ax, state, cfg, title=f"step {t}")
            frames.append(_to_rgb(fig))
    finally:
        plt.close(fig)
    imageio.mimsave(path, frames, duration=1000 / fps, loop=0)
    return path


def collisions(positions: torch.Tensor, state: TensorDictBase, cfg: EnvConfig) -> np.ndarray:
    """Per-robot collision flags ``[T, N]`` of positions ``[T, N, 2]`` in one copy's world ``state``,
    by the environment's own rule (:func:`formation_rl.envs.rewards.step_quantities`)."""
    t = positions.shape[0]
    pos = positions.permute(2, 1, 0).float()  # batch-last [2, N, T]: the T states as a batch
    q = step_quantities(
        pos,
        torch.zeros_like(pos),  # velocities: they enter the reward only, not the collision flags read here
        state["goal"].float()[:, None].expand(2, t),
        state["obstacle_centers"].float().T[..., None].expand(-1, -1, t),
        state["obstacle_radii"].float()[:, None].expand(-1, t),
        Geometry.build(cfg, positions.device),
        cfg,
    )
    return (q["robot_hit"] | q["obstacle_hit"]).T.cpu().numpy()


def label_steps(ax, anchors: list[tuple[int, np.ndarray]], fontsize: float = 9) -> list:
    """``step t`` labels by the points ``anchors`` (``(t, xy)``, the leader at step t), each moved to the first
    of a ring of offsets where it overlaps no earlier label (a team that waits sends them all to one
    point), with a thin line back to its point. Returns the text artists."""
    ax.apply_aspect()  # the axes' final place, so that the points are where they will be drawn
    renderer = ax.figure.canvas.get_renderer()
    offsets = [(8, 8), (8, -20), (-62, 8), (-62, -20)] + [(8, 8 + 16 * k) for k in range(1, 40)]
    placed, texts = [], []
    for t, xy in anchors:
        for dx, dy in offsets:
            text = ax.annotate(f"step {t}", xy, xytext=(dx, dy), textcoords="offset points", fontsize=fontsize,
                               zorder=8, bbox={"boxstyle": "round,pad=0.2", "fc": "white", "ec": "none", "alpha": 0.8},
                               arrowprops={"arrowstyle": "-", "lw": 0.5, "color": "#555555"})
            text.update_positions(renderer)
            box = Text.get_window_extent(text, renderer).padded(2)  # the words, not the line to the point
            if not any(box.overlaps(other) for other in placed):
                break
            text.remove()
        placed.append(box)
        texts.append(text)
    return texts


def plot_trajectories(rollout: TensorDictBase, cfg: EnvConfig, path: str | Path, index: int = 0,
                      steps: tuple[int, ...] = (10, 35, 95, 120), title: str | None = None) -> Path:
    """Figure 10 of the paper: each robot's path, the team and its active formation at ``steps``,
    the obstacle area shaded, collisions marked with a black x. Writes a PNG."""
    states = rollout_states(rollout, index)
    pos = np.stack([s["positions"].cpu().numpy() for s in states])  # [T+1, N, 2]
    first = states[0]
    n = pos.shape[1]
    colors = role_colors(n)
    fig, ax = plt.subplots(figsize=(6, 6), dpi=100)
    try:
        draw_state(ax, first, cfg, title=title)
        for p in ax.patches[-n:]:  # the robots at the start: faint
            p.set_alpha(0.3)
        for i in range(n):
            ax.plot(pos[:, i, 0], pos[:, i, 1], color=colors[i], lw=1.0, alpha=0.8, zorder=4)
        shown = [t for t in steps if t < len(pos)]
        for t in shown:
            step_state = states[t]
            for i, j in torch.nonzero(active_pairs(step_state["positions"].cpu(), cfg)).tolist():
                ax.plot(*zip(pos[t, i], pos[t, j], strict=True), color="black", lw=0.8, zorder=6)
            for i in range(n):
                ax.add_patch(plt.Circle(pos[t, i], cfg.robot_radius, color=colors[i], zorder=7))
        label_steps(ax, [(t, pos[t, 0]) for t in shown])
        hits = collisions(torch.as_tensor(pos[1:]), first, cfg)  # [T, N], the states after each step
        tt, ii = np.nonzero(hits)
        if len(tt):
            ax.scatter(pos[tt + 1, ii, 0], pos[tt + 1, ii, 1], marker="x", color="black", s=18, zorder=9,
                       label="collision")
            ax.legend(loc="upper left", fontsize=8)
        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(path)
    finally:
        plt.close(fig)
    return path

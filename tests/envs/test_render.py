"""Rendering: an RGB frame of one copy, a rollout as a GIF."""

import imageio.v2 as imageio
import numpy as np

from formation_rl.envs import EnvConfig, FormationEnv
from formation_rl.envs.render import active_pairs, role_colors, save_gif


def test_render_frame_shows_the_world():
    env = FormationEnv(2, seed=0)
    env.reset()
    frame = env.render(1)
    assert frame.dtype == np.uint8 and frame.shape[2] == 3 and frame.shape[0] > 100
    assert (frame < 128).any() and (frame > 200).any()  # obstacles drawn dark on a light arena
    red = (frame[..., 0] > 180) & (frame[..., 1] < 80) & (frame[..., 2] < 80)
    assert red.any()  # the leader


def test_active_formation_lines_follow_the_switch():
    import torch

    cfg = EnvConfig()
    outside = torch.tensor([[-3.5, -3.5]] + [[-3.6, -3.6]] * 4)
    inside = torch.tensor([[0.0, 0.0]] + [[-0.4, 0.0]] * 4)
    assert active_pairs(outside, cfg).sum() == 10  # V: every pair
    assert active_pairs(inside, cfg).sum() == 4  # chain
    assert role_colors(5)[1] != role_colors(5)[2]  # left and right followers differ


def test_rollout_gif(tmp_path):
    env = FormationEnv(2, config=EnvConfig(max_steps=6), seed=0)
    r = env.rollout(6)
    path = save_gif(r, tmp_path / "a.gif", env.config, index=1)
    frames = imageio.mimread(path)
    assert len(frames) == 7  # the reset state and 6 steps
    assert min(frames[0].shape[:2]) >= 480  # 240 px was too small to read the step in the title


def test_figure_collision_marks_follow_the_environment_rule():
    import torch

    from formation_rl.envs.render import collisions, rollout_states

    env = FormationEnv(1, seed=3)
    r = env.rollout(150, break_when_any_done=False)
    states = rollout_states(r)
    hits = collisions(torch.stack([s["positions"] for s in states])[1:], states[0], env.config)  # [T, N]
    flags = (r["next", "robot_collision"] | r["next", "obstacle_collision"])[0, :, 0].numpy()
    assert hits.shape == (150, 5) and flags.sum() > 0
    assert (hits.any(1) == flags).all()


def test_step_labels_of_a_team_that_waits_do_not_overlap(tmp_path):
    """Figure 10's "step t" labels sat on top of each other when the leader stood still between snapshots."""
    import matplotlib.pyplot as plt
    import torch
    from matplotlib.text import Text

    from formation_rl.envs.render import label_steps, plot_trajectories

    fig, ax = plt.subplots(figsize=(6, 6), dpi=100)
    ax.set_xlim(-4, 4)
    ax.set_ylim(-4, 4)
    texts = label_steps(ax, [(t, np.array([1.0, 1.0])) for t in (10, 35, 95, 120)])
    renderer = fig.canvas.get_renderer()
    boxes = [Text.get_window_extent(t, renderer) for t in texts]
    assert [t.get_text() for t in texts] == ["step 10", "step 35", "step 95", "step 120"]
    assert not any(a.overlaps(b) for i, a in enumerate(boxes) for b in boxes[i + 1:])
    plt.close(fig)
    env = FormationEnv(1, config=EnvConfig(max_steps=20), seed=0)  # nobody moves: one point for every label
    still = env.rollout(20, lambda td: td.set(("agents", "action"), torch.zeros(1, 5, 2)))
    assert plot_trajectories(still, env.config, tmp_path / "f.png", steps=(5, 10, 15, 20)).stat().st_size > 0

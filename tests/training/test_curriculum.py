"""obstacle_curriculum: training obstacles grow to full size; evaluation's are full size throughout."""

import pytest
from test_train import tiny

from formation_rl.training.trainer import Trainer


def test_obstacle_curriculum_grows_training_obstacles_only(tmp_path):
    cfg = tiny(frames=1600)
    cfg.obstacle_curriculum, cfg.obstacle_curriculum_start = 3200, 0.25
    trainer = Trainer(cfg, tmp_path)
    full = (cfg.env.obstacle_radius_min, cfg.env.obstacle_radius_max)
    trainer.train()  # 1,600 of 3,200 frames: the radii at 0.25 + 0.75 / 2 of full size
    scale = 0.25 + 0.75 * trainer.frames / 3200
    assert trainer.env.config.obstacle_radius_min == pytest.approx(full[0] * scale)
    assert trainer.env.config.obstacle_radius_max == pytest.approx(full[1] * scale)
    assert (cfg.env.obstacle_radius_min, cfg.env.obstacle_radius_max) == full  # the run's world is untouched
    radii = trainer.env.reset()["state", "obstacle_radii"]
    assert radii.max() <= full[1] * scale + 1e-6 and radii.min() >= full[0] * scale - 1e-6
    eval_radii = trainer.eval_env.reset()["state", "obstacle_radii"]
    assert eval_radii.min() >= full[0] - 1e-6  # evaluation: full size
    cfg.obstacle_curriculum_start = 0.0
    with pytest.raises(ValueError, match=r"^obstacle_curriculum_start = 0.0 is invalid: must be in \(0, 1\]"):
        Trainer(cfg, tmp_path / "bad")

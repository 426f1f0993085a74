"""sensing_curriculum: training episodes sense farther at first; evaluation senses at the world's range throughout."""

import pytest
from helpers import tiny

from formation_rl.training.trainer import Trainer


def test_sensing_curriculum_shrinks_the_training_range_only(tmp_path):
    cfg = tiny(frames=1600)
    cfg.sensing_curriculum, cfg.sensing_curriculum_start = 3200, 0.5
    trainer = Trainer(cfg, tmp_path)
    trainer.train()  # 1,600 of 3,200 frames: halfway from 0.5 m to 0.2 m
    expected = 0.2 + 0.3 * (1 - trainer.frames / 3200)
    assert trainer.env.config.sensing_range == pytest.approx(expected)
    assert cfg.env.sensing_range == trainer.eval_env.config.sensing_range == 0.2  # the run's world is untouched
    cfg.sensing_curriculum_start = 0.1
    with pytest.raises(ValueError, match=r"^sensing_curriculum_start = 0.1 is invalid: must be >= env.sensing_range"):
        Trainer(cfg, tmp_path / "bad")

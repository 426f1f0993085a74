"""formation_rl.evaluation.evaluate: the evaluation protocol (reference.md) and its 95% confidence intervals."""

import math

import pytest
import torch

from formation_rl.envs import EnvConfig, FormationEnv
from formation_rl.envs.metrics import episode_metrics
from formation_rl.evaluation.evaluate import evaluate_policy, mean_ci


def scripted(td):
    """A hand-made controller: every robot pushes towards the goal's quadrant, +x +y."""
    td.set(("agents", "action"), torch.full(td["agents", "observation"].shape[:-1] + (2,), 0.5))
    return td


def test_mean_ci_on_known_numbers():
    mean, ci = mean_ci(torch.tensor([1.0, 2.0, 3.0, 4.0, 5.0]))
    assert mean == 3.0 and ci == pytest.approx(2.776 * math.sqrt(2.5) / math.sqrt(5), abs=1e-9)
    mean, ci = mean_ci(torch.ones(100) * 2)
    assert (mean, ci) == (2.0, 0.0)
    assert math.isnan(mean_ci(torch.tensor([1.0]))[1])


def test_evaluation_equals_the_metrics_module_on_the_same_rollouts():
    cfg = EnvConfig(max_steps=30)
    per_episode = evaluate_policy(scripted, cfg, episodes=8, num_envs=4, seed=11, progress=False)
    env = FormationEnv(4, config=cfg, seed=11)
    rollouts = [env.rollout(30, scripted, break_when_any_done=False) for _ in range(2)]
    expected = [episode_metrics(r, cfg.goal_radius) for r in rollouts]
    for k, v in per_episode.items():
        torch.testing.assert_close(v, torch.cat([e[k] for e in expected]))
    assert per_episode["CBRO"].shape == (8,)

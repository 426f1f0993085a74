"""formation_rl.evaluation.diagnose: first and last collision steps, failure metrics (the app: tests/apps)."""

import torch
from tensordict.nn import TensorDictModule

from formation_rl.envs import EnvConfig
from formation_rl.evaluation.diagnose import failure_metrics, first_step, last_step
from formation_rl.evaluation.evaluate import evaluate_policy
from formation_rl.evaluation.policy import load_policy


def test_first_and_last_collision_steps():
    flags = torch.tensor([[False, True, False, True, False], [False] * 5, [True, False, False, False, False]])
    assert first_step(flags).tolist() == [2, 0, 1]
    assert last_step(flags).tolist() == [4, 0, 1]


def test_diagnose_finds_a_leader_pinned_at_a_wall():
    """A policy that pushes every robot east ends with the leader at the arena's edge, actions saturated."""
    class East(torch.nn.Module):
        def forward(self, obs):
            return torch.zeros(*obs.shape[:-1], 2).index_fill_(-1, torch.tensor([0]), 1.0)

    east = TensorDictModule(East(), in_keys=[("agents", "observation")], out_keys=[("agents", "action")])
    per = evaluate_policy(east, EnvConfig(), 8, progress=False, metrics=failure_metrics)
    assert per["leader_at_wall"].tolist() == [1.0] * 8 and per["saturated_actions"].tolist() == [0.5] * 8
    apf = evaluate_policy(load_policy("apf").module, EnvConfig(), 8, progress=False, metrics=failure_metrics)
    assert apf["leader_at_wall"].sum() == 0

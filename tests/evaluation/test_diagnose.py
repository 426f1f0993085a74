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
    # pushed east side by side, the team keeps its start offsets (< 1.5 m), and the leader, starting west
    # of the obstacle area's x range at y < -2, never enters it
    assert (per["follower_distance_end"] < 1.5).all() and (per["leader_in_area_steps"] == 0).all()
    apf = evaluate_policy(load_policy("apf").module, EnvConfig(), 8, progress=False, metrics=failure_metrics)
    assert apf["leader_at_wall"].sum() == 0


def test_follower_distance_and_area_steps():
    """The followers' final distance to the leader is measured from the last positions; area steps are a share."""
    from tensordict import TensorDict

    pos = torch.zeros(2, 3, 3, 2)  # [B, T, N, 2]
    pos[0, -1, 1] = torch.tensor([3.0, 4.0])  # episode 0: follower 1 ends 5 m from the leader, follower 2 on it
    area = torch.zeros(2, 3, 1, dtype=torch.bool)
    area[1, 1:] = True  # episode 1: the leader inside for 2 of 3 steps
    flags = torch.zeros(2, 3, 1, dtype=torch.bool)
    nxt = TensorDict({("state", "positions"): pos, "in_obstacle_area": area, "robot_collision": flags,
                      "obstacle_collision": flags, "goal_distance": torch.ones(2, 3, 1),
                      "formation_error": torch.zeros(2, 3, 1), "done": flags.clone(),
                      ("agents", "reward"): torch.zeros(2, 3, 3, 1)}, [2, 3])
    rollout = TensorDict({"next": nxt, ("agents", "action"): torch.zeros(2, 3, 3, 2)}, [2, 3])
    m = failure_metrics(rollout, 0.05)
    assert m["follower_distance_end"].tolist() == [2.5, 0.0]
    assert m["leader_in_area_steps"].tolist() == [0.0, 2 / 3]
    assert m["leader_enters_area"].tolist() == [0.0, 1.0]
    assert m["in_area_per_step"].tolist() == [[0.0, 0.0, 0.0], [0.0, 1.0, 1.0]]

"""formation_rl.algorithms.base: what every algorithm shares: the state it resumes from, no step on a non-finite
loss (the losses and the update itself: test_matd3.py, test_per.py)."""

import copy

import pytest
import torch

from formation_rl.algorithms import NonFiniteError, make_algorithm
from formation_rl.algorithms.config import AlgoConfig
from formation_rl.models import make_actor, make_critic

from .conftest import D, N, make_batch


def matd3(seed: int):
    torch.manual_seed(seed)
    return make_algorithm(make_actor(N, D, (16, 16)), make_critic(N, D, (16, 16)), AlgoConfig(name="matd3"))


def test_state_dict_carries_networks_targets_optimisers_and_step_counts():
    first = matd3(0)
    for _ in range(3):
        first.update(make_batch(16))
    state = copy.deepcopy(first.state_dict())  # a state_dict holds references, as torch's do: Adam's moments move on
    state["actor_optim"]["param_groups"][0]["capturable"] = True  # as saved under CUDA graphs
    second = matd3(1)
    second.load_state_dict(state)
    assert (second.critic_steps, second.actor_steps) == (3, 1)
    assert not second.actor_optim.param_groups[0]["capturable"]  # resumed without graphs, on the CPU
    for a, b in zip(first.loss.state_dict().values(), second.loss.state_dict().values(), strict=True):
        assert torch.equal(a, b)
    batch = make_batch(16)
    torch.manual_seed(5)  # the target-policy noise
    out_first = first.update(batch.clone())  # the 4th step: actors and targets move too (policy_delay 2)
    torch.manual_seed(5)
    out_second = second.update(batch.clone())
    assert "loss_actor" in out_first and all(torch.equal(out_first[k], out_second[k]) for k in out_first)
    for a, b in zip(first.loss.parameters(), second.loss.parameters(), strict=True):
        assert torch.equal(a, b)


def test_a_non_finite_loss_raises_before_any_optimiser_step():
    algo = matd3(0)
    before = [p.detach().clone() for p in algo.loss.parameters()]
    batch = make_batch(16)
    batch["next", "agents", "reward"][3] = float("nan")
    with pytest.raises(NonFiniteError, match=r"^the critic loss went non-finite \(nan\)$"):
        algo.update(batch)
    assert all(torch.equal(a, b) for a, b in zip(before, algo.loss.parameters(), strict=True))
    assert algo.critic_steps == 0 and not algo.critic_optim.state  # Adam never stepped

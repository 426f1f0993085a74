"""MATD3 / MADDPG on TorchRL's losses: eq. 7 and 8, the actor delay, soft targets, weighting."""

import pytest
import torch

from formation_rl.algorithms import MADDPG, MATD3
from formation_rl.algorithms.config import AlgoConfig
from formation_rl.models import make_actor, make_critic

from .conftest import D, N, make_batch


def matd3(**kw) -> MATD3:
    cfg = AlgoConfig(name="matd3", **kw)
    return MATD3(make_actor(N, D, (16, 16)), make_critic(N, D, (16, 16)), cfg)


def q_values(algo, params, td):
    """Each of the twin critics ``params[c]`` on ``td``: ``[C, B, N]``."""
    out = []
    for c in range(params.shape[0]):
        with params[c].to_module(algo.loss.qvalue_network):
            out.append(algo.loss.qvalue_network(td.clone())["agents", "state_action_value"][..., 0])
    return torch.stack(out)


def test_twin_target_is_min_of_target_critics():
    algo = matd3(policy_noise=0.0, noise_clip=0.0, gamma=0.9)
    term = torch.tensor([False, True, False, False, True, False, False, False]).view(8, 1, 1)
    batch = make_batch(8, terminated=term)
    _, meta = algo.loss.value_loss(batch.clone())
    nxt = batch["next"].clone()
    with algo.loss.target_actor_network_params.to_module(algo.loss.actor_network):
        algo.loss.actor_network(nxt)  # mu'(s'), no smoothing noise here
    q_next = q_values(algo, algo.loss.target_qvalue_network_params, nxt)  # [2, B, N]
    assert (q_next[0] - q_next[1]).abs().max() > 1e-4  # the twins differ
    r = batch["next", "agents", "reward"][..., 0]
    not_term = (~batch["next", "agents", "terminated"][..., 0]).float()
    expected = r + 0.9 * not_term * q_next.min(0).values  # eq. 7
    torch.testing.assert_close(meta["target_value"], expected, atol=1e-5, rtol=1e-5)


def test_target_policy_noise_is_clipped():
    algo = matd3(policy_noise=10.0, noise_clip=0.5)
    seen = []
    original = algo.loss._vmap_qvalue_network00

    def spy(td, params):
        seen.append(td.get(("agents", "action")).clone())
        return original(td, params)

    algo.loss._vmap_qvalue_network00 = spy
    batch = make_batch(64)
    algo.loss.value_loss(batch.clone())
    noisy = seen[0][0]  # first call: target critics on (s', mu'(s') + clip(noise)), [B, N, 2]
    nxt = batch["next"].clone()
    with algo.loss.target_actor_network_params.to_module(algo.loss.actor_network):
        clean = algo.loss.actor_network(nxt)["agents", "action"]
    offset = (noisy - clean).abs()
    assert offset.max() <= 0.5 + 1e-5  # eq. 8: clip(N(0, 10), -0.5, 0.5)
    assert noisy.abs().max() <= 1.0 + 1e-6  # and the action stays in bounds
    inside = clean.abs() < 0.5  # where the bound cannot interfere, N(0, 10) noise mostly sits on the clip
    on_clip = ((offset[inside] - 0.5).abs() < 1e-5).float().mean()
    assert on_clip > 0.85  # P(|N(0, 10)| > 0.5) = 0.96


def _actor_and_targets(algo):
    return [t.detach().clone() for t in algo.actor_params], algo.loss.target_actor_network_params.clone()


def test_actor_and_targets_only_move_on_delayed_steps():
    algo = matd3(policy_delay=2)
    actor0, target0 = _actor_and_targets(algo)
    critic0 = [p.detach().clone() for p in algo.critic_params]
    out = algo.update(make_batch())
    assert "loss_actor" not in out
    assert all(torch.equal(a, b) for a, b in zip(actor0, algo.actor_params, strict=True))
    assert (target0 == algo.loss.target_actor_network_params).all()
    assert any(not torch.equal(a, b) for a, b in zip(critic0, algo.critic_params, strict=True))
    out = algo.update(make_batch())
    assert "loss_actor" in out and algo.actor_steps == 1 and algo.critic_steps == 2
    assert any(not torch.equal(a, b) for a, b in zip(actor0, algo.actor_params, strict=True))


def test_critic_warmup_holds_the_actors_while_the_targets_follow_the_critics():
    algo = matd3(policy_delay=1, critic_warmup_steps=3, tau=0.5)
    actor0, _ = _actor_and_targets(algo)
    critic_target0 = algo.loss.target_qvalue_network_params.clone()
    for _ in range(3):
        assert "loss_actor" not in algo.update(make_batch())
    assert all(torch.equal(a, b) for a, b in zip(actor0, algo.actor_params, strict=True))
    assert algo.actor_steps == 0 and algo.critic_steps == 3
    assert (critic_target0 != algo.loss.target_qvalue_network_params).any()  # soft updates went on
    assert "loss_actor" in algo.update(make_batch())  # the fourth step moves the actors
    assert any(not torch.equal(a, b) for a, b in zip(actor0, algo.actor_params, strict=True))


class _Constant(torch.nn.Module):
    def forward(self, obs):
        return torch.full((*obs.shape[:-1], 2), 0.5)


def test_bc_weight_pulls_the_actors_to_the_anchor_and_zero_leaves_the_paper_loss():
    batch = make_batch(64)
    plain = matd3(bc_weight=0.0)
    plain.anchor = _Constant()  # ignored at bc_weight 0
    torch.manual_seed(0)
    loss0 = plain._actor_loss(batch.clone())[0]
    plain.anchor = None
    torch.manual_seed(0)
    torch.testing.assert_close(plain._actor_loss(batch.clone())[0], loss0)

    algo = matd3(bc_weight=100.0, policy_delay=1, lr_actor=1e-2)
    algo.anchor = _Constant()

    def gap():
        with torch.no_grad():
            return (algo.loss.actor_network(batch.clone())["agents", "action"] - 0.5).abs().mean().item()

    before = gap()
    for _ in range(60):
        algo.update(batch.clone())
    assert gap() < 0.2 * before


def test_soft_update_moves_targets_by_exactly_tau():
    algo = matd3(policy_delay=1, tau=0.01)
    target_before = algo.loss.target_qvalue_network_params.clone()
    algo.update(make_batch())
    online = algo.loss.qvalue_network_params.detach()
    expected = target_before * 0.99 + online * 0.01
    for key, value in expected.items(True, True):
        torch.testing.assert_close(algo.loss.target_qvalue_network_params[key], value, atol=1e-7, rtol=0)
    actor_target = algo.loss.target_actor_network_params
    assert (actor_target != algo.loss.actor_network_params.detach()).any()  # a target, not a copy


def test_importance_weights_enter_the_critic_loss_as_eq_21():
    algo = matd3(policy_noise=0.0, noise_clip=0.0)  # a deterministic target, so two calls agree
    batch = make_batch(8)
    w = torch.linspace(0.1, 1.0, 8)
    batch.set("priority_weight", w)
    per_sample, meta = algo.loss.value_loss(batch.exclude("priority_weight").clone())
    expected = (((meta["pred_value"] - meta["target_value"]) ** 2).sum(0) * w[:, None]).mean()
    out = algo.update(batch)
    torch.testing.assert_close(out["loss_critic"], expected, atol=1e-6, rtol=1e-5)
    # |delta| written for the buffer: max over the twin critics, per robot
    delta = (meta["pred_value"] - meta["target_value"]).abs().amax(0)
    torch.testing.assert_close(batch["td_error"], delta, atol=1e-6, rtol=1e-5)


@pytest.mark.parametrize("cls,name", [(MADDPG, "maddpg"), (MATD3, "matd3")])
def test_every_robot_learns_and_loss_is_finite(cls, name):
    cfg = AlgoConfig(name=name, num_critics=1 if name == "maddpg" else 2, policy_delay=1)
    algo = cls(make_actor(N, D, (16, 16)), make_critic(N, D, (16, 16)), cfg)
    before = [p.detach().clone() for p in algo.actor_params]
    out = algo.update(make_batch())
    assert all(torch.isfinite(v).all() for v in out.values())
    for a, b in zip(before, algo.actor_params, strict=True):
        changed = (a != b.detach()).flatten(1).any(1)  # per robot (leading dim N)
        assert changed.all()


def test_maddpg_single_critic_updates_targets_every_step():
    algo = MADDPG(make_actor(N, D, (16, 16)), make_critic(N, D, (16, 16)),
                  AlgoConfig(name="maddpg", num_critics=1, policy_delay=1, tau=0.5))
    t0 = algo.loss.target_value_network_params.clone()
    out = algo.update(make_batch())
    assert "loss_actor" in out
    online = algo.loss.value_network_params.detach()
    for key, value in (t0 * 0.5 + online * 0.5).items(True, True):
        torch.testing.assert_close(algo.loss.target_value_network_params[key], value, atol=1e-6, rtol=0)


def test_n_step_target_discounts_by_the_steps_taken():
    algo = matd3(policy_noise=0.0, noise_clip=0.0, gamma=0.9)
    batch = make_batch(8)
    steps = torch.tensor([1, 2, 3, 3, 1, 2, 3, 1]).view(8, 1, 1).expand(8, N, 1)
    batch.set("steps_to_next_obs", steps)  # as to_transitions keeps it after TorchRL's MultiStep
    _, meta = algo.loss.value_loss(batch.clone())
    nxt = batch["next"].clone()
    with algo.loss.target_actor_network_params.to_module(algo.loss.actor_network):
        algo.loss.actor_network(nxt)
    q_next = q_values(algo, algo.loss.target_qvalue_network_params, nxt).min(0).values
    expected = batch["next", "agents", "reward"][..., 0] + 0.9 ** steps[..., 0].float() * q_next
    torch.testing.assert_close(meta["target_value"], expected, atol=1e-5, rtol=1e-5)


def test_torchrl_actor_loss_reaches_the_actors_through_our_critic():
    # TorchRL's TD3Loss.actor_loss runs the twin critics under vmap; the critic must still pass
    # gradient to a_i there (a user's own loss may take that path)
    algo = matd3()
    loss, _ = algo.loss.actor_loss(make_batch(8))
    loss.mean().backward()
    grads = [p.grad for p in algo.loss.actor_network_params.values(True, True)]
    assert all(g is not None and g.abs().sum() > 0 for g in grads)


def test_own_only_leader_critic_stays_own_only_through_updates():
    """The input mask survives TorchRL's twin-critic expansion and the optimiser: after updates the
    leader's twin critics still ignore the followers' observations and actions."""
    cfg = AlgoConfig(name="matd3", policy_delay=1)
    algo = MATD3(make_actor(N, D, (16, 16)), make_critic(N, D, (16, 16), own_only=(0,)), cfg)
    for _ in range(3):
        algo.update(make_batch())
    td = make_batch()
    q0 = q_values(algo, algo.loss.qvalue_network_params, td)  # [C, B, N]
    other = td.clone()
    other["agents", "observation"][:, 1:] += 1.0
    other["agents", "action"][:, 1:] *= -1
    q1 = q_values(algo, algo.loss.qvalue_network_params, other)
    torch.testing.assert_close(q1[..., 0], q0[..., 0])  # leader: unchanged
    assert ((q1[..., 1:] - q0[..., 1:]).abs() > 1e-6).any()

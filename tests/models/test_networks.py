"""Actors are decentralized, critics centralized, and no parameters are shared between robots."""

import pytest
import torch
from tensordict import TensorDict
from torch import nn
from torch.func import functional_call, stack_module_state, vmap

from formation_rl.models import PerRobotMLP, make_actor, make_critic
from formation_rl.models.networks import _ReluLayers

N, D = 4, 10


def td(obs, act=None):
    data = {("agents", "observation"): obs}
    if act is not None:
        data[("agents", "action")] = act
    return TensorDict(data, [obs.shape[0]])


def test_per_robot_mlp_is_n_independent_mlps():
    mlp = PerRobotMLP(N, D, 3, (8, 6))
    x = torch.randn(5, N, D)
    y = mlp(x)
    for i in range(N):
        ref = nn.Sequential(nn.Linear(D, 8), nn.ReLU(), nn.Linear(8, 6), nn.ReLU(), nn.Linear(6, 3))
        for layer, w, b in zip(ref[::2], mlp.weights, mlp.biases, strict=True):
            layer.weight.data.copy_(w[i].T)
            layer.bias.data.copy_(b[i, 0])
        torch.testing.assert_close(y[:, i], ref(x[:, i]), atol=1e-5, rtol=1e-5)
    assert not torch.equal(mlp.weights[0][0], mlp.weights[0][1])  # robots start different, share nothing


def test_actor_sees_only_its_own_observation():
    actor = make_actor(N, D, (16, 16))
    obs = torch.randn(3, N, D)
    a0 = actor(td(obs.clone()))["agents", "action"]
    obs[:, 2] += 1.0  # change robot 2's observation only
    a1 = actor(td(obs))["agents", "action"]
    changed = (a0 - a1).abs().amax((0, 2)) > 1e-6
    assert changed.tolist() == [False, False, True, False]
    assert a1.abs().max() <= 1.0


def test_each_critic_sees_every_observation_and_action():
    critic = make_critic(N, D, (16, 16))
    obs, act = torch.randn(3, N, D), torch.rand(3, N, 2) * 2 - 1
    q0 = critic(td(obs.clone(), act.clone()))["agents", "state_action_value"]
    for j in range(N):
        o, a = obs.clone(), act.clone()
        o[:, j] += 0.5
        assert ((critic(td(o, act.clone()))["agents", "state_action_value"] - q0).abs().amax((0, 2)) > 1e-6).all()
        a[:, j] = -a[:, j]
        assert ((critic(td(obs.clone(), a))["agents", "state_action_value"] - q0).abs().amax((0, 2)) > 1e-6).all()


def test_robot_i_critic_passes_gradient_only_to_its_own_action():
    critic = make_critic(N, D, (16, 16))
    obs = torch.randn(3, N, D)
    act = (torch.rand(3, N, 2) * 2 - 1).requires_grad_()
    q = critic(td(obs, act))["agents", "state_action_value"]  # [3, N, 1]
    for i in range(N):
        (grad,) = torch.autograd.grad(q[:, i].sum(), act, retain_graph=True)
        per_robot = grad.abs().sum((0, 2))
        assert per_robot[i] > 0 and (per_robot[torch.arange(N) != i] == 0).all()


def test_critic_equals_per_robot_mlp_on_the_joint_input():
    critic = make_critic(N, D, (16, 16))
    module = critic.module
    obs, act = torch.randn(5, N, D), torch.rand(5, N, 2) * 2 - 1
    joint = torch.cat([obs.flatten(-2), act.flatten(-2)], -1)  # [B, N*D + 2N]
    expected = module.mlp(joint.unsqueeze(-2).expand(5, N, -1))  # robot i's MLP on the joint input
    torch.testing.assert_close(critic(td(obs, act))["agents", "state_action_value"], expected, atol=1e-5, rtol=1e-5)


@pytest.mark.parametrize("layer_norm", [(), (0,), (1, 3), (0, 1, 3), tuple(range(N))])
def test_critic_layer_norm_normalises_each_hidden_pre_activation(layer_norm):
    """model.critic_layer_norm: scaling a hidden layer's weights and bias by c > 0 leaves the normalised robots'
    critics unchanged (the normalised pre-activation is scale-free) and scales the others' values; the joint first
    layer equals the per-robot MLP on the joint input either way."""
    critic = make_critic(N, D, (16, 16), layer_norm=layer_norm)
    obs, act = torch.randn(5, N, D), torch.rand(5, N, 2) * 2 - 1
    q0 = critic(td(obs, act))["agents", "state_action_value"]
    joint = torch.cat([obs.flatten(-2), act.flatten(-2)], -1)
    torch.testing.assert_close(critic.module.mlp(joint.unsqueeze(-2).expand(5, N, -1)), q0, atol=1e-5, rtol=1e-5)
    with torch.no_grad():
        for k in (0, 1):
            critic.module.mlp.weights[k].mul_(3.0)
            critic.module.mlp.biases[k].mul_(3.0)
    q1 = critic(td(obs, act))["agents", "state_action_value"]
    for i in range(N):
        assert torch.allclose(q1[:, i], q0[:, i], atol=1e-4) == (i in layer_norm)


def test_bf16_runs_hidden_layers_in_bf16_only_with_gradients():
    """precision=bf16: passes without gradients (TD targets, collection) equal fp32 to float rounding (the
    hand-written layers sum the output layer in another order); with gradients the hidden layers run in bf16,
    the outputs stay fp32 and close, and gradients reach fp32 weights."""
    from formation_rl.models import set_precision

    actor, critic = make_actor(N, D, (16, 16)), make_critic(N, D, (16, 16))
    obs, act = torch.randn(64, N, D), torch.rand(64, N, 2) * 2 - 1
    with torch.no_grad():
        a32, q32 = actor(td(obs))["agents", "action"], critic(td(obs, act))["agents", "state_action_value"]
    set_precision(actor, "bf16")
    set_precision(critic, "bf16")
    with torch.no_grad():
        torch.testing.assert_close(actor(td(obs))["agents", "action"], a32, atol=1e-6, rtol=1e-5)
        torch.testing.assert_close(critic(td(obs, act))["agents", "state_action_value"], q32, atol=1e-6, rtol=1e-5)
    q = critic(td(obs, act.requires_grad_()))["agents", "state_action_value"]
    assert q.dtype == torch.float32
    assert not torch.allclose(q.detach(), q32, atol=1e-6, rtol=1e-5)  # bf16 inside: off by more than rounding
    torch.testing.assert_close(q.detach(), q32, atol=0.05, rtol=0.05)
    q.sum().backward()
    weights = list(critic.parameters())
    assert all(w.dtype == torch.float32 and w.grad is not None and w.grad.dtype == torch.float32 for w in weights)
    set_precision(critic, "fp32")
    with torch.enable_grad():
        assert torch.equal(critic(td(obs, act))["agents", "state_action_value"].detach(), q32)


@pytest.mark.parametrize("activation", ["relu", "tanh"])  # the hand-written layers, and autograd + autocast
def test_bf16_targets_lowers_the_updates_target_passes_only(activation):
    """precision=bf16_targets: inside ``target_passes()`` (the update's TD targets) passes without gradients
    run their hidden layers in bf16, close to fp32 with fp32 outputs; outside it (collection, evaluation)
    they stay fp32 (equal to float rounding)."""
    from formation_rl.models import set_precision
    from formation_rl.models.networks import target_passes

    actor, critic = make_actor(N, D, (16, 16), activation), make_critic(N, D, (16, 16), activation)
    obs, act = torch.randn(64, N, D), torch.rand(64, N, 2) * 2 - 1

    def outputs():
        with torch.no_grad():
            return actor(td(obs))["agents", "action"], critic(td(obs, act))["agents", "state_action_value"]

    fp32 = outputs()

    def same(outs):
        return all(torch.allclose(a, b, atol=1e-6, rtol=1e-5) for a, b in zip(outs, fp32, strict=True))

    for precision in ("bf16", "bf16_targets"):
        set_precision(actor, precision)
        set_precision(critic, precision)
        assert same(outputs())
        with target_passes():
            low = outputs()
        assert same(low) == (precision == "bf16")
        for a, b in zip(low, fp32, strict=True):
            assert a.dtype == torch.float32
            torch.testing.assert_close(a, b, atol=0.05, rtol=0.05)


class _AutogradReLU(nn.ReLU):
    """Not ``nn.ReLU`` itself: the networks take the autograd (+ autocast) path, the reference."""


def _grads(out, inputs):
    return torch.autograd.grad(out.square().sum(), inputs)


def test_hand_written_relu_layers_pass_gradcheck():
    """_ReluLayers' backward against finite differences (float64): actor mode, and critic mode into the observations."""
    torch.manual_seed(0)
    n, d, b = 3, 4, 5
    sizes = ((d, 6), (6, 6), (6, 2))
    ws = [torch.randn(n, i, o, dtype=torch.float64, requires_grad=True) for i, o in sizes]
    bs = [torch.randn(n, 1, o, dtype=torch.float64, requires_grad=True) for _, o in sizes]
    x = torch.randn(n, b, d, dtype=torch.float64, requires_grad=True)
    assert torch.autograd.gradcheck(lambda x, *p: _ReluLayers.apply(x, None, n, None, *p)[0], (x, *ws, *bs))
    ws[0] = torch.randn(n, n * (d + 2), 6, dtype=torch.float64, requires_grad=True)
    obs, act = torch.randn(b, n, d, dtype=torch.float64, requires_grad=True), torch.randn(b, n, 2, dtype=torch.float64)
    assert torch.autograd.gradcheck(lambda o, *p: _ReluLayers.apply(o, act, n, None, *p)[0], (obs, *ws, *bs))


def test_hand_written_layers_equal_the_autograd_path():
    """Values and gradients (weights, observations, each critic's own action) as autograd computes them."""
    torch.manual_seed(0)
    critic, actor = make_critic(N, D, (16, 16)).module, make_actor(N, D, (16, 16)).module[0]
    critic.mlp.hand_written = actor.hand_written = True  # in fp32 too (by default only under bf16)
    obs, act = torch.randn(8, N, D, requires_grad=True), (torch.rand(8, N, 2) * 2 - 1).requires_grad_()
    fast = critic(obs, act), actor(obs)
    fast_grads = _grads(fast[0], [obs, act, *critic.parameters()]) + _grads(fast[1], list(actor.parameters()))
    critic.mlp.activation = actor.activation = _AutogradReLU()
    ref = critic(obs, act), actor(obs)
    ref_grads = _grads(ref[0], [obs, act, *critic.parameters()]) + _grads(ref[1], list(actor.parameters()))
    for a, b in zip((*fast, *fast_grads), (*ref, *ref_grads), strict=True):
        torch.testing.assert_close(a, b, atol=1e-5, rtol=1e-5)


@pytest.mark.parametrize("inputs", ["shared", "expanded", "per_twin"])
def test_twin_critics_under_vmap_equal_each_critic_alone(inputs):
    """TorchRL's vmap over stacked twin critics: the vmap rule folds them into one call; the same values
    and gradients as each critic called alone, whether the inputs are shared, expanded, or per twin."""
    torch.manual_seed(0)
    critics = [make_critic(N, D, (16, 16)).module for _ in range(2)]
    for c in critics:
        c.mlp.hand_written = True
    params, _ = stack_module_state(critics)
    obs, act = torch.randn(8, N, D), (torch.rand(8, N, 2) * 2 - 1).requires_grad_()
    obs2 = {"shared": obs, "expanded": obs.expand(2, *obs.shape), "per_twin": torch.stack([obs, obs + 1])}[inputs]
    dims = (0, None, None) if inputs == "shared" else (0, 0, 0)
    act2 = act if inputs == "shared" else act.expand(2, *act.shape)
    q = vmap(lambda p, o, a: functional_call(critics[0], p, (o, a)), dims)(params, obs2, act2)
    each = torch.stack([c(o, act) for c, o in zip(critics, obs2 if obs2.dim() == 4 else (obs, obs), strict=True)])
    torch.testing.assert_close(q, each)
    grads = _grads(q, [act, *params.values()])
    flat = _grads(each, [act, *critics[0].parameters(), *critics[1].parameters()])
    k = len(params)
    expected = [flat[0], *(torch.stack([flat[1 + i], flat[1 + k + i]]) for i in range(k))]
    for g, e in zip(grads, expected, strict=True):
        torch.testing.assert_close(g, e)


def test_bf16_gradients_are_close_to_fp32():
    from formation_rl.models import set_precision

    torch.manual_seed(0)
    critic = make_critic(N, D, (32, 32))
    obs, act = torch.randn(256, N, D), (torch.rand(256, N, 2) * 2 - 1).requires_grad_()
    g32 = _grads(critic.module(obs, act), [act, *critic.parameters()])
    set_precision(critic, "bf16")
    g16 = _grads(critic.module(obs, act), [act, *critic.parameters()])
    for a, b in zip(g16, g32, strict=True):
        assert a.dtype == torch.float32
        assert (a - b).norm() <= 0.05 * b.norm()


def test_bf16_is_refused_where_the_cpu_lacks_it(monkeypatch):
    import pytest

    from formation_rl.training.config import TrainConfig, validate

    monkeypatch.setattr("formation_rl.models.bf16_supported", lambda device: False)
    with pytest.raises(ValueError, match=r"^precision = 'bf16' is invalid: must be fp32 on this cpu"):
        validate(TrainConfig(precision="bf16"))
    with pytest.raises(ValueError, match=r"^precision = 'bf16_targets' is invalid: must be fp32 on this cpu"):
        validate(TrainConfig(precision="bf16_targets"))
    with pytest.raises(ValueError, match=r"^precision = 'fp16' is invalid: must be fp32 or bf16 or bf16_targets or"):
        validate(TrainConfig(precision="fp16"))
    validate(TrainConfig(precision="auto"))  # auto falls back to fp32 there, no error


@pytest.mark.parametrize("native", [False, True])  # bf16 GEMMs 2.3x fp32's speed (an AMD EPYC) or 0.5x (an Intel Xeon)
def test_auto_precision_is_bf16_targets_where_bf16_runs_faster_else_fp32(monkeypatch, tmp_path, native):
    """precision=auto resolves once, in the trainer, and the run's config (saved in its checkpoints) records which."""
    from helpers import tiny

    from formation_rl.training.trainer import Trainer

    monkeypatch.setattr("formation_rl.models.bf16_speedup", lambda device: 2.3 if native else 0.5)
    trainer = Trainer(tiny("per_matd3", frames=400, precision="auto"), tmp_path)
    assert trainer.cfg.precision == ("bf16_targets" if native else "fp32")
    for m in trainer.actor.modules():
        if hasattr(m, "compute_dtype"):
            assert m.compute_dtype == (torch.bfloat16 if native else None)


def test_bf16_speedup_is_zero_without_native_bf16_and_a_positive_ratio_with_it(monkeypatch):
    """bf16_speedup measures where bf16 is native and skips the timing (0.0) where it is not; on a CPU it times one
    thread and gives the caller's thread count back."""
    from formation_rl.models import networks

    seen = []
    monkeypatch.setattr(networks, "_gemm_speedup", lambda dev: seen.append(torch.get_num_threads()) or 2.0)
    threads = torch.get_num_threads()
    torch.set_num_threads(2)
    try:
        networks.bf16_speedup.cache_clear()
        monkeypatch.setattr(networks, "bf16_supported", lambda device: True)
        assert networks.bf16_speedup("cpu") == 2.0 and seen == [1] and torch.get_num_threads() == 2
    finally:
        torch.set_num_threads(threads)
    monkeypatch.undo()

    networks.bf16_speedup.cache_clear()
    monkeypatch.setattr(networks, "bf16_supported", lambda device: False)
    assert networks.bf16_speedup("cpu") == 0.0
    networks.bf16_speedup.cache_clear()
    monkeypatch.setattr(networks, "bf16_supported", lambda device: True)
    assert 0 < networks.bf16_speedup("cpu") < float("inf")
    networks.bf16_speedup.cache_clear()


@pytest.mark.parametrize("hand_written", [False, True])
def test_own_only_critic_reads_its_own_observation_and_action(hand_written):
    """make_critic(own_only=(0,)): the leader's critic ignores every other robot; the others still see all."""
    critic = make_critic(N, D, (16, 16), own_only=(0,))
    critic.module.mlp.hand_written = hand_written
    obs, act = torch.randn(3, N, D), torch.rand(3, N, 2) * 2 - 1
    q0 = critic(td(obs.clone(), act.clone()))["agents", "state_action_value"]
    for j in range(N):
        o, a = obs.clone(), act.clone()
        o[:, j] += 0.5
        a[:, j] = -a[:, j]
        moved = (critic(td(o, a))["agents", "state_action_value"] - q0).abs().amax((0, 2)) > 1e-6  # per critic
        assert moved[0].item() == (j == 0)  # the leader's critic moves only with its own inputs
        assert moved[1:].all()
    obs.requires_grad_()
    q = critic(td(obs, act))["agents", "state_action_value"]
    (grad,) = torch.autograd.grad(q[:, 0].sum(), obs)
    assert (grad[:, 1:] == 0).all() and grad[:, 0].abs().sum() > 0

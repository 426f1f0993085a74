"""Per-robot networks with no parameter sharing, evaluated for all robots in one batched matmul.

Hand-written instead of ``MultiAgentMLP(centralized=True)`` for one reason of correctness and one of
speed: in MADDPG/MATD3 the actor of robot i climbs its *own* critic Q_i through its own action a_i
only (paper §3, Fig. 4), which a critic fed one shared input cannot express; and one
``baddbmm`` per layer serves every robot (and, under the losses' vmap, both twin critics).
"""

from __future__ import annotations

import functools
import itertools
import math
import time
from contextlib import contextmanager
from pathlib import Path

import torch
from tensordict.nn import TensorDictModule
from torch import nn
from torchrl.modules import ValueOperator

from formation_rl.compat import is_batched_tensor

ACTIVATIONS = {"relu": nn.ReLU, "tanh": nn.Tanh, "elu": nn.ELU, "leaky_relu": nn.LeakyReLU}


def bf16_supported(device: torch.device | str) -> bool:
    """Whether ``device`` multiplies bf16 natively: a CUDA GPU that says so, or a CPU with AVX512-BF16 or AMX."""
    device = torch.device(device)
    if device.type == "cuda":
        return torch.cuda.is_available() and torch.cuda.is_bf16_supported()
    try:
        flags = Path("/proc/cpuinfo").read_text()
    except OSError:  # not Linux: no way to tell here
        return False
    return " avx512_bf16" in flags or " amx_bf16" in flags


@functools.cache
def bf16_speedup(device: str) -> float:
    """How many times faster ``device`` runs a bf16 GEMM than an fp32 one at the critics' hidden-layer shape
    (``[10, 1024, 128] @ [10, 128, 128]``: two twins x five robots, batch 1024), median of 5 timed blocks,
    under half a second once per process; 0.0 where bf16 is not native. Measured, not assumed: a CPU that reports
    AVX512-BF16 without AMX (an Intel Xeon here, 2026-12-04) ran this GEMM at 0.47-0.68x fp32's speed and the
    whole step at 1.26x fp32's time (benchmarks/README.md). On a CPU it times one thread: the ratio is the
    core's, and on all threads beside another busy process (an evaluation, a second run) the threads' waits
    swamped it (an AMX CPU measured 1.0-1.2x there against 4.3x alone, so `precision=auto` took
    fp32; one thread: 4.6-7.9x, 2026-12-05)."""
    dev = torch.device(device)
    if not bf16_supported(dev):
        return 0.0
    if dev.type == "cpu":
        threads = torch.get_num_threads()
        torch.set_num_threads(1)
        try:
            return _gemm_speedup(dev)
        finally:
            torch.set_num_threads(threads)
    return _gemm_speedup(dev)


def _gemm_speedup(dev: torch.device) -> float:
    sync = torch.cuda.synchronize if dev.type == "cuda" else (lambda: None)

    def seconds(dtype: torch.dtype) -> float:
        a = torch.randn(10, 1024, 128, device=dev, dtype=dtype)
        w = torch.randn(10, 128, 128, device=dev, dtype=dtype)
        times = []
        for _ in range(7):  # the first two warm up
            sync()
            start = time.perf_counter()
            for _rep in range(3):
                torch.bmm(a, w)
            sync()
            times.append(time.perf_counter() - start)
        return sorted(times[2:])[2]

    return seconds(torch.float32) / seconds(torch.bfloat16)


_TARGET_PASSES = False  # inside target_passes(): the update's passes without gradients (its TD targets)


@contextmanager
def target_passes():
    """Marks the passes without gradients inside it as the update's TD-target passes, which run their hidden
    layers in each network's ``target_dtype`` (``precision=bf16_targets``); collection and evaluation, outside
    it, stay fp32. (A module flag rather than an argument: TorchRL's loss calls the networks itself.)"""
    global _TARGET_PASSES
    before, _TARGET_PASSES = _TARGET_PASSES, True
    try:
        yield
    finally:
        _TARGET_PASSES = before


def _hidden_autocast(x: torch.Tensor, dtype: torch.dtype | None):
    """Autocast of the hidden layers to ``dtype`` (None: off), the dtype :meth:`PerRobotMLP.hidden_dtype` chose."""
    return torch.autocast(x.device.type, dtype=dtype or torch.bfloat16, enabled=dtype is not None)


def _output_layer(h: torch.Tensor, weight: torch.Tensor, bias: torch.Tensor) -> torch.Tensor:
    """``h W + b`` for the last layer's few outputs (the Q-value, the 2 actions), ``[G, B, out]``: computed as
    ``[G, out, B]`` rows, a GEMM with M = out rather than N = out, which runs 3-4x faster here. The hand-written
    layers only; the fp32 default keeps its ``baddbmm`` and so its runs bit for bit (this order changes float
    rounding, and a run's outcome on the leader + follower sub-task flips with rounding: docs/RESULTS.md)."""
    return torch.baddbmm(bias.transpose(1, 2), weight.transpose(1, 2), h.transpose(1, 2)).transpose(1, 2)


def _group_major(h: torch.Tensor, groups: int, width: int) -> torch.Tensor:
    """The joint layer's output ``[B, G*H]`` as ``[G, B, H]``, copied contiguous: the bf16 step ran ~6% faster
    than on the strided view (``benchmarks/levers.py --precision bf16_targets``)."""
    return h.view(-1, groups, width).transpose(0, 1).contiguous()


class _ReluLayers(torch.autograd.Function):
    """Per-robot ReLU layers with a hand-written backward: ``relu(h W_k + b_k)`` for every layer but the
    last, which is affine and runs in the weights' dtype (fp32).

    Why by hand, when autograd and autocast give the same values: under TorchRL's vmap over the twin
    critics each ``baddbmm`` splits into a ``bmm`` and a bias add, autocast casts every weight on every
    call, and the critic's input is copied per twin; here each hidden layer is one ``baddbmm`` (bias
    fused) and an in-place ReLU, its backward a ``threshold_backward`` and two ``bmm``s, and the vmap rule
    folds the twins into the robot dimension (one GEMM for both critics, one joint input for both).
    Hidden layers compute in ``dtype`` (bf16 under ``precision=bf16``; ``None``: the input's dtype);
    gradients of the fp32 weights come back in fp32.

    Two modes. Actor (``action is None``): ``x`` is robot-major ``[G, B, in]``. Critic: ``x`` is the
    observations ``[B, N, D]`` and ``action`` the actions ``[B, N, 2]``; every group (critic) reads the
    joint input ``[o_1..o_N, a_1..a_N]`` (one GEMM for all of them), and the actions' gradient flows into
    critic g through its own action's rows only (``a_{g mod N}``, see :class:`CentralizedCritic`).
    Returns ``(out [G, B, out], *saved)``; ``saved`` are kept for the backward only.
    """

    @staticmethod
    def forward(x, action, num_robots, dtype, *params):
        n_layers = len(params) // 2
        weights, biases = params[:n_layers], params[n_layers:]
        if action is not None:  # the joint input, and a column of ones that carries the first layer's bias
            x = torch.cat([x.reshape(x.shape[0], -1), action.reshape(action.shape[0], -1), x.new_ones(x.shape[0], 1)],
                          -1)  # [B, N*D + 2N + 1]
        h = x.to(dtype) if dtype not in (None, x.dtype) else x.view_as(x)  # (a view: autograd saves no input as-is)
        saved = [h]
        for w, b in zip(weights[:-1], biases[:-1], strict=True):
            w, b = w.to(h.dtype), b.to(h.dtype)
            if h.dim() == 2:  # the joint input: [B, in + 1] @ [in + 1, G*H], all groups' weights side by side
                g, _, out = w.shape
                h = torch.mm(h, torch.cat([w, b], 1).permute(1, 0, 2).reshape(-1, g * out))  # bias: no extra pass
                h = _group_major(h, g, out)
            else:
                h = torch.baddbmm(b, h, w)
            saved.append(h.relu_())
        last = h.to(weights[-1].dtype)
        if last.dtype != h.dtype:  # the fp32 copy of the last hidden layer, for the last weights' gradient
            saved.append(last)
        return (_output_layer(last, weights[-1], biases[-1]), *saved)

    @staticmethod
    def setup_context(ctx, inputs, output):
        x, action, num_robots, dtype, *params = inputs
        n_layers = len(params) // 2
        ctx.num_robots, ctx.critic = num_robots, action is not None
        ctx.obs_shape = x.shape
        ctx.extra = len(output) - 1 - n_layers  # 1: the fp32 copy of the last hidden layer is saved
        ctx.mark_non_differentiable(*output[1:])
        ctx.set_materialize_grads(False)  # (the saved outputs get no gradient: no zero tensors for them)
        ctx.save_for_backward(*params[:n_layers], *output[1:])

    @staticmethod
    def backward(ctx, grad_out, *_):
        saved = ctx.saved_tensors
        n_layers = (len(saved) + 1 - ctx.extra) // 2
        if grad_out is None:
            return (None,) * (4 + 2 * n_layers)
        weights, acts = saved[:n_layers], saved[n_layers : 2 * n_layers]
        last = saved[-1] if ctx.extra else acts[-1]
        low, w_last = acts[-1].dtype, weights[-1]
        grad_w, grad_b = [None] * n_layers, [None] * n_layers
        grad_w[-1] = torch.bmm(grad_out.transpose(1, 2), last).transpose(1, 2)  # (this side: no transposed copy)
        grad_b[-1] = grad_out.sum(1, keepdim=True)
        if w_last.shape[-1] == 1:  # one output (Q): an outer product, which bmm with K = 1 runs slowly
            grad_h = grad_out.to(low) * w_last.transpose(1, 2).to(low)
        else:
            grad_h = torch.bmm(grad_out.to(low), w_last.transpose(1, 2).to(low))
        grad_x = grad_action = None
        for k in range(n_layers - 2, -1, -1):
            grad_z = torch.ops.aten.threshold_backward(grad_h, acts[k + 1], 0)  # ReLU's backward, from its output
            h, w = acts[k], weights[k]
            g, fan_in, hid = w.shape
            if h.dim() == 2:  # joint input: [in + 1, B] @ [B, G*H], the bias's gradient in the row of ones
                flat = grad_z.transpose(0, 1).reshape(-1, g * hid)
                grad_wb = (h.t() @ flat).view(fan_in + 1, g, hid).transpose(0, 1).to(w.dtype)
                grad_w[k], grad_b[k] = grad_wb[:, :-1], grad_wb[:, -1:]
            else:
                grad_w[k] = torch.bmm(h.transpose(1, 2), grad_z).to(w.dtype)
                grad_b[k] = grad_z.sum(1, keepdim=True).to(w.dtype)  # (summed in fp32 inside, as bmm does)
            if k > 0:
                grad_h = torch.bmm(grad_z, w.transpose(1, 2).to(low))
            elif ctx.critic:
                n = ctx.num_robots
                if ctx.needs_input_grad[0]:  # every critic's gradient into the observations
                    grad_joint = flat @ w.permute(1, 0, 2).reshape(fan_in, g * hid).t().to(low)
                    grad_x = grad_joint[:, : fan_in - 2 * n].reshape(ctx.obs_shape).to(w.dtype)
                if ctx.needs_input_grad[1]:  # critic g's gradient into its own action only
                    groups = torch.arange(g, device=w.device)
                    rows = fan_in - 2 * n + 2 * (groups % n)
                    w_own = w[groups[:, None], rows[:, None] + torch.arange(2, device=w.device)]  # [G, 2, H]
                    grad_own = torch.bmm(grad_z, w_own.transpose(1, 2).to(low)).to(w.dtype)  # [G, B, 2]
                    grad_action = grad_own.view(-1, n, *grad_own.shape[1:]).sum(0).transpose(0, 1)  # [B, N, 2]
            elif ctx.needs_input_grad[0]:
                grad_x = torch.bmm(grad_z, w.transpose(1, 2).to(low)).to(w.dtype)
        return (grad_x, grad_action, None, None, *grad_w, *grad_b)

    @staticmethod
    def vmap(info, in_dims, x, action, num_robots, dtype, *params):
        """Weights batched on the twin dimension (TorchRL stacks the critics): fold the twins into the
        groups; inputs TorchRL expanded over the twins (stride 0) count as one input for all of them."""
        c = info.batch_size

        def unbatch(t, d):  # (tensor, batch dim or None); an expanded batch is no batch
            if t is None or d is None:
                return t, None
            t = t.movedim(d, 0)
            return (t[0], None) if t.stride(0) == 0 else (t, 0)

        (x, x_dim), (action, a_dim) = unbatch(x, in_dims[0]), unbatch(action, in_dims[1])
        params = [p.movedim(d, 0) if d is not None else p.expand(c, *p.shape) for p, d in zip(params, in_dims[4:],
                                                                                             strict=True)]
        if action is not None and (x_dim is not None or a_dim is not None):  # twins on inputs of their own
            outs = [_ReluLayers.apply(x if x_dim is None else x[i], action if a_dim is None else action[i],
                                      num_robots, dtype, *(p[i] for p in params)) for i in range(c)]
            return tuple(torch.stack(o) for o in zip(*outs, strict=True)), (0,) * len(outs[0])
        if action is None:
            x = (x if x_dim is not None else x.expand(c, *x.shape)).reshape(-1, *x.shape[-2:])
        out = _ReluLayers.apply(x, action, num_robots, dtype, *(p.reshape(-1, *p.shape[2:]) for p in params))
        dims = [0] * len(out)
        unfolded = [o.view(c, -1, *o.shape[1:]) for o in out]
        if action is not None:  # the joint input is one for every twin
            unfolded[1], dims[1] = out[1], None
        return tuple(unfolded), tuple(dims)


class PerRobotMLP(nn.Module):
    """N independent MLPs ``in -> hidden... -> out``, input ``[..., N, in]``, output ``[..., N, out]``."""

    def __init__(self, num_robots: int, in_features: int, out_features: int, hidden: tuple[int, ...] = (128, 128),
                 activation: str = "relu", layer_norm: tuple[int, ...] = ()):
        super().__init__()
        if activation not in ACTIVATIONS:
            raise ValueError(f"model.activation = {activation!r} is invalid: must be one of {', '.join(ACTIVATIONS)}")
        sizes = [in_features, *hidden, out_features]
        self.num_robots = num_robots
        self.weights = nn.ParameterList()
        self.biases = nn.ParameterList()
        for fan_in, fan_out in zip(sizes[:-1], sizes[1:], strict=True):
            bound = 1.0 / math.sqrt(fan_in)  # nn.Linear's default initialisation, per robot
            self.weights.append(nn.Parameter(torch.empty(num_robots, fan_in, fan_out).uniform_(-bound, bound)))
            self.biases.append(nn.Parameter(torch.empty(num_robots, 1, fan_out).uniform_(-bound, bound)))
        self.activation = ACTIVATIONS[activation]()  # (in place measured no faster: vmap copies the twins)
        self.compute_dtype: torch.dtype | None = None  # torch.bfloat16: hidden layers under autocast with grad
        self.target_dtype: torch.dtype | None = None  # ... and in the update's TD-target passes (target_passes())
        self.hand_written: bool | None = None  # _ReluLayers: None = under bf16 only; True/False forces it (tests)
        self.layer_norm = tuple(layer_norm)  # these robots' hidden layers normalised (no affine), autograd path

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        lead, (n, d) = x.shape[:-2], x.shape[-2:]
        h = x.reshape(-1, n, d).transpose(0, 1)
        h = self.relu_layers(h) if self.fast else self.layers_from(h, 0)
        return h.transpose(0, 1).reshape(*lead, n, -1)

    @property
    def fast(self) -> bool:
        """ReLU hidden layers run through :class:`_ReluLayers` (forward and backward by hand): under
        ``precision=bf16`` only, until a learning A/B shows it equal to the autograd path (the fp32 default
        stays on autograd; the same-process step A/B is in benchmarks/README.md)."""
        on = self.compute_dtype is not None if self.hand_written is None else self.hand_written
        return on and type(self.activation) is nn.ReLU and not self.layer_norm

    def hidden_dtype(self) -> torch.dtype | None:
        """The hidden layers' dtype for the pass now running (None: fp32): ``compute_dtype`` with gradients on,
        ``target_dtype`` in the update's TD-target passes, fp32 in every other pass without gradients."""
        if torch.is_grad_enabled():
            return self.compute_dtype
        return self.target_dtype if _TARGET_PASSES else None

    def relu_layers(self, x: torch.Tensor, action: torch.Tensor | None = None,
                    first: torch.Tensor | None = None) -> torch.Tensor:
        """Every layer through :class:`_ReluLayers`: on robot-major ``x`` ``[N, B, in]``, or (critic) on the joint
        input of observations ``x`` ``[B, N, D]`` and ``action`` ``[B, N, 2]``; returns ``[N, B, out]``. Hidden
        layers in :meth:`hidden_dtype` (as :meth:`layers_from`).
        ``first``: the first layer's weights to use instead of ``weights[0]`` (a masked copy)."""
        dtype = self.hidden_dtype()
        weights = list(self.weights)  # (a list: slicing a ParameterList makes new Parameters)
        if first is not None:
            weights[0] = first
        return _ReluLayers.apply(x, action, self.num_robots, dtype, *weights, *self.biases)[0]

    def norm(self, h: torch.Tensor) -> torch.Tensor:
        """``model.critic_layer_norm``: robot-major ``h`` ``[N, B, H]`` with the ``layer_norm`` robots' rows
        normalised, the others as they are."""
        if not self.layer_norm:
            return h
        # runs of robots, normalised or not, joined by one cat: the backward slices views (a stack of single rows
        # backward-filled a zero tensor per row, 10% of the recipe's step on one thread); no mask buffer: it would
        # join the loss's parameter TensorDict (and its soft updates)
        parts, start = [], 0
        for on, run in itertools.groupby(range(self.num_robots), key=lambda i: i in self.layer_norm):
            end = start + len(list(run))
            parts.append(nn.functional.layer_norm(h[start:end], h.shape[-1:]) if on else h[start:end])
            start = end
        return parts[0] if len(parts) == 1 else torch.cat(parts)

    def layers_from(self, h: torch.Tensor, first: int) -> torch.Tensor:
        """Layers ``first...`` on robot-major input ``[N, B, in_first]``; returns ``[N, B, out]``.

        Every layer but the last runs in :meth:`hidden_dtype`; the last (to the Q-value or the action)
        always runs in fp32 on fp32 inputs.
        """
        last = len(self.weights) - 1
        with _hidden_autocast(h, self.hidden_dtype()):
            for k in range(first, last):
                h = self.activation(self.norm(torch.baddbmm(self.biases[k], h, self.weights[k])))  # robot i's layer
        return torch.baddbmm(self.biases[last], h.float(), self.weights[last])


class CentralizedCritic(nn.Module):
    """Q_i(o_1..o_N, a_1..a_N) for every robot i, each robot with its own MLP (reference.md, Algorithms; CTDE).

    Critic i sees every observation and action; gradients reach the actions only through a_i
    (the others enter detached), so ``-sum_i Q_i`` trains actor i on its own critic, as in MADDPG.
    The first layer, over the joint input shared by all critics, runs as one GEMM instead of N.

    ``own_only``: robots whose critic reads only their own observation and action (a zero mask on the
    rest of the first layer's rows): for a robot whose reward depends on nothing the others do, the
    others' inputs are noise to its critic.
    """

    def __init__(self, num_robots: int, obs_dim: int, action_dim: int = 2, hidden: tuple[int, ...] = (128, 128),
                 activation: str = "relu", own_only: tuple[int, ...] = (), layer_norm: tuple[int, ...] = ()):
        super().__init__()
        n, d = num_robots, obs_dim
        # critic i's first-layer input: every observation (N*D), then every action (N*2)
        self.mlp = PerRobotMLP(n, n * (d + action_dim), 1, hidden, activation, layer_norm)
        mask = None
        if own_only:
            mask = torch.ones(n, n * (d + action_dim), 1)
            for i in own_only:
                mask[i] = 0.0
                mask[i, i * d:(i + 1) * d] = 1.0
                mask[i, n * d + i * action_dim:n * d + (i + 1) * action_dim] = 1.0
            with torch.no_grad():  # nn.Linear's initialisation for the fan-in the robot really has
                self.mlp.weights[0][list(own_only)] *= math.sqrt(n)
        self.register_buffer("input_mask", mask)  # None: every critic reads everything

    def forward(self, observation: torch.Tensor, action: torch.Tensor) -> torch.Tensor:
        lead, (n, d) = observation.shape[:-2], observation.shape[-2:]
        act = action.reshape(-1, n, 2)
        dead = act.detach()
        w1, b1 = self.mlp.weights[0], self.mlp.biases[0]
        if self.input_mask is not None:
            w1 = w1 * self.input_mask
        if self.mlp.fast:  # the same, forward and backward by hand
            h = self.mlp.relu_layers(observation.reshape(-1, n, d), act, first=w1)  # [N, B, 1]
            return h.transpose(0, 1).reshape(*lead, n, 1)
        # first layer of all N critics as one GEMM over the shared joint input, bias fused:
        # [B, N*D + 2N] @ [N*D + 2N, N*H] (weights [N, N*D + 2N, H] laid side by side)
        h_dim = w1.shape[-1]
        joint = torch.cat([observation.reshape(-1, n * d), dead.reshape(-1, 2 * n)], -1)
        with _hidden_autocast(joint, self.mlp.hidden_dtype()):
            h = torch.addmm(b1.reshape(n * h_dim), joint, w1.permute(1, 0, 2).reshape(-1, n * h_dim))
            h = h.view(-1, n, h_dim).transpose(0, 1)  # [N, B, H]
            if _may_need_grad(action):
                # a_i's gradient path into critic i alone: adds zero to the values, (a_i - sg(a_i)) W_i^(i)
                ar = torch.arange(n, device=w1.device)
                w_own = w1[:, n * d :].reshape(n, n, 2, h_dim)[ar, ar]  # [N, 2, H]
                h = torch.baddbmm(h, (act - dead).transpose(0, 1), w_own)
            h = self.mlp.activation(self.mlp.norm(h))
        h = self.mlp.layers_from(h, 1)  # [N, B, 1]
        return h.transpose(0, 1).reshape(*lead, n, 1)


def _may_need_grad(t: torch.Tensor) -> bool:
    """Whether a gradient may flow back into ``t``; under vmap (TorchRL's twin critics) a batched
    tensor reports ``requires_grad=False`` whatever lies beneath, so it counts as yes."""
    if not torch.is_grad_enabled():
        return False
    return t.requires_grad or is_batched_tensor(t)


class ResidualActor(nn.Module):
    """Per-robot corrections to a fixed controller: ``clip(base(o) + scale * tanh(mu(o)), -1, 1)``.

    ``base`` maps ``[..., N, D]`` observations to ``[..., N, 2]`` actions and is not trained (no
    parameters; no gradient flows through it). The last layer of ``mu`` starts at zero, so the
    actors start as the controller itself and learn only what to change (residual policy learning,
    Silver et al. 2018; Johannink et al. 2019).
    """

    def __init__(self, mlp: PerRobotMLP, base: nn.Module, scale: float):
        super().__init__()
        self.mlp, self.base, self.scale = mlp, base, scale
        with torch.no_grad():
            mlp.weights[-1].zero_()
            mlp.biases[-1].zero_()

    def forward(self, observation: torch.Tensor) -> torch.Tensor:
        return self.squash(observation, self.mlp(observation))

    def squash(self, observation: torch.Tensor, pre: torch.Tensor) -> torch.Tensor:
        """The action from the correction's pre-tanh output ``pre`` (the actor loss computes that itself)."""
        with torch.no_grad():
            base = self.base(observation)
        return (base + self.scale * torch.tanh(pre)).clamp(-1.0, 1.0)


# precision: (hidden layers with gradients, hidden layers of the update's TD-target passes); None = fp32
PRECISIONS = {"fp32": (None, None), "bf16": (torch.bfloat16, None), "bf16_targets": (torch.bfloat16, torch.bfloat16)}


def set_precision(module: nn.Module, precision: str) -> None:
    """``fp32``, ``bf16`` or ``bf16_targets`` for every :class:`PerRobotMLP` in ``module``
    (see :meth:`PerRobotMLP.hidden_dtype`)."""
    for m in module.modules():
        if isinstance(m, PerRobotMLP):
            m.compute_dtype, m.target_dtype = PRECISIONS[precision]


def make_actor(num_robots: int, obs_dim: int, hidden=(128, 128), activation: str = "relu",
               base: nn.Module | None = None, residual_scale: float = 0.5) -> TensorDictModule:
    """Deterministic per-robot actors ``o_i -> tanh(mu_i(o_i))`` in [-1, 1]^2 (decentralized execution);
    with ``base`` (a controller of the same observations), :class:`ResidualActor` corrections to it."""
    mlp = PerRobotMLP(num_robots, obs_dim, 2, tuple(hidden), activation)
    net = nn.Sequential(mlp, nn.Tanh()) if base is None else ResidualActor(mlp, base, residual_scale)
    return TensorDictModule(net, in_keys=[("agents", "observation")], out_keys=[("agents", "action")])


def make_critic(num_robots: int, obs_dim: int, hidden=(128, 128), activation: str = "relu",
                own_only: tuple[int, ...] = (), layer_norm: tuple[int, ...] = ()) -> ValueOperator:
    """Centralized per-robot critic writing ``("agents", "state_action_value")`` ``[..., N, 1]``
    (``own_only``: see :class:`CentralizedCritic`; ``layer_norm``: the robots whose critics normalise their hidden
    pre-activations)."""
    return ValueOperator(
        CentralizedCritic(num_robots, obs_dim, 2, tuple(hidden), activation, tuple(own_only), tuple(layer_norm)),
        in_keys=[("agents", "observation"), ("agents", "action")],
        out_keys=[("agents", "state_action_value")],
    )

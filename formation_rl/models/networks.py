"""Per-robot networks with no parameter sharing, evaluated for all robots in one batched matmul.

Hand-written instead of ``MultiAgentMLP(centralized=True)`` for one reason of correctness and one of
speed: in MADDPG/MATD3 the actor of robot i climbs its *own* critic Q_i through its own action a_i
only (paper §3, Fig. 4), which a critic fed one shared input cannot express; and one
``baddbmm`` per layer serves every robot (and, under the losses' vmap, both twin critics).
"""

from __future__ import annotations

import math
from pathlib import Path

import torch
from tensordict.nn import TensorDictModule
from torch import nn
from torchrl.modules import ValueOperator

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


def _hidden_autocast(x: torch.Tensor, dtype: torch.dtype | None):
    """bf16 autocast of the hidden layers while gradients are on (the update's forward and backward);
    passes without gradients (TD targets, collection, evaluation) stay in fp32."""
    on = dtype is not None and torch.is_grad_enabled()
    return torch.autocast(x.device.type, dtype=dtype or torch.bfloat16, enabled=on)


class PerRobotMLP(nn.Module):
    """N independent MLPs ``in -> hidden... -> out``, input ``[..., N, in]``, output ``[..., N, out]``."""

    def __init__(self, num_robots: int, in_features: int, out_features: int, hidden: tuple[int, ...] = (128, 128),
                 activation: str = "relu"):
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

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        lead, (n, d) = x.shape[:-2], x.shape[-2:]
        return self.layers_from(x.reshape(-1, n, d).transpose(0, 1), 0).transpose(0, 1).reshape(*lead, n, -1)

    def layers_from(self, h: torch.Tensor, first: int) -> torch.Tensor:
        """Layers ``first...`` on robot-major input ``[N, B, in_first]``; returns ``[N, B, out]``.

        With ``compute_dtype`` set and gradients on, every layer but the last runs in that dtype; the
        last (to the Q-value or the action) always runs in fp32 on fp32 inputs.
        """
        last = len(self.weights) - 1
        with _hidden_autocast(h, self.compute_dtype):
            for k in range(first, last):
                h = self.activation(torch.baddbmm(self.biases[k], h, self.weights[k]))  # robot i's layer
        return torch.baddbmm(self.biases[last], h.float(), self.weights[last])


class CentralizedCritic(nn.Module):
    """Q_i(o_1..o_N, a_1..a_N) for every robot i, each robot with its own MLP (SPEC §5, CTDE).

    Critic i sees every observation and action; gradients reach the actions only through a_i
    (the others enter detached), so ``-sum_i Q_i`` trains actor i on its own critic, as in MADDPG.
    The first layer, over the joint input shared by all critics, runs as one GEMM instead of N.
    """

    def __init__(self, num_robots: int, obs_dim: int, action_dim: int = 2, hidden: tuple[int, ...] = (128, 128),
                 activation: str = "relu"):
        super().__init__()
        # critic i's first-layer input: every observation (N*D), then every action (N*2)
        self.mlp = PerRobotMLP(num_robots, num_robots * (obs_dim + action_dim), 1, hidden, activation)

    def forward(self, observation: torch.Tensor, action: torch.Tensor) -> torch.Tensor:
        lead, (n, d) = observation.shape[:-2], observation.shape[-2:]
        act = action.reshape(-1, n, 2)
        dead = act.detach()
        # first layer of all N critics as one GEMM over the shared joint input, bias fused:
        # [B, N*D + 2N] @ [N*D + 2N, N*H] (weights [N, N*D + 2N, H] laid side by side)
        w1, b1 = self.mlp.weights[0], self.mlp.biases[0]
        h_dim = w1.shape[-1]
        joint = torch.cat([observation.reshape(-1, n * d), dead.reshape(-1, 2 * n)], -1)
        with _hidden_autocast(joint, self.mlp.compute_dtype):
            h = torch.addmm(b1.reshape(n * h_dim), joint, w1.permute(1, 0, 2).reshape(-1, n * h_dim))
            h = h.view(-1, n, h_dim).transpose(0, 1)  # [N, B, H]
            if _may_need_grad(action):
                # a_i's gradient path into critic i alone: adds zero to the values, (a_i - sg(a_i)) W_i^(i)
                ar = torch.arange(n, device=w1.device)
                w_own = w1[:, n * d :].reshape(n, n, 2, h_dim)[ar, ar]  # [N, 2, H]
                h = torch.baddbmm(h, (act - dead).transpose(0, 1), w_own)
            h = self.mlp.activation(h)
        h = self.mlp.layers_from(h, 1)  # [N, B, 1]
        return h.transpose(0, 1).reshape(*lead, n, 1)


def _may_need_grad(t: torch.Tensor) -> bool:
    """Whether a gradient may flow back into ``t``; under vmap (TorchRL's twin critics) a batched
    tensor reports ``requires_grad=False`` whatever lies beneath, so it counts as yes."""
    if not torch.is_grad_enabled():
        return False
    return t.requires_grad or torch._C._functorch.is_batchedtensor(t)


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


PRECISIONS = {"fp32": None, "bf16": torch.bfloat16}


def set_precision(module: nn.Module, precision: str) -> None:
    """``fp32`` or ``bf16`` for every :class:`PerRobotMLP` in ``module`` (see :meth:`PerRobotMLP.layers_from`)."""
    for m in module.modules():
        if isinstance(m, PerRobotMLP):
            m.compute_dtype = PRECISIONS[precision]


def make_actor(num_robots: int, obs_dim: int, hidden=(128, 128), activation: str = "relu",
               base: nn.Module | None = None, residual_scale: float = 0.5) -> TensorDictModule:
    """Deterministic per-robot actors ``o_i -> tanh(mu_i(o_i))`` in [-1, 1]^2 (decentralized execution);
    with ``base`` (a controller of the same observations), :class:`ResidualActor` corrections to it."""
    mlp = PerRobotMLP(num_robots, obs_dim, 2, tuple(hidden), activation)
    net = nn.Sequential(mlp, nn.Tanh()) if base is None else ResidualActor(mlp, base, residual_scale)
    return TensorDictModule(net, in_keys=[("agents", "observation")], out_keys=[("agents", "action")])


def make_critic(num_robots: int, obs_dim: int, hidden=(128, 128), activation: str = "relu") -> ValueOperator:
    """Centralized per-robot critic writing ``("agents", "state_action_value")`` ``[..., N, 1]``."""
    return ValueOperator(
        CentralizedCritic(num_robots, obs_dim, 2, tuple(hidden), activation),
        in_keys=[("agents", "observation"), ("agents", "action")],
        out_keys=[("agents", "state_action_value")],
    )

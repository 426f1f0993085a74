"""What MADDPG, MATD3 and PER-MATD3 share: TorchRL loss, optimisers, soft targets, one update step."""

from __future__ import annotations

import dataclasses
import functools

import torch
from tensordict import TensorDict, TensorDictBase
from torchrl.objectives import LossModule, SoftUpdate, ValueEstimators

from formation_rl.algorithms.config import AlgoConfig
from formation_rl.models.networks import ResidualActor, target_passes

KEYS = dict(
    action=("agents", "action"),
    state_action_value=("agents", "state_action_value"),
    reward=("agents", "reward"),
    done=("agents", "done"),
    terminated=("agents", "terminated"),
)
class NonFiniteError(ValueError):
    """A loss, gradient or input went NaN or infinite; nothing was stepped with it."""


PRIORITY_KEY = "td_error"  # where |delta| [B, N] goes for the prioritized buffer (eq. 17)
WEIGHT_KEY = "priority_weight"  # importance weights [B] from the prioritized buffer (eq. 20)
CUDAGRAPH_WARMUP = 3  # eager calls of each gradient-step graph before it is captured (optimiser state, lazy init)


class Algorithm:
    """Centralized-critic actor-critic on a TorchRL loss; subclasses build the loss.

    The losses run with ``reduction="none"`` and TorchRL's own weighting off, so that the
    importance weights enter exactly as eq. 21-22 write them: ``mean_b w_b * delta_b^2``.
    """

    loss: LossModule
    critic_params_name: str  # "value_network_params" (DDPG) or "qvalue_network_params" (TD3)

    def __init__(self, cfg: AlgoConfig):
        self.cfg = cfg
        accepted = {f.name for f in dataclasses.fields(self.loss.tensor_keys)}
        self.loss.set_keys(**{k: v for k, v in KEYS.items() if k in accepted})
        self.loss.make_value_estimator(ValueEstimators.TD0, gamma=cfg.gamma)
        self.actor_params = [p for p in self.loss.actor_network_params.values(True, True) if p.requires_grad]
        critic = getattr(self.loss, self.critic_params_name)
        self.critic_params = [p for p in critic.values(True, True) if p.requires_grad]
        # fused Adam: 0.93-0.97x of the foreach step's wall time (benchmarks/levers.py, 4 runs, 2 CPU kinds)
        self.actor_optim = torch.optim.Adam(self.actor_params, lr=cfg.lr_actor, fused=True)
        self.critic_optim = torch.optim.Adam(self.critic_params, lr=cfg.lr_critic, fused=True)
        self.target_updater = SoftUpdate(self.loss, tau=cfg.tau)
        self.critic_steps = 0
        self.actor_steps = 0
        self.cudagraphs = False  # enable_cudagraphs(): replay the step from CUDA graphs
        self.anchor: torch.nn.Module | None = None  # obs -> actions the actors are pulled towards (bc_weight)
        self._graphs: dict[bool, object] = {}

    # ------------------------------------------------------------------ one gradient step
    def update(self, batch: TensorDictBase) -> dict[str, torch.Tensor]:
        """One critic step (and, every ``policy_delay`` of them, one actor step and target update).

        Writes ``|delta|`` ``[B, N]`` (max over critics) at ``PRIORITY_KEY`` in ``batch``.
        """
        due = (self.critic_steps + 1) % self.cfg.policy_delay == 0
        with_actor = due and self.critic_steps >= self.cfg.critic_warmup_steps
        if self.cudagraphs:
            out = self._graphed_step(batch, with_actor)
        else:
            out = self._step(batch, with_actor, check=True)
        if due and not with_actor:  # critic warm-up: the actors wait, the targets follow the critics
            self.target_updater.step()
        self.critic_steps += 1
        self.actor_steps += with_actor
        batch.set(PRIORITY_KEY, out.pop("priority"))
        out.pop("finite", None)
        return out.to_dict()

    def _step(self, batch: TensorDictBase, with_actor: bool, check: bool = False) -> TensorDict:
        """The update itself, free of host synchronisation unless ``check``: with ``check`` a non-finite
        loss or gradient raises before its optimiser steps; without it (under a CUDA graph) the step
        returns a ``finite`` flag for the caller to raise on, after the fact."""
        weights = batch.get(WEIGHT_KEY, None)  # [B], normalised by their max (eq. 20)
        with target_passes():  # the loss's passes without gradients are its TD targets' (precision=bf16_targets)
            per_sample, meta = self._critic_loss(batch.exclude(WEIGHT_KEY))  # [B, N], summed over critics
        if weights is not None:
            critic_loss = (per_sample * weights.unsqueeze(-1)).mean()  # eq. 21-22
        else:
            critic_loss = per_sample.mean()
        self.critic_optim.zero_grad(set_to_none=True)
        critic_loss.backward()
        critic_grad = _grad_norm(self.critic_params)
        if check:
            _raise_if_nonfinite(critic_loss, critic_grad, "critic")
        finite = torch.isfinite(critic_loss) & torch.isfinite(critic_grad)
        self.critic_optim.step()

        pred, target = meta["pred_value"], meta["target_value"]  # [C, B, N] or [B, N]; [B, N]
        td_error = (pred - target).abs()
        if td_error.dim() == 3:
            td_error = td_error.amax(0)  # max over the twin critics (eq. 17)
        out = TensorDict(loss_critic=critic_loss.detach(), q_value=pred.mean().detach(),
                         td_error=td_error.mean().detach(), grad_norm_critic=critic_grad,
                         priority=td_error.detach())

        if with_actor:
            # actor loss without importance weights: eq. 21-22 weight the critic losses only
            actor_loss = self._actor_loss(batch)[0]
            self.actor_optim.zero_grad(set_to_none=True)
            actor_loss.backward()
            actor_grad = _grad_norm(self.actor_params)
            if check:
                _raise_if_nonfinite(actor_loss, actor_grad, "actor")
            finite = finite & torch.isfinite(actor_loss) & torch.isfinite(actor_grad)
            self.actor_optim.step()
            self.target_updater.step()
            out["loss_actor"], out["grad_norm_actor"] = actor_loss.detach(), actor_grad
        out["finite"] = finite
        return out

    def _graphed_step(self, batch: TensorDictBase, with_actor: bool) -> TensorDict:
        """:meth:`_step` replayed from a CUDA graph (tensordict's ``CudaGraphModule``), one graph with
        the actor step and one without; captured on first use, after ``CUDAGRAPH_WARMUP`` eager calls."""
        graph = self._graphs.get(with_actor)
        if graph is None:
            from tensordict.nn import CudaGraphModule

            graph = self._graphs[with_actor] = CudaGraphModule(
                functools.partial(self._step, with_actor=with_actor), in_keys=[], out_keys=[],
                warmup=CUDAGRAPH_WARMUP)
        device = self.actor_params[0].device
        inputs = batch.exclude("index")  # the sampler's indices may live on the CPU (PER trees)
        weights = inputs.get(WEIGHT_KEY, None)
        if weights is not None:
            inputs.set(WEIGHT_KEY, weights.to(device, non_blocking=True))
        out = graph(inputs)
        if not bool(out["finite"]):
            part = "critic" if not with_actor or bool(torch.isfinite(out["loss_critic"])) else "actor"
            raise NonFiniteError(f"the {part} loss or gradient went non-finite (under CUDA graphs the step was "
                                 f"already applied to the in-memory networks; nothing was saved with it)")
        return out

    def enable_cudagraphs(self) -> None:
        """Replay each gradient step from a CUDA graph (device=cuda): Adam becomes ``capturable``."""
        self._set_capturable(True)
        for optim in (self.actor_optim, self.critic_optim):
            for p, state in optim.state.items():  # a loaded state keeps Adam's step count on the CPU
                if torch.is_tensor(state.get("step")):
                    state["step"] = state["step"].to(device=p.device, dtype=torch.float32)
        self.cudagraphs = True
        self._graphs = {}

    def _critic_loss(self, batch: TensorDictBase):
        return self.loss.value_loss(batch)

    def _actor_loss(self, batch: TensorDictBase):
        """``-mean_i Q_i(o, a_1..mu_i(o_i)..a_N) + action_reg * mean(u^2)``, u the actors' pre-tanh outputs.

        Written here rather than taken from ``TD3Loss.actor_loss`` / ``DDPGLoss.loss_actor`` for two
        reasons: TD3 climbs the first critic only, and TorchRL evaluates every twin critic and keeps
        the first (half the actor step's critic work thrown away); and the pre-tanh penalty of the
        MADDPG reference implementation, which keeps the actors out of tanh saturation, where the
        policy gradient vanishes and an action stays pinned at +-1. Parameters and their detached
        critic copies are the loss's own.
        """
        loss = self.loss
        obs = batch.get(("agents", "observation"))
        net = loss.actor_network.module
        residual = isinstance(net, ResidualActor)
        mlp = net.mlp if residual else net[0]  # PerRobotMLP; net[1] is the tanh
        with loss.actor_network_params.to_module(loss.actor_network, preserve_module_state=False):
            pre = mlp(obs)
        action = net.squash(obs, pre) if residual else torch.tanh(pre)
        critic_module, critic_params = self._actor_critic()
        with critic_params.to_module(critic_module, preserve_module_state=False):
            q = critic_module.module(obs, action)  # [B, N, 1]; gradient only through a_i into Q_i
        actor_loss = -q.mean()
        if self.anchor is not None and self.cfg.bc_weight > 0:  # TD3+BC: -Q / mean|Q| + w * (a - a_anchor)^2
            with torch.no_grad():
                anchor = self.anchor(obs)
            actor_loss = actor_loss / q.abs().mean().detach().clamp_min(1e-6)
            actor_loss = actor_loss + self.cfg.bc_weight * (action - anchor).pow(2).mean()
        if self.cfg.action_reg > 0:
            actor_loss = actor_loss + self.cfg.action_reg * pre.pow(2).mean()
        return actor_loss, {"q_actor": q.detach()}

    def _actor_critic(self):
        """The critic module and the detached parameters the actor climbs."""
        raise NotImplementedError

    # ------------------------------------------------------------------ checkpoints
    def state_dict(self) -> dict:
        return {
            "loss": self.loss.state_dict(),
            "actor_optim": self.actor_optim.state_dict(),
            "critic_optim": self.critic_optim.state_dict(),
            "critic_steps": self.critic_steps,
            "actor_steps": self.actor_steps,
        }

    def load_state_dict(self, state: dict) -> None:
        self.loss.load_state_dict(state["loss"])
        self.actor_optim.load_state_dict(state["actor_optim"])
        self.critic_optim.load_state_dict(state["critic_optim"])
        self.critic_steps = state["critic_steps"]
        self.actor_steps = state["actor_steps"]
        if self.cudagraphs:  # the loaded optimiser state is new memory: capture again
            self.enable_cudagraphs()
        else:  # a state saved under CUDA graphs resumes without them (on the CPU, say)
            self._set_capturable(False)

    def _set_capturable(self, on: bool) -> None:
        for optim in (self.actor_optim, self.critic_optim):
            for group in optim.param_groups:
                group["capturable"] = on


def _grad_norm(params: list[torch.Tensor]) -> torch.Tensor:
    """The gradient norm of ``params`` (no clipping), without a host synchronisation."""
    return torch.nn.utils.clip_grad_norm_(params, float("inf")).detach()


def _raise_if_nonfinite(loss: torch.Tensor, norm: torch.Tensor, name: str) -> None:
    """Raise before any optimiser step if the loss or its gradient norm is not finite."""
    if not torch.isfinite(loss):
        raise NonFiniteError(f"the {name} loss went non-finite ({loss.item()})")
    if not torch.isfinite(norm):
        raise NonFiniteError(f"the {name} gradient went non-finite (norm {norm.item()})")

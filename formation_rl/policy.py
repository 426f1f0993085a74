"""Load a trained policy for evaluation or deployment, without optimiser or critic state."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch
from tensordict import TensorDict
from tensordict.nn import TensorDictModule

from formation_rl.config import ModelConfig
from formation_rl.envs import EnvConfig
from formation_rl.models import make_actor
from formation_rl.trainer import POLICY, load_checkpoint_file, residual_base


class Policy:
    """Deterministic per-robot actors: ``policy(obs)`` maps ``[..., N, D]`` observations to ``[..., N, 2]`` actions."""

    def __init__(self, actor: TensorDictModule, env_config: EnvConfig, algo: str):
        self.actor, self.env_config, self.algo = actor, env_config, algo

    @property
    def module(self) -> TensorDictModule:
        """The actors as a TorchRL policy (``("agents", "observation")`` -> ``("agents", "action")``)."""
        return self.actor

    def check_world(self, env_cfg: EnvConfig) -> None:
        """Raise if ``env_cfg`` gives observations this policy cannot read (team size, obstacle slots)."""
        mine = self.env_config
        if env_cfg.num_robots != mine.num_robots:
            raise ValueError(f"env.num_robots = {env_cfg.num_robots} is invalid: the policy was trained with "
                             f"{mine.num_robots} robots and has one actor per robot")
        if env_cfg.obs_dim != mine.obs_dim:
            raise ValueError(f"env.num_obstacles = {env_cfg.num_obstacles} is invalid: the policy reads "
                             f"{mine.num_obstacles} obstacle slots (observation width {mine.obs_dim}, "
                             f"requested {env_cfg.obs_dim})")

    @torch.no_grad()
    def __call__(self, observation):
        as_numpy = isinstance(observation, np.ndarray)
        obs = torch.as_tensor(observation, dtype=torch.float32)
        n, d = self.env_config.num_robots, self.env_config.obs_dim
        if obs.shape[-2:] != (n, d):
            raise ValueError(f"observation shape {tuple(obs.shape)} is invalid: the policy expects [..., {n}, {d}]")
        lead = obs.shape[:-2]
        td = TensorDict({("agents", "observation"): obs.reshape(-1, n, d)}, [obs[..., 0, 0].numel()])
        action = self.actor(td)["agents", "action"].reshape(*lead, n, 2)
        return action.numpy() if as_numpy else action


CLASSICAL = "apf"  # the name that loads the non-learned reference controller (formation_rl.controllers)


def is_classical(path) -> bool:
    return str(path) == CLASSICAL


def classical_policy(env_config: EnvConfig | None = None, device: str | torch.device = "cpu") -> Policy:
    """The artificial-potential-field controller of :mod:`formation_rl.controllers` for ``env_config``."""
    from formation_rl.controllers import apf_policy

    cfg = env_config or EnvConfig()
    return Policy(apf_policy(cfg).to(device), cfg, CLASSICAL)


def policy_path(path: str | Path) -> Path:
    """``policy.pt`` itself, the one beside a ``last.pt``, or the one of a run directory."""
    p = Path(path)
    if p.is_dir():
        p = p / POLICY if (p / POLICY).exists() else p / "policy.pt"
    elif p.name != "policy.pt" and (p.parent / "policy.pt").exists():
        p = p.parent / "policy.pt"
    if not p.is_file():
        raise ValueError(f"ckpt = {str(path)!r} is invalid: no policy.pt at {p}")
    return p


def load_policy(path: str | Path, device: str | torch.device = "cpu") -> Policy:
    """A policy from ``policy.pt``, a ``last.pt`` beside one, or a run directory; ``"apf"``: the
    classical controller on the default world (:func:`classical_policy` for another)."""
    if is_classical(path):
        return classical_policy(None, device)
    p = policy_path(path)
    state = load_checkpoint_file(p)
    if "actor" not in state:
        raise ValueError(f"checkpoint {p} holds no actor: pass a policy.pt or a run directory")
    env_cfg = EnvConfig.from_dict(state["env"])
    model = ModelConfig(**state["model"])
    actor = make_actor(env_cfg.num_robots, env_cfg.obs_dim, tuple(model.hidden), model.activation,
                       base=residual_base(model, env_cfg), residual_scale=model.residual_scale)
    actor.load_state_dict(state["actor"])
    return Policy(actor.to(device).eval(), env_cfg, state["algo"])

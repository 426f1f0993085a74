"""Load a trained policy for evaluation or deployment, without optimiser or critic state."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch
from tensordict import TensorDict, TensorDictBase
from tensordict.nn import TensorDictModule, TensorDictModuleBase

from formation_rl.envs import EnvConfig
from formation_rl.evaluation.checkpoint import POLICY, load_checkpoint_file
from formation_rl.models import make_actor
from formation_rl.models.config import ModelConfig
from formation_rl.models.controller import residual_base
from formation_rl.utils import drop_retired


class Policy(TensorDictModuleBase):
    """Deterministic per-robot actors, for evaluation or deployment (no gradients).

    - ``policy(obs)`` maps ``[..., N, D]`` observations (tensor or numpy array) to ``[..., N, 2]`` actions;
    - ``policy(tensordict)`` reads ``("agents", "observation")`` and writes ``("agents", "action")``: the
      policy is itself a TorchRL policy, ``env.rollout(150, policy=policy)``;
    - ``policy.module`` is the underlying actor module (the same keys), with gradients when called outside
      ``torch.no_grad()`` (the environment detaches the actions it is given).

    Observations must be laid out as ``policy.env_config`` says (team size, obstacle slots and
    ``relative_positions``); ``check_world`` raises for a world that gives other ones. ``label`` names
    what the policy is (the algorithm, and ``residual=apf`` for actors correcting the classical controller).
    """

    in_keys = [("agents", "observation")]
    out_keys = [("agents", "action")]

    def __init__(self, actor: TensorDictModule, env_config: EnvConfig, algo: str, model: ModelConfig | None = None):
        super().__init__()
        self.actor, self.env_config, self.algo, self.model = actor, env_config, algo, model

    @property
    def module(self) -> TensorDictModule:
        """The actors as a TorchRL policy (``("agents", "observation")`` -> ``("agents", "action")``)."""
        return self.actor

    @property
    def label(self) -> str:
        """What the policy is, for titles: ``per_matd3``, ``per_matd3 residual=apf``, ``apf``."""
        residual = self.model.residual if self.model is not None else "none"
        return self.algo if residual == "none" else f"{self.algo} residual={residual}"

    def check_world(self, env_cfg: EnvConfig) -> None:
        """Raise if ``env_cfg`` gives observations this policy cannot read (team size, obstacle slots, layout)."""
        mine = self.env_config
        if env_cfg.num_robots != mine.num_robots:
            raise ValueError(f"env.num_robots = {env_cfg.num_robots} is invalid: the policy was trained with "
                             f"{mine.num_robots} robots and has one actor per robot")
        for name in ("relative_positions", "observe_velocities", "observe_distance_errors"):
            if getattr(env_cfg, name) != getattr(mine, name):
                raise ValueError(f"env.{name} = {getattr(env_cfg, name)} is invalid: the policy reads the observation "
                                 f"layout of {name}={getattr(mine, name)}")
        if env_cfg.obs_dim != mine.obs_dim:
            raise ValueError(f"env.num_obstacles = {env_cfg.num_obstacles} is invalid: the policy reads "
                             f"{mine.num_obstacles} obstacle slots (observation width {mine.obs_dim}, "
                             f"requested {env_cfg.obs_dim})")

    @torch.no_grad()
    def forward(self, observation):
        if isinstance(observation, TensorDictBase):
            return self.actor(observation)
        as_numpy = isinstance(observation, np.ndarray)
        obs = torch.as_tensor(observation, dtype=torch.float32, device=_device(self.actor))
        n, d = self.env_config.num_robots, self.env_config.obs_dim
        if obs.shape[-2:] != (n, d):
            raise ValueError(f"observation shape {tuple(obs.shape)} is invalid: the policy expects [..., {n}, {d}]")
        lead = obs.shape[:-2]
        td = TensorDict({("agents", "observation"): obs.reshape(-1, n, d)}, [obs[..., 0, 0].numel()])
        action = self.actor(td)["agents", "action"].reshape(*lead, n, 2)
        return action.cpu().numpy() if as_numpy else action


def _device(module: torch.nn.Module) -> torch.device:
    tensor = next(iter(module.parameters()), None)
    if tensor is None:
        tensor = next(iter(module.buffers()), None)
    return tensor.device if tensor is not None else torch.device("cpu")


CLASSICAL = "apf"  # the name that loads the non-learned reference controller (formation_rl.models.controller)


def is_classical(path) -> bool:
    return str(path) == CLASSICAL


def classical_policy(env_config: EnvConfig | None = None, device: str | torch.device = "cpu") -> Policy:
    """The artificial-potential-field controller of :mod:`formation_rl.models.controller` for ``env_config``."""
    from formation_rl.models.controller import apf_policy

    cfg = env_config or EnvConfig()
    return Policy(apf_policy(cfg).to(device), cfg, CLASSICAL)


def policy_path(path: str | Path) -> Path:
    """A policy file itself (``policy.pt``, ``best_policy.pt``, a pretrained one), the ``policy.pt`` beside a
    ``last.pt``, or the one of a run directory."""
    p = Path(path)
    if p.is_dir():
        p = p / POLICY if (p / POLICY).exists() else p / "policy.pt"
    elif p.name == "last.pt" and (p.parent / "policy.pt").exists():
        p = p.parent / "policy.pt"
    if not p.is_file():
        raise ValueError(f"ckpt = {str(path)!r} is invalid: no policy.pt at {p}")
    return p


def output_dir(kind: str, ckpt: str | Path) -> Path:
    """Where ``make eval`` / ``make render`` (``kind``: eval, render) write by default: ``outputs/<kind>/<name>``,
    never beside the checkpoint. ``name``: ``apf``, the checkpoint file's stem (``pretrained/per_matd3.pt``:
    ``per_matd3``), or for a ``policy.pt`` / ``last.pt`` the run directory's name (``<name>_best`` for its
    ``best_policy.pt``)."""
    if is_classical(ckpt):
        return Path("outputs") / kind / CLASSICAL
    p = policy_path(ckpt).resolve()
    if p.stem in ("policy", "last", "best_policy"):
        run = p.parent.parent if p.parent.name == "checkpoints" else p.parent
        return Path("outputs") / kind / (run.name + ("_best" if p.stem == "best_policy" else ""))
    return Path("outputs") / kind / p.stem


def load_policy(path: str | Path, device: str | torch.device = "cpu", env_config: EnvConfig | None = None) -> Policy:
    """A policy from ``policy.pt``, a ``last.pt`` beside one, or a run directory; ``"apf"``: the
    classical controller.

    ``env_config`` is the world the policy will act in (e.g. ``env.config`` of a ``FormationEnv``): the
    controller is built for it, so it reads that world's observation layout (``relative_positions``,
    team size, obstacle slots; without it: the default world, absolute positions); a checkpoint is
    checked against it (:meth:`Policy.check_world`: one-line ``ValueError`` for a layout it cannot read).
    """
    if is_classical(path):
        return classical_policy(env_config, device)
    p = policy_path(path)
    state = load_checkpoint_file(p)
    if "actor" not in state:
        raise ValueError(f"checkpoint {p} holds no actor: pass a policy.pt or a run directory")
    env_cfg = EnvConfig.from_dict(state["env"])
    model = ModelConfig(**drop_retired(state["model"], "model"))
    actor = make_actor(env_cfg.num_robots, env_cfg.obs_dim, tuple(model.hidden), model.activation,
                       base=residual_base(model, env_cfg), residual_scale=model.residual_scale)
    actor.load_state_dict(state["actor"])
    policy = Policy(actor.to(device).eval(), env_cfg, state["algo"], model)
    if env_config is not None:
        policy.check_world(env_config)
    return policy

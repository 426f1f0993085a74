"""PettingZoo face of the formation world: ``formation_v0.parallel_env(...)``.

A ``ParallelEnv`` over one copy of :class:`~formation_rl.envs.FormationEnv` (same world, same
config fields). Hand-written because TorchRL only wraps PettingZoo envs, not the reverse.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import torch
from gymnasium import spaces
from pettingzoo import ParallelEnv
from pettingzoo.utils.conversions import parallel_to_aec
from tensordict import TensorDict

from formation_rl.envs.config import EnvConfig
from formation_rl.envs.formation_env import FLAG_KEYS, VALUE_KEYS, FormationEnv

RENDER_MODES = ("rgb_array",)


def agent_names(num_robots: int) -> list[str]:
    """``leader``, ``follower_1``, ..., ``follower_{N-1}`` (index order of the TorchRL env)."""
    return ["leader"] + [f"follower_{i}" for i in range(1, num_robots)]


class FormationParallelEnv(ParallelEnv):
    metadata = {"name": "formation_v0", "render_modes": list(RENDER_MODES), "is_parallelizable": True,
                "render_fps": 10}

    def __init__(self, render_mode: str | None = None, config: EnvConfig | dict | None = None, **fields):
        if render_mode is not None and render_mode not in RENDER_MODES:
            raise ValueError(f"render_mode = {render_mode!r} is invalid: must be None or one of {RENDER_MODES}")
        cfg = config if isinstance(config, EnvConfig) else EnvConfig.from_dict(config or {})
        if fields:
            cfg = EnvConfig.from_dict({**dataclasses.asdict(cfg), **fields})
        self.render_mode = render_mode
        self._env = FormationEnv(1, config=cfg)
        self.config = self._env.config
        self.possible_agents = agent_names(cfg.num_robots)
        self.agents: list[str] = []
        self._obs_space = spaces.Box(-np.inf, np.inf, (cfg.obs_dim,), np.float32)
        self._act_space = {a: spaces.Box(-1.0, 1.0, (2,), np.float32) for a in self.possible_agents}
        self._td: TensorDict | None = None

    def observation_space(self, agent: str) -> spaces.Box:
        return self._obs_space

    def action_space(self, agent: str) -> spaces.Box:
        return self._act_space[agent]

    def reset(self, seed: int | None = None, options: dict | None = None):
        if seed is not None:
            self._env.set_seed(seed)
            for i, a in enumerate(self.possible_agents):
                self._act_space[a].seed(seed + i)
        self._td = self._env.reset()
        self.agents = list(self.possible_agents)
        return self._observations(self._td), {a: {} for a in self.agents}

    def step(self, actions: dict[str, np.ndarray]):
        if not self.agents:
            raise RuntimeError("step() called after the episode ended: call reset() first")
        missing = [a for a in self.agents if a not in actions]
        if missing:
            raise ValueError(f"actions: no action for agent {missing[0]!r}; expected one for each of {self.agents}")
        act = torch.as_tensor(np.stack([np.asarray(actions[a], dtype=np.float32) for a in self.agents]))
        self._td.set(("agents", "action"), act.reshape(1, len(self.agents), 2))
        nxt = self._env.step(self._td).get("next")
        self._td = nxt.exclude(("agents", "reward"), "done", "terminated", "truncated")
        obs = self._observations(nxt)
        reward = nxt.get(("agents", "reward"))[0, :, 0].tolist()
        term, trunc = bool(nxt.get("terminated")), bool(nxt.get("truncated"))
        info = {k: nxt.get(k).item() for k in FLAG_KEYS + VALUE_KEYS}
        agents = self.agents
        if term or trunc:
            self.agents = []
        return (
            obs,
            {a: float(r) for a, r in zip(agents, reward, strict=True)},
            {a: term for a in agents},
            {a: trunc for a in agents},
            {a: dict(info) for a in agents},
        )

    def _observations(self, td: TensorDict) -> dict[str, np.ndarray]:
        obs = td.get(("agents", "observation"))[0].numpy()
        return {a: obs[i].copy() for i, a in enumerate(self.possible_agents)}

    def state(self) -> np.ndarray:
        """Global state: every robot's observation, concatenated."""
        return self._td.get(("agents", "observation"))[0].reshape(-1).numpy().copy()

    def render(self) -> np.ndarray | None:
        if self.render_mode is None:
            return None
        return self._env.render(0)

    def close(self) -> None:
        pass


def parallel_env(
    render_mode: str | None = None, config: EnvConfig | dict | None = None, **fields
) -> FormationParallelEnv:
    """The formation world as a PettingZoo ``ParallelEnv``; ``fields`` override ``EnvConfig`` fields."""
    return FormationParallelEnv(render_mode=render_mode, config=config, **fields)


def env(render_mode: str | None = None, config: EnvConfig | dict | None = None, **fields):
    """The same world as a PettingZoo AEC env."""
    return parallel_to_aec(parallel_env(render_mode=render_mode, config=config, **fields))


raw_env = parallel_env

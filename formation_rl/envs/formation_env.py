"""The formation world as a batched multi-agent TorchRL environment."""

from __future__ import annotations

import numpy as np
import torch
from tensordict import TensorDict, TensorDictBase
from torchrl.data import Bounded, Categorical, Composite, Unbounded
from torchrl.envs import EnvBase

from formation_rl.envs import world
from formation_rl.envs.config import EnvConfig
from formation_rl.envs.rewards import Geometry, step_quantities

STATE_KEYS = ("positions", "velocities", "goal", "obstacle_centers", "obstacle_radii")
FLAG_KEYS = ("robot_collision", "obstacle_collision", "in_obstacle_area")
VALUE_KEYS = ("goal_distance", "formation_error")


class FormationEnv(EnvBase):
    """Leader-follower formation through circular obstacles (Zhou et al. 2023), ``num_envs`` copies.

    One agent group ``"agents"`` of N robots (index 0 the leader): ``("agents", "observation")``
    ``[B, N, D]``, ``("agents", "action")`` ``[B, N, 2]`` in [-1, 1], ``("agents", "reward")``
    ``[B, N, 1]``; root ``done``/``terminated``/``truncated`` ``[B, 1]``; the world under ``"state"``
    and the per-step diagnostics (reference.md, Metrics) at the root. Actions may require grad (a policy called
    outside ``torch.no_grad()``): the step detaches them, the world is not differentiable.

    ``compile_physics=True`` runs the step's tensor program (dynamics, rewards, observations) through
    ``torch.compile``: faster per step at large B on CPU, after a compilation of about 30 s on the
    first step (``benchmarks/README.md`` has the numbers). TorchRL's own ``compile=`` argument,
    which compiles all of ``step_and_maybe_reset``, works too.
    """

    def __init__(
        self,
        num_envs: int = 1,
        *,
        config: EnvConfig | dict | None = None,
        device: torch.device | str = "cpu",
        seed: int | None = None,
        compile_physics: bool = False,
        start_anywhere: float = 0.0,
        start_team: bool = False,
    ):
        if not isinstance(num_envs, int) or isinstance(num_envs, bool) or num_envs < 1:
            raise ValueError(f"num_envs = {num_envs!r} is invalid: must be an integer >= 1")
        cfg = config if isinstance(config, EnvConfig) else EnvConfig.from_dict(config or {})
        cfg.validate()
        if not (isinstance(start_anywhere, int | float) and 0 <= start_anywhere <= 1):
            raise ValueError(f"start_anywhere = {start_anywhere!r} is invalid: must be a number in [0, 1]")
        self.start_anywhere = float(start_anywhere)
        self.start_team = bool(start_team)  # those starts move the whole start square, not each robot
        super().__init__(device=device, batch_size=torch.Size([num_envs]))
        self.config = cfg
        self.num_envs = b = num_envs
        n, m, d = cfg.num_robots, cfg.num_obstacles, cfg.obs_dim
        self._make_specs(b, n, m, d)
        self._geom = Geometry.build(cfg, self.device)
        self._obs_index = world.observation_index(n, m, self.device, cfg.observe_velocities,
                                                   cfg.observe_distance_errors)
        self._advance = torch.compile(self._advance_eager) if compile_physics else self._advance_eager
        self._generator = torch.Generator(device=self.device)
        self._generator.manual_seed(int(torch.randint(2**62, ())) if seed is None else seed)
        # world state, batch-last ([2, N, B] positions ...); sampling every copy now also proves
        # the layout is feasible before any compute is spent
        self._world: dict[str, torch.Tensor] = {}
        self._fixed: dict[str, torch.Tensor] = {}  # goal and obstacles, batch-first, as reported
        self._steps = torch.zeros(b, dtype=torch.int64, device=self.device)
        self._place(None, world.sample_scenarios(b, cfg, self._generator, self.device, self.start_anywhere,
                                                            self.start_team))

    # ------------------------------------------------------------------ specs
    def _make_specs(self, b: int, n: int, m: int, d: int) -> None:
        dev = self.device
        flag = Categorical(2, (b, 1), dtype=torch.bool, device=dev)
        value = Unbounded((b, 1), device=dev)
        self.full_observation_spec = Composite(
            agents=Composite(observation=Unbounded((b, n, d), device=dev), shape=(b, n)),
            state=Composite(
                positions=Unbounded((b, n, 2), device=dev),
                velocities=Unbounded((b, n, 2), device=dev),
                goal=Unbounded((b, 2), device=dev),
                obstacle_centers=Unbounded((b, m, 2), device=dev),
                obstacle_radii=Unbounded((b, m), device=dev),
                shape=(b,),
            ),
            **{k: flag.clone() for k in FLAG_KEYS},
            **{k: value.clone() for k in VALUE_KEYS},
            shape=(b,),
        )
        self.full_action_spec = Composite(
            agents=Composite(action=Bounded(-1.0, 1.0, (b, n, 2), device=dev), shape=(b, n)), shape=(b,)
        )
        self.full_reward_spec = Composite(
            agents=Composite(reward=Unbounded((b, n, 1), device=dev), shape=(b, n)), shape=(b,)
        )
        self.full_done_spec = Composite(
            done=flag.clone(), terminated=flag.clone(), truncated=flag.clone(), shape=(b,)
        )

    # ------------------------------------------------------------------ core
    def _place(self, idx: torch.Tensor | None, fresh: dict[str, torch.Tensor]) -> None:
        """Install freshly sampled scenarios (batch-first) in copies ``idx`` (all when None)."""
        vel = fresh.get("velocities", torch.zeros_like(fresh["positions"]))  # at rest unless given
        last = {  # batch-last views of the fresh values
            "pos": fresh["positions"].permute(2, 1, 0),
            "vel": vel.permute(2, 1, 0),
            "goal": fresh["goal"].T,
            "centers": fresh["obstacle_centers"].permute(2, 1, 0),
            "radii": fresh["obstacle_radii"].T,
        }
        fixed = ("goal", "obstacle_centers", "obstacle_radii")
        if idx is None:
            self._world = {k: v.contiguous() for k, v in last.items()}
            self._fixed = {k: fresh[k] for k in fixed}
            self._steps.zero_()
            return
        for k, v in last.items():
            self._world[k] = self._world[k].index_copy(-1, idx, v)
        # out of place: earlier outputs hold these tensors
        self._fixed = {k: self._fixed[k].index_copy(0, idx, fresh[k]) for k in fixed}
        self._steps.index_fill_(0, idx, 0)

    def _measure(self, pos, vel, goal, centers, radii, prev_pos=None) -> dict[str, torch.Tensor]:
        """Observation, reward and diagnostics of a world given batch-last, returned batch-first."""
        q = step_quantities(pos, vel, goal, centers, radii, self._geom, self.config, prev_pos)
        obs = world.observe(pos, vel, q, self._obs_index)  # [B, N, D]
        if self.config.relative_positions:
            obs = world.make_relative(obs, self.config.observe_velocities)
        return {
            "observation": obs,
            "reward": q["reward"].T.unsqueeze(-1).contiguous(),  # [B, N, 1]
            "positions": pos.permute(2, 1, 0).contiguous(),  # [B, N, 2]
            "velocities": vel.permute(2, 1, 0).contiguous(),
            "robot_collision": q["robot_collision"].unsqueeze(-1),  # [B, 1]
            "obstacle_collision": q["obstacle_collision"].unsqueeze(-1),
            "in_obstacle_area": q["in_area"].unsqueeze(-1),
            "goal_distance": q["goal_distance"].unsqueeze(-1),
            "formation_error": q["formation_error"].unsqueeze(-1),
        }

    def _advance_eager(self, pos, vel, action, goal, centers, radii):
        """Integrate one step and measure the new world: the whole per-step tensor program."""
        prev = pos
        pos, vel = world.integrate(pos, vel, action.clamp(-1.0, 1.0).permute(2, 1, 0), self.config)
        return pos, vel, self._measure(pos, vel, goal, centers, radii, prev)

    def _pack(self, m: dict[str, torch.Tensor], rewards: bool) -> TensorDict:
        b, n = self.num_envs, self.config.num_robots
        agents = {"observation": m["observation"]}
        if rewards:
            agents["reward"] = m["reward"]
        out = {
            "agents": TensorDict(agents, batch_size=(b, n), device=self.device),
            "state": TensorDict({"positions": m["positions"], "velocities": m["velocities"], **self._fixed},
                                batch_size=(b,), device=self.device),
            **{k: m[k] for k in FLAG_KEYS + VALUE_KEYS},
        }
        return TensorDict(out, batch_size=(b,), device=self.device)

    def _observe(self, rewards: bool) -> TensorDict:
        w = self._world
        return self._pack(self._measure(w["pos"], w["vel"], w["goal"], w["centers"], w["radii"]), rewards)

    def _step(self, tensordict: TensorDictBase) -> TensorDictBase:
        w = self._world
        # the world does not backpropagate: actions that carry gradients (a policy outside no_grad) are detached
        action = tensordict.get(("agents", "action")).detach()
        w["pos"], w["vel"], measured = self._advance(w["pos"], w["vel"], action, w["goal"], w["centers"], w["radii"])
        self._steps += 1
        out = self._pack(measured, rewards=True)
        truncated = (self._steps >= self.config.max_steps).unsqueeze(-1)  # [B, 1]
        out.set("truncated", truncated)
        out.set("terminated", torch.zeros_like(truncated))
        out.set("done", truncated.clone())
        return out

    def _reset(self, tensordict: TensorDictBase | None = None, **kwargs) -> TensorDictBase:
        idx = None  # every copy
        if tensordict is not None and "_reset" in tensordict.keys():
            idx = tensordict.get("_reset").reshape(self.num_envs).nonzero().squeeze(-1)
        count = self.num_envs if idx is None else idx.numel()
        if count:
            self._place(idx, world.sample_scenarios(count, self.config, self._generator, self.device,
                                                          self.start_anywhere, self.start_team))
        out = self._observe(rewards=False)
        done = torch.zeros(self.num_envs, 1, dtype=torch.bool, device=self.device)
        out.set("done", done)
        out.set("terminated", done.clone())
        out.set("truncated", done.clone())
        return out

    def rand_action(self, tensordict: TensorDictBase | None = None) -> TensorDictBase:
        """Uniform random actions in [-1, 1] from torch's global RNG, as ``full_action_spec.rand()``
        would draw them, with one ``torch.rand`` instead of the generic spec sampler (2-3x cheaper)."""
        action = torch.rand(self.num_envs, self.config.num_robots, 2, device=self.device).mul_(2.0).sub_(1.0)
        if tensordict is None:
            tensordict = TensorDict(batch_size=self.batch_size, device=self.device)
        tensordict.set(("agents", "action"), action)
        return tensordict

    def rng_state(self) -> torch.Tensor:
        """The scenario generator's state (checkpoints save it, so a resumed run samples the same scenarios)."""
        return self._generator.get_state()

    def set_rng_state(self, state: torch.Tensor) -> None:
        self._generator.set_state(state)

    def _set_seed(self, seed: int | None) -> None:
        if seed is not None:
            self._generator.manual_seed(seed)

    # ------------------------------------------------------------------ views
    def world_state(self) -> TensorDict:
        """The current world state of every copy, batch-first (``positions`` ``[B, N, 2]`` ...)."""
        return self._observe(rewards=False)["state"]

    def set_world_state(self, **state) -> TensorDict:
        """Put the world in a known state (tests, scripted scenarios); returns its observation.

        Keyword arguments are the ``("state", ...)`` keys, batch-first, broadcast to every copy;
        ``steps`` sets the step counter. Keys left out keep their value.
        """
        current = self.world_state().to_dict()
        steps = state.pop("steps", None)
        unknown = sorted(set(state) - set(STATE_KEYS))
        if unknown:
            raise ValueError(f"set_world_state: unknown key {unknown[0]!r}; allowed: {', '.join(STATE_KEYS)}")
        for k, v in state.items():
            current[k] = torch.as_tensor(v, dtype=torch.float32, device=self.device).expand_as(current[k]).clone()
        kept = self._steps.clone()
        self._place(None, current)
        self._steps = kept if steps is None else torch.as_tensor(steps, device=self.device).expand_as(kept).clone()
        return self._observe(rewards=False)

    def relabel_goal(self, batch: TensorDictBase, goal: torch.Tensor) -> TensorDictBase:
        """``batch`` (steps of this env, any batch shape ``S``) as if the leader's goal had been ``goal``
        ``[*S, 2]``: observations, next observations and rewards measured again from the stored world
        states, under the same reward (hindsight goals, ``algo.her``; ours). The world states, actions
        and flags are shared with ``batch``, not copied; the goal-dependent diagnostics are not redone."""
        shape, n = batch.batch_size, self.config.num_robots

        def last(key: tuple[str, ...], inner: int) -> torch.Tensor:  # batch-first [*S, ..., 2] -> batch-last
            x = batch.get(key)
            return x.flatten(0, len(shape) - 1).permute(*range(inner, -1, -1))

        g = goal.reshape(-1, 2).T
        centers, radii = last(("state", "obstacle_centers"), 2), last(("state", "obstacle_radii"), 1)
        pos0, pos1 = last(("state", "positions"), 2), last(("next", "state", "positions"), 2)
        before = self._measure(pos0, last(("state", "velocities"), 2), g, centers, radii)
        after = self._measure(pos1, last(("next", "state", "velocities"), 2), g, centers, radii, prev_pos=pos0)
        out = batch.clone(recurse=False)
        out.set(("agents", "observation"), before["observation"].reshape(*shape, n, -1))
        out.set(("next", "agents", "observation"), after["observation"].reshape(*shape, n, -1))
        out.set(("next", "agents", "reward"), after["reward"].reshape(*shape, n, 1))
        for key in (("state", "goal"), ("next", "state", "goal")):
            out.set(key, goal.expand_as(batch.get(key)))
        return out

    def render(self, index: int = 0, **kwargs) -> np.ndarray:
        """RGB array ``[H, W, 3]`` of copy ``index`` in its current state."""
        from formation_rl.envs.render import render_state

        return render_state(self.world_state()[index], self.config, **kwargs)

"""PettingZoo ParallelEnv: red against blue, every robot an agent (1v1 default, 2v2 an option).

    from sim.parallel_env import parallel_env
    env = parallel_env()                                          # red_0 vs blue_0
    env = parallel_env(world={"red": ["24in", "15in"], "blue": ["24in", "15in"]})   # 2v2
    obs, infos = env.reset(seed=1)
    actions = {a: env.action_space(a).sample() for a in env.agents}
    obs, rewards, terms, truncs, infos = env.step(actions)

Agents are named <alliance>_<slot>. Every agent observes the alliance-symmetric stacked vector of
jetson.autonomy.spec, so one policy can play either side (self-play). The configuration is the
Gymnasium env's (sim.match.EnvConfig) minus agent_alliance and opponent. A pin (with end_on_pin)
or the end of the match ends the episode for every agent at once.
"""

from __future__ import annotations

import contextlib
from typing import Any

import gymnasium as gym
import numpy as np
import pybullet as p
from pettingzoo import ParallelEnv

from jetson.autonomy.spec import observation_bounds
from sim.errors import ConfigError
from sim.match import EnvConfig, MatchCore, make_config
from sim.render import top_down
from sim.world.physics import World


class TippingPointParallelEnv(ParallelEnv):
    metadata = {
        "name": "pete_tipping_point_v0",
        "render_modes": ["rgb_array"],
        "render_fps": 12,
        "is_parallelizable": True,
    }

    def __init__(
        self,
        config: EnvConfig | dict[str, Any] | None = None,
        render_mode: str | None = None,
        **overrides: Any,
    ) -> None:
        self.config = make_config(config, **overrides)
        if render_mode not in (None, "rgb_array"):
            raise ConfigError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        self.render_mode = render_mode
        self.client = p.connect(p.DIRECT)
        self.core = MatchCore(self.config, client=self.client)
        self.possible_agents = [
            f"{a}_{self._slot(i)}" for i, (a, _) in enumerate(self.world.lineup)
        ]
        self._index = {name: i for i, name in enumerate(self.possible_agents)}
        self.agents: list[str] = []
        low, high = observation_bounds(self.core.spec)
        self._obs_space = {
            a: gym.spaces.Box(low, high, dtype=np.float32) for a in self.possible_agents
        }
        n = self.config.action_size
        self._act_space = {
            a: gym.spaces.Box(-1.0, 1.0, shape=(n,), dtype=np.float32) for a in self.possible_agents
        }
        self.max_cycles = self.config.max_steps
        self._steps = 0
        self._rng = np.random.default_rng()

    def _slot(self, index: int) -> int:
        alliance = self.world.lineup[index][0]
        return sum(1 for a, _ in self.world.lineup[:index] if a == alliance)

    @property
    def world(self) -> World:
        return self.core.world

    # The same space object every call (the API requires it; seeding relies on it).
    def observation_space(self, agent: str) -> gym.spaces.Box:
        return self._obs_space[agent]

    def action_space(self, agent: str) -> gym.spaces.Box:
        return self._act_space[agent]

    def reset(
        self, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, np.ndarray], dict[str, dict[str, Any]]]:
        if seed is not None:
            self._rng = np.random.default_rng(seed)
        obs = self.core.reset(self._rng)
        self.agents = list(self.possible_agents)
        self._steps = 0
        return (
            {a: obs[self._index[a]] for a in self.agents},
            {a: self.core.info(self._index[a]) for a in self.agents},
        )

    def step(
        self, actions: dict[str, Any]
    ) -> tuple[
        dict[str, np.ndarray],
        dict[str, float],
        dict[str, bool],
        dict[str, bool],
        dict[str, dict[str, Any]],
    ]:
        if not self.agents:
            raise RuntimeError("step() after the episode ended: call reset()")
        unknown = set(actions) - set(self.agents)
        if unknown:
            raise ValueError(f"actions for agents not in play: {sorted(unknown)}")
        commands = []
        for i, name in enumerate(self.possible_agents):
            # A live agent without an action stands still (the protocol's stop).
            commands.append(
                self.core.command(i, actions[name])
                if name in actions
                else self.core.command(i, np.zeros(self.config.action_size))
            )
        results, ended, _ = self.core.step(commands)
        self._steps += 1
        truncated = bool(
            not ended and self.max_cycles is not None and self._steps >= self.max_cycles
        )
        live = self.agents
        obs = {a: results[self._index[a]].observation for a in live}
        rewards = {a: results[self._index[a]].reward for a in live}
        terms = dict.fromkeys(live, bool(ended))
        truncs = dict.fromkeys(live, truncated)
        infos = {a: results[self._index[a]].info for a in live}
        if ended or truncated:
            self.agents = []
        return obs, rewards, terms, truncs, infos

    def render(self) -> np.ndarray | None:
        if self.render_mode != "rgb_array":
            return None
        return top_down(self.world)

    def state(self) -> np.ndarray:
        """A global view for centralised critics: every robot's pose and load, and the rings."""
        w = self.world
        robots = [
            (r.x, r.y, np.cos(np.radians(r.heading)), np.sin(np.radians(r.heading)), r.held)
            for r in w.robots
        ]
        rings = np.column_stack([w.ring_xy, w.ring_state == 0]).ravel()
        return np.concatenate([np.asarray(robots, dtype=np.float64).ravel(), rings]).astype(
            np.float32
        )

    def close(self) -> None:
        if self.client >= 0:
            with contextlib.suppress(p.error):
                p.disconnect(physicsClientId=self.client)
            self.client = -1


def parallel_env(**config: Any) -> TippingPointParallelEnv:
    """Make the environment, as PettingZoo's own `parallel_env(**kwargs)` constructors do."""
    render_mode = config.pop("render_mode", None)
    return TippingPointParallelEnv(config or None, render_mode=render_mode)

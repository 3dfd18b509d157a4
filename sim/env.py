"""Gymnasium environment: one learning robot on the Tipping Point field.

    import gymnasium as gym
    import sim.env  # registers the id
    env = gym.make("pete/TippingPoint-v0")                         # vs the scripted chaser
    env = gym.make("pete/TippingPoint-v0", opponent="none", world={"fidelity": "high"})
    env = sim.env.TippingPointEnv(opponent="policy", opponent_policy=lambda obs: my_net(obs))

Observation: jetson.autonomy.spec's stacked vector (float32, ObservationSpec in `env.spec_obs`).
Action: [linear, angular] in [-1, 1] (scaled to the robot's limits; angular > 0 turns clockwise),
plus [intake] / [clamp] when configured; with `skills`, one score per skill
(jetson/autonomy/skills.py).
Reward: the sum of the weighted components; each component is in info["reward_components"] (this
step) and info["episode_reward_components"].
The episode terminates when the match ends (or on a pin, when end_on_pin) and is truncated at
max_steps. Every random draw (start jitter, GPS and observation noise, the side when
agent_alliance="random") comes from self.np_random, so a seed fixes the whole episode.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from dataclasses import replace
from typing import Any

import gymnasium as gym
import numpy as np
import pybullet as p

from jetson.autonomy.geometry import other_alliance
from jetson.autonomy.spec import ObservationSpec, observation_bounds
from sim.baselines.scripted import GreedyChaser
from sim.errors import ConfigError
from sim.match import EnvConfig, MatchCore, make_config
from sim.render import top_down
from sim.world.physics import World

ENV_ID = "pete/TippingPoint-v0"

Policy = Callable[[np.ndarray], Any]


class TippingPointEnv(gym.Env[np.ndarray, np.ndarray]):
    metadata = {"render_modes": ["rgb_array"], "render_fps": 12}

    def __init__(
        self,
        config: EnvConfig | dict[str, Any] | None = None,
        render_mode: str | None = None,
        opponent_policy: Policy | None = None,
        **overrides: Any,
    ) -> None:
        self.config = make_config(config, **overrides)
        if render_mode not in (None, "rgb_array"):
            raise ConfigError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        self.render_mode = render_mode
        if self.config.opponent == "policy" and opponent_policy is None:
            raise ConfigError("opponent='policy' needs opponent_policy (obs -> action)")
        self.opponent_policy = opponent_policy
        self.client = p.connect(p.DIRECT)
        alliances = (
            ("red", "blue")
            if self.config.agent_alliance == "random"
            else (self.config.agent_alliance,)
        )
        self._cores: dict[str, MatchCore] = {}
        for alliance in alliances:
            wc = self.config.world
            if not getattr(wc, alliance):
                raise ConfigError(f"the agent plays {alliance} but world.{alliance} has no robot")
            if self.config.opponent == "none":
                wc = replace(wc, **{other_alliance(alliance): ()})
            self._cores[alliance] = MatchCore(self.config, wc, client=self.client)
        first = next(iter(self._cores.values()))
        self.spec_obs: ObservationSpec = first.spec
        low, high = observation_bounds(self.spec_obs)
        self.observation_space = gym.spaces.Box(low, high, dtype=np.float32)
        n = self.config.action_size
        self.action_space = gym.spaces.Box(-1.0, 1.0, shape=(n,), dtype=np.float32)
        self._core = first
        self._agent = 0
        self._others: dict[int, GreedyChaser | None] = {}
        self._obs: list[np.ndarray] = []
        self._steps = 0

    @property
    def core(self) -> MatchCore:
        return self._core

    @property
    def world(self) -> World:
        return self._core.world

    @property
    def agent_index(self) -> int:
        return self._agent

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        if self.config.agent_alliance == "random":
            alliance = "red" if self.np_random.random() < 0.5 else "blue"
        else:
            alliance = self.config.agent_alliance
        self._core = self._cores[alliance]
        self._obs = self._core.reset(self.np_random)
        lineup = self._core.world.lineup
        self._agent = next(i for i, (a, _) in enumerate(lineup) if a == alliance)
        self._others = {}
        for i, (a, _) in enumerate(lineup):
            if i == self._agent:
                continue
            plays_policy = self.config.opponent == "policy" and a != alliance
            self._others[i] = None if plays_policy else GreedyChaser(i)
        self._steps = 0
        return self._obs[self._agent], self._core.info(self._agent)

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        core = self._core
        world = core.world
        commands = []
        for i in range(len(world.robots)):
            if i == self._agent:
                commands.append(core.command(i, action))
            elif self._others[i] is None:
                assert self.opponent_policy is not None
                commands.append(core.command(i, self.opponent_policy(self._obs[i])))
            else:
                chaser = self._others[i]
                assert chaser is not None
                commands.append(chaser.act(world))
        results, ended, _ = core.step(commands)
        self._obs = [r.observation for r in results]
        self._steps += 1
        me = results[self._agent]
        limit = self.config.max_steps
        truncated = bool(limit is not None and self._steps >= limit and not ended)
        return me.observation, me.reward, bool(ended), truncated, me.info

    def render(self) -> np.ndarray | None:
        if self.render_mode != "rgb_array":
            return None
        return top_down(self._core.world)

    def close(self) -> None:
        if self.client >= 0:
            with contextlib.suppress(p.error):
                p.disconnect(physicsClientId=self.client)
            self.client = -1


def register() -> None:
    if ENV_ID not in gym.registry:
        gym.register(id=ENV_ID, entry_point="sim.env:TippingPointEnv")


register()

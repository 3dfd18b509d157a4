"""Self-play as Unity ML-Agents runs it: a pool of past snapshots, opponent swaps, ELO.

  - Every `save_steps` learner steps the current weights become a snapshot, rated with the
    learner's ELO at that moment.
  - Every `swap_steps` a new opponent is drawn: with probability
    `play_against_latest_model_ratio` a copy of the current weights ("latest"), otherwise a
    uniform pick among the last `window` snapshots. The opponent stays frozen until the next swap.
  - After every match against a pool opponent, both ratings move by K (result - expected),
    expected = 1 / (1 + 10^((R_opponent - R_learner) / 400)): the learner's rises only by
    beating its own past.

The pool stores weights as opaque objects (the trainer's state dicts): this module has no torch.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from sim.errors import ConfigError


@dataclass(frozen=True)
class SelfPlayConfig:
    save_steps: int = 10_000
    swap_steps: int = 10_000
    window: int = 10
    play_against_latest_model_ratio: float = 0.5
    initial_elo: float = 1200.0
    elo_k: float = 16.0

    def __post_init__(self) -> None:
        if self.save_steps < 1 or self.swap_steps < 1 or self.window < 1:
            raise ConfigError("selfplay: save_steps, swap_steps and window must be >= 1")
        if not 0.0 <= self.play_against_latest_model_ratio <= 1.0:
            raise ConfigError("selfplay.play_against_latest_model_ratio must be within [0, 1]")
        if self.elo_k <= 0:
            raise ConfigError("selfplay.elo_k must be positive")


def elo_expected(rating: float, opponent: float) -> float:
    return 1.0 / (1.0 + 10.0 ** ((opponent - rating) / 400.0))


@dataclass
class Snapshot:
    id: int
    step: int
    elo: float
    weights: Any
    latest: bool = False  # a copy of the current weights taken at a swap, not a saved snapshot


class OpponentPool:
    def __init__(self, config: SelfPlayConfig, seed: int) -> None:
        self.config = config
        self.rng = np.random.default_rng(seed)
        self.learner_elo = config.initial_elo
        self.snapshots: list[Snapshot] = []  # the window, oldest first
        self.current: Snapshot | None = None
        self._next_id = 0
        self._last_save = 0
        self._last_swap = 0
        self._live: dict[int, Snapshot] = {}  # opponents some match may still be playing

    def _new(self, step: int, weights: Any, latest: bool) -> Snapshot:
        snap = Snapshot(self._next_id, step, self.learner_elo, weights, latest)
        self._next_id += 1
        return snap

    def start(self, step: int, weights: Any) -> Snapshot:
        """The first opponent: the initial weights, saved as the first snapshot."""
        first = self._new(step, weights, latest=False)
        self.snapshots = [first]
        self.current = first
        self._live = {first.id: first}
        self._last_save = self._last_swap = step
        return first

    def update(self, step: int, weights_fn: Any) -> Snapshot | None:
        """Save and swap as due at learner step `step`; returns the new opponent after a swap.
        weights_fn() copies the current weights (called only when needed)."""
        c = self.config
        if step - self._last_save >= c.save_steps:
            self._last_save = step
            self.snapshots.append(self._new(step, weights_fn(), latest=False))
            self.snapshots = self.snapshots[-c.window :]
        if step - self._last_swap < c.swap_steps:
            return None
        self._last_swap = step
        if self.rng.random() < c.play_against_latest_model_ratio or not self.snapshots:
            snap = self._new(step, weights_fn(), latest=True)
        else:
            snap = self.snapshots[int(self.rng.integers(len(self.snapshots)))]
        self.current = snap
        self._live[snap.id] = snap
        return snap

    def get(self, snapshot_id: int) -> Snapshot:
        return self._live[snapshot_id]

    def retire(self, in_use: set[int]) -> None:
        """Drop opponents no match plays any more (the current one always stays)."""
        keep = set(in_use)
        if self.current is not None:
            keep.add(self.current.id)
        self._live = {i: s for i, s in self._live.items() if i in keep}

    def record(self, snapshot_id: int, result: float) -> None:
        """A finished match against snapshot `snapshot_id`: 1 win, 0.5 draw, 0 loss."""
        snap = self._live.get(snapshot_id)
        if snap is None:
            snap = next((s for s in self.snapshots if s.id == snapshot_id), None)
        if snap is None:
            return
        delta = self.config.elo_k * (result - elo_expected(self.learner_elo, snap.elo))
        self.learner_elo += delta
        snap.elo -= delta

    def state_dict(self) -> dict[str, Any]:
        def dump(s: Snapshot) -> dict[str, Any]:
            return {
                "id": s.id,
                "step": s.step,
                "elo": s.elo,
                "weights": s.weights,
                "latest": s.latest,
            }

        return {
            "learner_elo": self.learner_elo,
            "snapshots": [dump(s) for s in self.snapshots],
            "current": None if self.current is None else dump(self.current),
            "next_id": self._next_id,
            "last_save": self._last_save,
            "last_swap": self._last_swap,
            "rng": self.rng.bit_generator.state,
        }

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.learner_elo = float(state["learner_elo"])
        self.snapshots = [Snapshot(**s) for s in state["snapshots"]]
        cur = state["current"]
        self.current = None
        if cur is not None:
            self.current = next((s for s in self.snapshots if s.id == cur["id"]), None) or Snapshot(
                **cur
            )
        self._next_id = int(state["next_id"])
        self._last_save = int(state["last_save"])
        self._last_swap = int(state["last_swap"])
        self.rng.bit_generator.state = state["rng"]
        self._live = {} if self.current is None else {self.current.id: self.current}

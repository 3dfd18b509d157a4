"""Self-play bookkeeping as ML-Agents does it: snapshots, window, swaps, ELO."""

from __future__ import annotations

import pytest

from sim.errors import ConfigError
from sim.training.selfplay import OpponentPool, SelfPlayConfig, elo_expected


def test_elo_expectation_and_update() -> None:
    assert elo_expected(1200, 1200) == pytest.approx(0.5)
    assert elo_expected(1600, 1200) == pytest.approx(1 / (1 + 10**-1))
    pool = OpponentPool(SelfPlayConfig(elo_k=16), seed=0)
    first = pool.start(0, "w0")
    pool.record(first.id, 1.0)  # a win against an equal: +K/2 for the learner
    assert pool.learner_elo == pytest.approx(1208.0)
    assert first.elo == pytest.approx(1192.0)
    pool.record(first.id, 0.5)  # a draw against a weaker one costs the learner a little
    assert pool.learner_elo < 1208.0


def test_snapshots_every_save_steps_within_the_window() -> None:
    cfg = SelfPlayConfig(save_steps=100, swap_steps=10_000, window=3)
    pool = OpponentPool(cfg, seed=0)
    pool.start(0, "w0")
    for step in range(50, 1001, 50):
        pool.update(step, lambda s=step: f"w{s}")
    assert [s.weights for s in pool.snapshots] == ["w800", "w900", "w1000"]
    assert [s.step for s in pool.snapshots] == [800, 900, 1000]


def test_swap_draws_latest_or_the_window_by_ratio() -> None:
    always_latest = OpponentPool(
        SelfPlayConfig(save_steps=50, swap_steps=100, play_against_latest_model_ratio=1.0), 0
    )
    always_latest.start(0, "w0")
    swaps = [always_latest.update(s, lambda s=s: f"w{s}") for s in range(50, 501, 50)]
    drawn = [x for x in swaps if x is not None]
    assert len(drawn) == 5, "a swap every 100 steps"
    assert all(x.latest and x.weights == f"w{x.step}" for x in drawn)

    never_latest = OpponentPool(
        SelfPlayConfig(save_steps=50, swap_steps=100, play_against_latest_model_ratio=0.0), 0
    )
    never_latest.start(0, "w0")
    ids = set()
    for s in range(50, 5001, 50):
        new = never_latest.update(s, lambda s=s: f"w{s}")
        if new is not None:
            assert not new.latest
            assert new in never_latest.snapshots, "drawn from the window"
            ids.add(new.id)
    assert len(ids) > 3, "different past snapshots get drawn"


def test_state_round_trip_and_retire() -> None:
    pool = OpponentPool(SelfPlayConfig(save_steps=10, swap_steps=20), seed=5)
    pool.start(0, "w0")
    for s in range(10, 101, 10):
        pool.update(s, lambda s=s: f"w{s}")
    assert pool.current is not None
    pool.record(pool.current.id, 1.0)
    copy = OpponentPool(SelfPlayConfig(save_steps=10, swap_steps=20), seed=99)
    copy.load_state_dict(pool.state_dict())
    assert copy.learner_elo == pool.learner_elo
    assert [s.id for s in copy.snapshots] == [s.id for s in pool.snapshots]
    assert copy.current is not None and copy.current.id == pool.current.id
    # Same random state: the next draws agree.
    a = [pool.update(s, lambda: "x") for s in range(110, 300, 10)]
    b = [copy.update(s, lambda: "x") for s in range(110, 300, 10)]
    assert [x.id if x else None for x in a] == [x.id if x else None for x in b]
    pool.retire(set())
    assert pool.get(pool.current.id) is pool.current  # type: ignore[union-attr]


def test_bad_selfplay_config_is_named() -> None:
    with pytest.raises(ConfigError, match="play_against_latest_model_ratio"):
        SelfPlayConfig(play_against_latest_model_ratio=1.5)
    with pytest.raises(ConfigError, match="save_steps"):
        SelfPlayConfig(save_steps=0)

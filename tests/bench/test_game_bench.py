"""bench.game's summary: the win rate counts a draw half, and the win rate without the foul
credit takes the credit for the other side's platform fouls out of the scripted alliance's
score (a match won only through that credit is a loss there)."""

from __future__ import annotations

import pytest

from bench.game import GameRecord, summarise

ZERO = {
    "rings_high": 0.0,
    "rings_low": 0.0,
    "rings_base": 0.0,
    "goals_in_zone": 0.0,
    "goals_elevated": 0.0,
    "robots_elevated": 0.0,
    "foul_credit": 0.0,
    "autonomous_bonus": 0.0,
}


def record(seed: int, ours: int, theirs: int, credit: float) -> GameRecord:
    mine = dict(ZERO, foul_credit=credit, goals_in_zone=ours - credit)
    return GameRecord(
        seed=seed,
        opponent="ring_race",
        ours="red",
        score={"red": ours, "blue": theirs},
        elements={"red": mine, "blue": dict(ZERO, goals_in_zone=float(theirs))},
        fouls={"red": {}, "blue": {"platform_protection": int(credit // 30)}},
        balanced_both_up={"red": True, "blue": False},
        awp={"red": False, "blue": False},
    )


def test_the_win_rate_with_and_without_the_foul_credit() -> None:
    records = [
        record(0, 200, 100, 0.0),  # won on its own
        record(1, 220, 150, 90.0),  # won only through the credit: 130 to 150 without it
        record(2, 150, 150, 0.0),  # a draw
    ]
    m = summarise(records, "training").metrics
    assert m["vs_ring_race_win_rate"] == pytest.approx(2.5 / 3)
    assert m["vs_ring_race_win_rate_without_foul_credit"] == pytest.approx(1.5 / 3)
    assert m["vs_ring_race_score_ours_without_foul_credit"] == pytest.approx((200 + 130 + 150) / 3)
    assert m["vs_ring_race_fouls_theirs_platform_protection"] == pytest.approx(1.0)


def test_the_platform_contact_at_the_end_is_reported_by_side() -> None:
    """A robot touching the opposing platform as the match ends (<SG3>: a Disqualification) is
    a share of matches by side; it does not change the win rate (points decide it)."""
    records = [record(0, 200, 100, 0.0), record(1, 100, 200, 0.0)]
    records[0].platform_contact_at_end = {"red": False, "blue": True}
    m = summarise(records, "training").metrics
    assert m["vs_ring_race_theirs_platform_contact_at_end_rate"] == pytest.approx(0.5)
    assert m["vs_ring_race_ours_platform_contact_at_end_rate"] == pytest.approx(0.0)
    assert m["vs_ring_race_win_rate"] == pytest.approx(0.5)


def test_the_climb_only_matches_are_their_own_rows_and_leave_the_targets_alone() -> None:
    """Matches played with the steal off (c) are summarised as vs_ring_race_climb_only_*; the
    default alliance's rows, which carry the targets, never count them."""
    records = [record(0, 200, 100, 0.0), record(1, 100, 200, 0.0)]
    climb = [record(2, 250, 90, 0.0), record(3, 240, 80, 0.0), record(4, 90, 100, 0.0)]
    for g in climb:
        g.climb_only = True
        g.balanced_both_up = {"red": False, "blue": False}
    m = summarise(records + climb, "training").metrics
    assert m["vs_ring_race_win_rate"] == pytest.approx(0.5)
    assert m["vs_ring_race_balanced_both_elevated_rate"] == pytest.approx(1.0)
    assert m["vs_ring_race_climb_only_win_rate"] == pytest.approx(2 / 3)
    assert m["vs_ring_race_climb_only_score_ours"] == pytest.approx((250 + 240 + 90) / 3)
    assert m["vs_ring_race_climb_only_balanced_both_elevated_rate"] == pytest.approx(0.0)
    assert m["seeds"] == 2

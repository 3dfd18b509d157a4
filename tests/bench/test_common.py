"""The benchmark result format every bench/NAME.py writes."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from bench.common import Result


def test_result_json_has_the_documented_shape(tmp_path: Path) -> None:
    r = Result("example")
    r.add("rate", 250_000.0)
    r.add("latency_ms", 7.5)
    r.add("size", 42)
    r.target("rate", 200_000, ">=")
    r.target("latency_ms", 5, "<=")
    data = json.loads(r.save(tmp_path).read_text())
    assert data["benchmark"] == "example"
    assert data["metrics"] == {"rate": 250_000.0, "latency_ms": 7.5, "size": 42}
    assert data["targets"] == {
        "rate": {"target": 200_000, "op": ">=", "met": True},
        "latency_ms": {"target": 5, "op": "<=", "met": False},
    }
    assert isinstance(data["machine"], str) and data["machine"]
    assert not r.all_met


def test_unmeasured_target_is_not_met_and_shown() -> None:
    r = Result("example")
    r.target("never", 1, ">=")
    assert r.met() == {"never": False}
    assert "(missing)" in r.table()


@pytest.mark.parametrize("bad", [float("nan"), float("inf"), True, "3"])
def test_non_numbers_are_refused(bad: object) -> None:
    with pytest.raises((TypeError, ValueError)):
        Result("x").add("m", bad)  # type: ignore[arg-type]


def test_unknown_operator_is_refused() -> None:
    with pytest.raises(ValueError, match="op"):
        Result("x").target("m", 1, "==")  # type: ignore[arg-type]


@pytest.mark.parametrize("bad", [0, -1.5, float("nan"), float("inf"), True, "3", None])
def test_binary_numbers_must_be_positive_and_finite(bad: object) -> None:
    from bench.common import positive_number

    with pytest.raises(SystemExit, match=r"bench\.x: p99 ="):
        positive_number("x", "p99", bad)
    assert positive_number("x", "p99", 2) == 2.0

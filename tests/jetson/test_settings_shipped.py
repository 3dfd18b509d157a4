"""The shipped settings load to exactly what they did before every value was type-checked
(jetson/config_check.py): the same values, of the same types (an integer stays an integer).

shipped_settings.json holds what the loader gave before the checker; a setting added since is
not in it and is not compared. After changing a shipped file or a default on purpose, write it
again: `.venv/bin/python tests/jetson/test_settings_shipped.py --write`.
tests/sim/training/test_config_shipped.py does the same for the training configs with the
helpers here.
"""

from __future__ import annotations

import json
import math
import sys
from dataclasses import fields, is_dataclass
from pathlib import Path
from typing import Any

from jetson.models import DEFAULT_POLICY
from jetson.settings import DecisionConfig, Settings

ROOT = Path(__file__).resolve().parents[2]
SNAPSHOT = Path(__file__).with_name("shipped_settings.json")


def tagged(value: Any) -> Any:
    """A JSON form of a config that keeps what JSON would blur: dataclass names, tuples apart
    from lists, dicts apart from dataclasses, and non-finite floats."""
    if is_dataclass(value) and not isinstance(value, type):
        out = {f.name: tagged(getattr(value, f.name)) for f in fields(value)}
        return {"__class__": type(value).__name__, **out}
    if isinstance(value, tuple):
        return {"__tuple__": [tagged(v) for v in value]}
    if isinstance(value, list):
        return [tagged(v) for v in value]
    if isinstance(value, dict):
        return {"__dict__": {str(k): tagged(v) for k, v in value.items()}}
    if type(value) in (bool, int, str, type(None)):
        return value
    if type(value) is float:
        return value if math.isfinite(value) else {"__float__": repr(value)}
    return {"__type__": type(value).__name__, "repr": repr(value)}


def assert_same(expected: Any, actual: Any, where: str = "$") -> None:
    """`actual` (a tagged config) holds every value of `expected` with the same type; a
    dataclass may have gained fields, a dict may not have gained keys."""
    if isinstance(expected, dict):
        assert isinstance(actual, dict), f"{where}: {actual!r}, was {expected!r}"
        if "__class__" not in expected:
            assert set(actual) == set(expected), f"{where}: keys {sorted(actual)}"
        for key, value in expected.items():
            assert key in actual, f"{where}.{key} is gone"
            assert_same(value, actual[key], f"{where}.{key}")
    elif isinstance(expected, list):
        assert isinstance(actual, list) and len(actual) == len(expected), f"{where}: {actual!r}"
        for k, (e, a) in enumerate(zip(expected, actual, strict=True)):
            assert_same(e, a, f"{where}[{k}]")
    else:
        assert type(actual) is type(expected) and actual == expected, (
            f"{where}: {actual!r} ({type(actual).__name__}), was {expected!r}"
        )


def current() -> dict[str, Any]:
    overrides = Settings().with_overrides(
        link={"port": "/dev/x", "baud": None},
        decision={"drive_phases": ("autonomous",), "valid_ms": 100, "perception_max_age_s": 0.5},
        camera={"enabled": False, "source": "unix:/tmp/s"},
        record={"dir": ""},
        log={"level": "debug", "summary": False},
    )
    decision = DecisionConfig.from_dict(
        {"drive_phases": ["driver"], "valid_ms": 300, "decision_hz": 12, "rings_held": 2}
    )
    out = {
        "pete-jetson.toml": Settings.load(ROOT / "jetson" / "deploy" / "pete-jetson.toml"),
        "defaults": Settings(),
        "overrides": overrides,
        "decision_from_dict": decision,
    }
    text = json.dumps({k: tagged(v) for k, v in out.items()}, indent=1, sort_keys=True)
    return json.loads(text.replace(json.dumps(str(DEFAULT_POLICY)), '"<DEFAULT_POLICY>"'))


def test_the_shipped_settings_load_to_the_same_values_and_types() -> None:
    assert_same(json.loads(SNAPSHOT.read_text()), current())


if __name__ == "__main__" and sys.argv[1:] == ["--write"]:
    SNAPSHOT.write_text(json.dumps(current(), indent=1, sort_keys=True) + "\n")

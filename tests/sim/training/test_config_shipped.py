"""The shipped training configs, and the evaluation scenarios, load to exactly what they did
before every value was type-checked (jetson/config_check.py): the same values, of the same types.

shipped_configs.json holds what the loaders gave before the checker (tests/jetson/
test_settings_shipped.py explains the form); a field added since is not compared. After changing
a shipped config or a default on purpose, write it again:
`.venv/bin/python tests/sim/training/test_config_shipped.py --write`.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import pytest

from tests.jetson.test_settings_shipped import assert_same, tagged

SNAPSHOT = Path(__file__).with_name("shipped_configs.json")


def current() -> dict[str, Any]:
    from sim.evaluate import SCENARIOS, eval_env
    from sim.match import make_config
    from sim.training.config import CONFIG_DIR, load_config

    configs = {}
    for path in sorted(CONFIG_DIR.glob("*.toml")):
        cfg = load_config(path)
        entry = {"config": tagged(cfg), "env": tagged(cfg.env_config())}
        for phase in cfg.phases:
            step = phase["from_step"]
            entry[f"at_step_{step}"] = tagged(cfg.at_step(step))
            entry[f"env_at_step_{step}"] = tagged(cfg.at_step(step).env_config())
        configs[path.name] = entry
    evaluation = {
        f"eval_{scenario}_{fidelity}": tagged(eval_env(scenario, fidelity))
        for scenario in sorted(SCENARIOS)
        for fidelity in ("training", "high")
    }
    mixed = make_config(
        {
            "world": {"robots": {"15in": {"ring_capacity": None}, "30in": {"mass_kg": 12}}},
            "observation": {"n_rings": 6},
            "skills": {"ring_options": 2},
        },
        reward={"ring": 1},
    )
    out = {"configs": configs, "evaluation": evaluation, "make_config_mixed": tagged(mixed)}
    return json.loads(json.dumps(out))


def test_the_shipped_configs_load_to_the_same_values_and_types() -> None:
    pytest.importorskip("torch")
    expected = json.loads(SNAPSHOT.read_text())
    now = current()
    for group in ("configs", "evaluation"):  # one added since is not compared
        for name, loaded in expected[group].items():
            assert name in now[group], f"{group}: {name} is gone"
            assert_same(loaded, now[group][name], f"{group}.{name}")
    assert_same(expected["make_config_mixed"], now["make_config_mixed"], "make_config")


if __name__ == "__main__" and sys.argv[1:] == ["--write"]:
    SNAPSHOT.write_text(json.dumps(current(), indent=1, sort_keys=True) + "\n")

"""Every training config value is checked for type and range when the file loads
(jetson/config_check.py): an error names the file, the key, what it takes and what was found,
and `pete-sim train` refuses it with one line and exit status 2 before making a run folder."""

from __future__ import annotations

import typing
from dataclasses import fields, is_dataclass
from pathlib import Path

import pytest

pytest.importorskip("torch")

from jetson import config_check
from sim import cli
from sim.errors import ConfigError
from sim.training.config import TrainConfig, load_config, parse_config

# (the file's text, what the error must say: the key, what it takes, what was found)
BAD = [
    # Did not name the key, and left an empty run folder behind.
    ('seed = "one"\n', ["seed", "integer", "string 'one'"]),
    ("total_steps = -5\n", ["total_steps", "must be >= 1", "-5"]),
    ("total_steps = 1.5e6\n", ["total_steps", "integer", "float 1500000.0"]),
    ("[ppo]\ngamma = nan\n", ["[ppo] gamma", "finite number", "nan"]),
    ("[ppo]\ngamma = -0.5\n", ["[ppo]", "gamma", "-0.5"]),
    ('[ppo]\nhidden = [128, "x"]\n', ["[ppo] hidden", "array [integer, ...]", "[128, 'x']"]),
    ('[ppo]\nactivation = "gelu"\n', ["[ppo] activation", "'tanh'", "string 'gelu'"]),
    ("[ppo]\nlearnin_rate = 1e-3\n", ["[ppo]", "unknown keys ['learnin_rate']", "learning_rate"]),
    ("ppo = 3\n", ["ppo", "expected a table", "integer 3"]),
    ("env = 3\n", ["env", "expected a table", "integer 3"]),
    ('[env.world]\ncontrol_hz = "x"\n', ["[env.world] control_hz", "number", "string 'x'"]),
    ('[env.world]\nfidelity = "low"\n', ["[env.world] fidelity", "'training'", "'low'"]),
    ('[env.world]\nred = "15in"\n', ["[env.world] red", "array", "string '15in'"]),
    ("[env.world.robots.15in]\nmass_kg = -1.0\n", ["[env.world.robots.15in] mass_kg", "-1.0"]),
    ("[env.reward]\nring = true\n", ["[env.reward] ring", "number", "boolean true"]),
    ("[env]\nskills = 3\n", ["[env] skills", "a table or none", "integer 3"]),
    ('[env.observation]\nn_rings = "x"\n', ["[env.observation] n_rings", "integer", "'x'"]),
    ('[opponents]\npool = "x"\n', ["opponents", "number", "'x'"]),
    ("[evaluation]\nmatches = 1.5\n", ["[evaluation] matches", "integer", "float 1.5"]),
    ("[imitation]\ncoef = nan\n", ["[imitation] coef", "finite number", "nan"]),
    ("phases = 3\n", ["phases", "array", "integer 3"]),
    (
        "[[phases]]\nfrom_step = 10\n[phases.opponents]\npool = 'a'\n",
        ["[phases[0]] opponents", "number", "'a'"],
    ),
    (
        "[[phases]]\nfrom_step = 10\n[phases.rollout]\nshort_share = 'a'\n",
        ["[phases[0].rollout] short_share", "number", "string 'a'"],
    ),
    (
        "[[phases]]\nfrom_step = 10\n[phases.env.world]\ncontrol_hz = -1.0\n",
        ["[phases[0]]", "[env.world] control_hz", "positive", "-1.0"],
    ),
]


@pytest.mark.parametrize(("text", "needles"), BAD, ids=[t.strip() for t, _ in BAD])
def test_a_bad_value_names_the_file_the_key_the_type_and_what_was_found(
    tmp_path: Path, text: str, needles: list[str]
) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text('name = "bad"\n' + text)
    with pytest.raises(ConfigError) as caught:
        load_config(bad)
    message = str(caught.value)
    assert message.startswith(f"{bad}: "), message
    for needle in needles:
        assert needle in message, f"{needle!r} not in {message!r}"


def test_a_checkpoints_config_is_checked_and_named_too() -> None:
    with pytest.raises(ConfigError, match=r"^checkpoint config: seed: expected integer"):
        parse_config({"seed": "one"}, "checkpoint config")
    cfg = load_config("tiny")
    assert parse_config(cfg.to_dict(), "checkpoint config") == cfg


def test_every_default_passes_its_own_check() -> None:
    """The annotations the checker reads agree with the defaults, nested tables included."""
    seen: set[type] = set()

    def walk(cls: type) -> None:
        seen.add(cls)
        hints = typing.get_type_hints(cls)
        for f in fields(cls):
            value = getattr(cls(), f.name)
            for inner in (hints[f.name], *typing.get_args(hints[f.name])):
                if is_dataclass(inner) and inner not in seen:
                    walk(inner)  # type: ignore[arg-type]
            if not is_dataclass(value):
                config_check.check_value(value, hints[f.name], f.name, ConfigError)

    walk(TrainConfig)
    walk(type(load_config("default").env_config()))
    names = {c.__name__ for c in seen}
    assert {"PPOConfig", "WorldConfig", "RobotConfig", "ObservationSpec", "SkillConfig"} <= names


def test_pete_sim_train_refuses_a_bad_config_with_one_line_and_no_run_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.chdir(tmp_path)
    bad = tmp_path / "bad.toml"
    bad.write_text('name = "bad"\nseed = "one"\n')
    assert cli.main(["train", "--config", str(bad), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"pete-sim train: {bad}: seed: expected integer, found string 'one'"]
    assert not (tmp_path / "runs").exists(), "no run folder for a config that does not load"

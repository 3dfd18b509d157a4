"""Every daemon setting is checked for type and range when loaded (jetson/config_check.py): an
error names the file or the command line, the key, what it takes and what was found, and
`pete-jetson run` refuses it with one line and exit status 2."""

from __future__ import annotations

import subprocess
import sys
import typing
from dataclasses import fields, is_dataclass
from pathlib import Path

import pytest

from jetson import config_check
from jetson.errors import SettingsError
from jetson.settings import DecisionConfig, Settings

ROOT = Path(__file__).resolve().parents[2]

# (the file's text, what the error must say: the key, what it takes, what was found)
BAD = [
    # Ran, then a TypeError on every loop pass while the summary said "errors none".
    ("[link]\nport = 5\n", ["[link] port", "string or none", "integer 5"]),
    ('[link]\nbaud = "fast"\n', ["[link] baud", "integer", "string 'fast'"]),
    ('[link]\nexclusive = "no"\n', ["[link] exclusive", "boolean", "string 'no'"]),
    ('[camera]\nenabled = "false"\n', ["[camera] enabled", "boolean", "string 'false'"]),
    # Was a raw Python comparison error.
    ('[link]\nhello_period_s = "x"\n', ["[link] hello_period_s", "number", "string 'x'"]),
    ("[link]\nhello_period_s = -1.0\n", ["[link] hello_period_s", "must be positive", "-1.0"]),
    ("[link]\nhello_period_s = nan\n", ["[link] hello_period_s", "finite number", "nan"]),
    ("[record]\nkeep_mb = inf\n", ["[record] keep_mb", "finite number", "inf"]),
    ("[decision]\nvalid_ms = true\n", ["[decision] valid_ms", "integer", "boolean true"]),
    ("[decision]\nvalid_ms = 5000\n", ["[decision] valid_ms", "1..1000", "5000"]),
    ("[decision]\nsteal_s = 500.0\n", ["[decision] steal_s", "[0, 120]", "500.0"]),
    ("[decision]\nsteal_s = -1.0\n", ["[decision] steal_s", "0: no steal", "-1.0"]),
    ('[decision]\nsteal_s = "late"\n', ["[decision] steal_s", "number", "'late'"]),
    ('[decision]\nsteal_climb = "yes"\n', ["[decision] steal_climb", "boolean", "string 'yes'"]),
    ("[link]\nbaud = 1.5\n", ["[link] baud", "integer", "float 1.5"]),
    ('[decision]\ndrive_phases = "driver"\n', ["[decision] drive_phases", "array", "'driver'"]),
    ("[decision]\ndrive_phases = [1]\n", ["[decision] drive_phases", "string", "[1]"]),
    ('[camera]\ndetector = "yolo"\n', ["[camera] detector", "cnn or classical", "'yolo'"]),
    ("[link]\nprot = 1\n", ["[link]", "unknown keys ['prot']", "hello_period_s", "baud"]),
    ("[linc]\n", ["unknown table [linc]", "link", "decision", "camera"]),
    ("link = 5\n", ["link", "expected a table", "integer 5"]),
]


@pytest.mark.parametrize(("text", "needles"), BAD, ids=[t.strip() for t, _ in BAD])
def test_a_bad_value_names_the_file_the_key_the_type_and_what_was_found(
    tmp_path: Path, text: str, needles: list[str]
) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text(text)
    with pytest.raises(SettingsError) as caught:
        Settings.load(bad)
    message = str(caught.value)
    assert message.startswith(f"config file {bad}: "), message
    for needle in needles:
        assert needle in message, f"{needle!r} not in {message!r}"


def test_command_line_overrides_go_through_the_same_checks() -> None:
    with pytest.raises(SettingsError, match=r"^command line: \[link\] baud: expected integer"):
        Settings().with_overrides(link={"baud": "fast"})
    with pytest.raises(SettingsError, match=r"^command line: \[decision\] valid_ms: .*1\.\.1000"):
        Settings().with_overrides(decision={"valid_ms": 5000})
    with pytest.raises(SettingsError, match=r"command line: \[camera\] enabled: expected boolean"):
        Settings().with_overrides(camera={"enabled": "no"})
    with pytest.raises(SettingsError, match=r"command line: \[link\]: unknown keys \['prot'\]"):
        Settings().with_overrides(link={"prot": 1})
    # An override replaces one key and keeps the file's others; None is an option not given.
    s = Settings().with_overrides(link={"baud": 9600}).with_overrides(link={"port": "/dev/x"})
    assert (s.link.port, s.link.baud) == ("/dev/x", 9600)
    assert s.with_overrides(link={"port": None}).link.port == "/dev/x"


def test_a_recording_header_decision_table_is_checked_too() -> None:
    assert DecisionConfig.from_dict({"valid_ms": 300}).valid_ms == 300
    with pytest.raises(SettingsError, match=r"\[decision\] frame_pose: expected boolean"):
        DecisionConfig.from_dict({"frame_pose": "yes"})


def test_every_default_passes_its_own_check() -> None:
    """The annotations the checker reads agree with the defaults (and msgspec reads them all)."""
    seen = 0
    for group in fields(Settings):
        cls = typing.get_type_hints(Settings)[group.name]
        assert is_dataclass(cls)
        hints = typing.get_type_hints(cls)
        for f in fields(cls):
            config_check.check_value(getattr(cls(), f.name), hints[f.name], f.name, SettingsError)
            seen += 1
    assert seen > 30


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["--config", "{bad}"], "[link] port: expected string or none, found integer 5"),
        (["--valid-ms", "5000"], "command line: [decision] valid_ms"),
    ],
)
def test_pete_jetson_run_refuses_bad_settings_with_one_line(
    tmp_path: Path, args: list[str], needle: str
) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text("[link]\nport = 5\n")
    argv = [a.replace("{bad}", str(bad)) for a in args]
    proc = subprocess.run(
        [sys.executable, "-m", "jetson.cli", "run", "--no-camera", *argv],
        cwd=tmp_path, capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in proc.stderr, proc.stderr
    assert lines[0].startswith("pete-jetson: error: ") and needle in lines[0], lines[0]

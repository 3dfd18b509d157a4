"""The Jetson side runs on Python 3.10 (JetPack 6): what 3.11 added comes from protocol.compat,
vermin finds nothing newer in protocol/ and jetson/, and pete-sim says what it needs instead of
a traceback. CI has no 3.10 interpreter, so these run on 3.11."""

from __future__ import annotations

import enum
import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from jetson.handshake import LinkState
from protocol.compat import StrEnum, tomllib
from protocol.errors import ErrorKind, FrameError

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("member", [*ErrorKind, *LinkState], ids=str)
def test_our_str_enums_behave_as_the_standard_one(member: StrEnum) -> None:
    reference = enum.StrEnum("Reference", {member.name: member.value})[member.name]
    for show in (str, lambda m: f"{m}", lambda m: f"{m:>20}", json.dumps):
        assert show(member) == show(reference)
    assert member == member.value and hash(member) == hash(member.value)
    assert type(member)(member.value) is member
    assert {member.value: 1}[member] == 1


def test_a_frame_error_names_its_kind_by_value() -> None:
    assert str(FrameError(ErrorKind.BAD_CRC, "x")) == "bad_crc: x"


def test_compat_tomllib_parses_and_raises_its_decode_error() -> None:
    assert tomllib.loads("[a]\nb = 1\n") == {"a": {"b": 1}}
    with pytest.raises(tomllib.TOMLDecodeError):
        tomllib.loads("[a\n")


def vermin(*paths: Path) -> subprocess.CompletedProcess[str]:
    exe = shutil.which("vermin", path=str(Path(sys.executable).parent))
    if exe is None:
        pytest.skip("vermin is not installed (it is in the dev extra)")
    return subprocess.run(
        [exe, "--target=3.10-", "--no-tips", "--violations", "--eval-annotations", "-q"]
        + [str(p) for p in paths],
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )


def test_vermin_finds_nothing_newer_than_python_310_on_the_jetson_side() -> None:
    out = vermin(ROOT / "protocol", ROOT / "jetson")
    assert out.returncode == 0, out.stdout + out.stderr


def test_vermin_flags_what_python_310_lacks(tmp_path: Path) -> None:
    """The check above can fail: the same command flags the features we replaced."""
    (tmp_path / "a.py").write_text("import tomllib\nfrom enum import StrEnum\n")
    out = vermin(tmp_path)
    assert out.returncode != 0
    assert "tomllib" in out.stdout and "StrEnum" in out.stdout


def run_sim(prelude: str, *argv: str) -> subprocess.CompletedProcess[str]:
    code = f"import sys\n{prelude}\nfrom sim.cli import main\nsys.exit(main({list(argv)!r}))\n"
    return subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=False
    )


def test_pete_sim_without_the_sim_extra_names_the_extra(tmp_path: Path) -> None:
    out = run_sim("sys.modules['pybullet'] = None", "view", "--out", str(tmp_path / "v"))
    assert out.returncode == 2, out.stderr
    assert "Traceback" not in out.stderr
    assert "pybullet is not installed" in out.stderr and "pip install '.[sim]'" in out.stderr


def test_pete_sim_on_python_310_says_it_needs_311(tmp_path: Path) -> None:
    # A version_info that says 3.10, as a tuple with .major and .minor.
    prelude = "class V(tuple):\n    major, minor = 3, 10\nsys.version_info = V((3, 10, 12))\n"
    out = run_sim(prelude, "view", "--out", str(tmp_path / "v"))
    assert out.returncode == 2, out.stderr
    assert "needs Python 3.11 or newer (this is 3.10)" in out.stderr
    assert not (tmp_path / "v").exists()

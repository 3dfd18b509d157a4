"""`pete-protocol`: help, encode, decode, check, generate and info, as a user runs them."""

from __future__ import annotations

import functools
import json
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from protocol import cli, framing, generate
from protocol.messages import (
    FINGERPRINT,
    Command,
    Fault,
    Hello,
    Log,
    LogLevel,
    MatchPhase,
    Role,
    State,
)
from protocol.schema import DEFAULT_SCHEMA

EXE = Path(sys.executable).with_name("pete-protocol")


def run_cli(*args: str, stdin: bytes = b"") -> subprocess.CompletedProcess[bytes]:
    """The installed entry point, as a user runs it."""
    return subprocess.run([str(EXE), *args], input=stdin, capture_output=True, timeout=60)


def call(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    code = cli.main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


def json_lines(text: str) -> list[dict[str, Any]]:
    return [json.loads(line) for line in text.splitlines() if line.strip()]


# --- help ---------------------------------------------------------------------------------------


def test_top_level_help_lists_every_command() -> None:
    result = run_cli("--help")
    assert result.returncode == 0
    text = result.stdout.decode()
    assert "wire protocol" in text
    for command in ("info", "generate", "check", "golden", "encode", "decode"):
        assert command in text


@pytest.mark.parametrize(
    ("command", "purpose"),
    [
        ("info", "fingerprint"),
        ("generate", "codecs"),
        ("check", "stale"),
        ("golden", "golden_vectors.json"),
        ("encode", "wire bytes of one message"),
        ("decode", "one JSON object per message"),
    ],
)
def test_each_command_help_says_what_it_is_for(
    capsys: pytest.CaptureFixture[str], command: str, purpose: str
) -> None:
    with pytest.raises(SystemExit) as info:
        cli.main([command, "--help"])
    assert info.value.code == 0
    out = " ".join(capsys.readouterr().out.split())  # argparse wraps lines
    assert f"pete-protocol {command}" in out
    assert purpose in out


def test_no_command_is_a_usage_error() -> None:
    result = run_cli()
    assert result.returncode == 2
    assert b"usage" in result.stderr


# --- encode -------------------------------------------------------------------------------------


def test_encode_command_down_prints_the_hex_of_the_line(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, err = call(
        capsys, "encode", "Command", "--json", '{"linear": 0.5}', "--link", "down"
    )
    assert code == 0, err
    expected = framing.encode_downlink(Command(linear=0.5), 0)
    assert out.strip() == expected.hex()
    assert bytes.fromhex(out.strip()).startswith(b":030011")


def test_encode_fields_left_out_take_defaults(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = call(capsys, "encode", "Command", "--seq", "9")
    assert code == 0
    packet = bytes.fromhex(out.strip())
    assert packet == framing.encode_packet(Command(), 9)
    assert framing.decode_packet(packet) == (Command(seq=0, linear=0.0, valid_ms=0), 9)


def test_encode_enums_flags_and_text_by_name(capsys: pytest.CaptureFixture[str]) -> None:
    fields = {"phase": "driver", "faults": ["gps_fault", "motor_fault"], "x": 1.25}
    code, out, _ = call(capsys, "encode", "State", "--json", json.dumps(fields), "--link", "up")
    assert code == 0
    msg = framing.message_from_dict(State, fields)
    assert msg.faults == Fault.GPS_FAULT | Fault.MOTOR_FAULT
    assert bytes.fromhex(out.strip()) == framing.encode_uplink(msg, 0)
    code, out, _ = call(capsys, "encode", "Log", "--json", '{"level": "error", "text": "hi"}')
    assert bytes.fromhex(out.strip()) == framing.encode_packet(Log(LogLevel.ERROR, 0, "hi"), 0)


def test_encode_spaced_and_raw() -> None:
    spaced = run_cli("encode", "Command", "--spaced")
    assert spaced.returncode == 0
    assert spaced.stdout.decode().split() == [
        f"{b:02x}" for b in framing.encode_packet(Command(), 0)
    ]
    raw = run_cli("encode", "Command", "--link", "down", "--raw", "--json", '{"intake": true}')
    assert raw.returncode == 0
    assert raw.stdout == framing.encode_downlink(Command(intake=True), 0)


@pytest.mark.parametrize(
    ("args", "names"),
    [
        (["encode", "Command", "--json", "{linear: 0.5}"], ["--json", "not valid JSON"]),
        (["encode", "Command", "--json", "[1, 2]"], ["--json", "JSON object"]),
        (["encode", "Command", "--json", '{"speed": 1}'], ["Command", "'speed'"]),
        (["encode", "Teleport"], ["unknown message", "'Teleport'", "Command"]),
        (["encode", "Command", "--json", '{"valid_ms": -5}'], ["Command.valid_ms", "-5"]),
        (["encode", "State", "--json", '{"faults": 1.5}'], ["State.faults"]),
        (["encode", "State", "--json", '{"phase": "halftime"}'], ["State.phase", "'halftime'"]),
        (["encode", "Command", "--seq", "300"], ["--seq", "0..255"]),
        (["--schema", "/nonexistent/schema.toml", "info"], ["schema error", "not found"]),
        (["decode", "--link", "up", "--input", "/nonexistent/capture.bin"], ["capture.bin"]),
    ],
)
def test_bad_input_exits_2_naming_the_problem_without_a_traceback(
    args: list[str], names: list[str]
) -> None:
    result = run_cli(*args)
    err = result.stderr.decode()
    assert result.returncode == 2
    assert "Traceback" not in err
    assert err.startswith("pete-protocol: ")
    for name in names:
        assert name in err
    assert result.stdout == b""


# --- decode -------------------------------------------------------------------------------------


def test_decode_up_prints_messages_text_and_errors() -> None:
    state = State(seq=3, phase=MatchPhase.AUTONOMOUS, faults=Fault.LINK_ERRORS)
    data = (
        framing.encode_uplink(state, 17)
        + framing.stream_frame(b"sout", b"hello brain\n")
        + b"\x09junk\x00"  # COBS that promises more bytes than it has
        + framing.encode_uplink(Hello(FINGERPRINT, 1, Role.BRAIN, 5, "0.1.0"), 18)
    )
    result = run_cli("decode", "--link", "up", "--stats", stdin=data)
    assert result.returncode == 0, result.stderr
    lines = json_lines(result.stdout.decode())
    assert lines[0] == {
        "type": "message",
        "name": "State",
        "seq": 17,
        "fields": framing.message_to_dict(state),
    }
    assert lines[0]["fields"]["phase"] == "autonomous"
    assert lines[0]["fields"]["faults"] == ["link_errors"]
    assert lines[1] == {"type": "text", "stream": "sout", "text": "hello brain"}
    assert lines[2]["type"] == "error" and lines[2]["kind"] == "bad_cobs"
    assert lines[3]["name"] == "Hello" and lines[3]["fields"]["role"] == "brain"
    assert lines[4]["type"] == "stats"
    assert lines[4]["received"] == 2 and lines[4]["errors"]["bad_cobs"] == 1
    assert len(lines) == 5


def test_decode_down_prints_messages_and_errors(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    command = Command(seq=4, linear=0.5, angular=-0.25, intake=True, valid_ms=150)
    capture = tmp_path / "down.bin"
    capture.write_bytes(
        framing.encode_downlink(command, 1)
        + b"garbage\n"
        + framing.encode_downlink(State(), 2)
        + framing.encode_downlink(command, 3)[:-5]  # cut short by the next frame
        + framing.encode_downlink(command, 4)
    )
    code, out, _ = call(capsys, "decode", "--link", "down", "--input", str(capture))
    assert code == 0
    lines = json_lines(out)
    assert [(x["type"], x.get("name") or x.get("kind")) for x in lines] == [
        ("message", "Command"),
        ("error", "garbage"),
        ("error", "wrong_direction"),
        ("error", "truncated"),
        ("message", "Command"),
    ]
    assert lines[0]["fields"] == {
        "seq": 4,
        "linear": 0.5,
        "angular": -0.25,
        "intake": True,
        "valid_ms": 150,
        "clamp": "leave",
        "lift": "leave",
    }
    assert [x["seq"] for x in lines if x["type"] == "message"] == [1, 4]


def test_decode_hex_input_survives_any_split_and_spacing() -> None:
    line = framing.encode_downlink(Command(linear=1.0), 6)
    spaced = " ".join(f"{b:02x}" for b in line) * 200  # > 4096 characters: several reads
    result = run_cli("decode", "--link", "down", "--hex", stdin=spaced.encode())
    assert result.returncode == 0, result.stderr
    lines = json_lines(result.stdout.decode())
    assert len(lines) == 200
    assert all(x["name"] == "Command" and x["fields"]["linear"] == 1.0 for x in lines)


def test_decode_hex_rejects_non_hex() -> None:
    result = run_cli("decode", "--link", "down", "--hex", stdin=b"3a zz")
    assert result.returncode == 2
    assert b"--hex" in result.stderr and b"Traceback" not in result.stderr


# --- check / generate ---------------------------------------------------------------------------


@pytest.fixture
def tree(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """Point the CLI's generate/check at a copy of the generated files under tmp_path."""
    monkeypatch.setattr(generate, "outputs", functools.partial(generate.outputs, root=tmp_path))
    return tmp_path


def test_generate_writes_every_file_once(capsys: pytest.CaptureFixture[str], tree: Path) -> None:
    code, out, _ = call(capsys, "generate")
    assert code == 0
    written = {line.removeprefix("wrote ").strip() for line in out.splitlines()}
    assert written == {
        str(tree / "protocol" / "messages.py"),
        str(tree / "brain" / "include" / "pete" / "messages.hpp"),
        str(tree / "brain" / "include" / "pete" / "wire.hpp"),
        str(tree / "tests" / "cpp" / "protocol" / "golden_vectors.inc"),
    }
    # what it wrote is what the real tree holds (that tree is current: test_codec_golden)
    generated = (tree / "protocol" / "messages.py").read_text()
    assert generated == (generate.REPO_ROOT / "protocol" / "messages.py").read_text()
    code, out, _ = call(capsys, "generate")
    assert code == 0 and "up to date" in out


def test_check_passes_on_a_fresh_tree_and_names_a_stale_file(
    capsys: pytest.CaptureFixture[str], tree: Path
) -> None:
    generate.write(generate.outputs())
    code, out, err = call(capsys, "check")
    assert code == 0 and "match" in out and err == ""

    hpp = tree / "brain" / "include" / "pete" / "messages.hpp"
    hpp.write_text(hpp.read_text().replace("kFingerprint = 0x", "kFingerprint = 0x1"))
    code, _, err = call(capsys, "check")
    assert code == 1
    assert str(hpp) in err and "pete-protocol generate" in err
    assert "messages.py" not in err

    (tree / "protocol" / "messages.py").unlink()
    code, _, err = call(capsys, "check")
    assert code == 1
    assert "messages.py" in err and str(hpp) in err


def test_check_against_an_edited_schema_fails_and_names_the_codecs(tmp_path: Path) -> None:
    # Reads the real tree, writes nothing: the files are stale for this schema, not for ours.
    edited = tmp_path / "schema.toml"
    edited.write_text(DEFAULT_SCHEMA.read_text().replace('name = "intake"', 'name = "shooter"'))
    result = run_cli("--schema", str(edited), "check")
    err = result.stderr.decode()
    assert result.returncode == 1
    assert "stale: protocol/messages.py" in err
    assert "stale: brain/include/pete/messages.hpp" in err
    assert "wire.hpp" not in err


def test_check_on_the_real_tree_passes() -> None:
    result = run_cli("check")
    assert result.returncode == 0, result.stderr.decode()


# --- info ---------------------------------------------------------------------------------------


def test_info_prints_the_fingerprint_and_every_message(capsys: pytest.CaptureFixture[str]) -> None:
    code, out, _ = call(capsys, "info")
    assert code == 0
    assert f"fingerprint 0x{FINGERPRINT:08X}" in out
    rows = {
        line.split()[1]: line.split() for line in out.splitlines() if line[:3].strip().isdigit()
    }
    assert set(rows) == {"Hello", "State", "Command", "Log", "Partner", "PartnerStatus"}
    assert rows["Command"][2] == "jetson->brain"
    assert int(rows["State"][3]) == State.BODY_SIZE
    # the downlink column is the exact length of a line
    assert int(rows["Command"][5]) == len(framing.encode_downlink(Command(), 0))

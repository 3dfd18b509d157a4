"""The Python codec and the generated C++ codec agree byte for byte.

The C++ side runs as build/host/bin/pete_codec_tool (tests/cpp/protocol/codec_tool.cpp), which
`make build` compiles under ASan and UBSan, so every input here also exercises the C++ decoder for
memory errors.
"""

from __future__ import annotations

import random
import struct
import subprocess
from pathlib import Path
from typing import Any

import pytest

from protocol import framing
from protocol.errors import ErrorKind, FrameError
from protocol.framing import DownlinkDecoder, Received
from protocol.messages import (
    FINGERPRINT,
    Alliance,
    Command,
    Fault,
    GpsStatus,
    Hello,
    Log,
    LogLevel,
    MatchPhase,
    Role,
    State,
)

TOOL = Path(__file__).resolve().parents[2] / "build" / "host" / "bin" / "pete_codec_tool"
TIMEOUT_S = 120

pytestmark = pytest.mark.skipif(
    not TOOL.exists(), reason=f"{TOOL} is not built: run `make build` (cmake) first"
)

# f32 bit patterns a codec is most likely to get wrong.
_EDGE_F32 = (
    0x00000000,  # +0
    0x80000000,  # -0
    0x00000001,  # smallest subnormal
    0x807FFFFF,  # largest negative subnormal
    0x00800000,  # smallest normal
    0x7F7FFFFF,  # FLT_MAX
    0xFF7FFFFF,  # -FLT_MAX
    0x3F800000,  # 1
)
# Text the C++ side keeps as raw bytes: multi-byte UTF-8 must come back unchanged.
_TEXT_ALPHABET = [chr(c) for c in range(1, 128)] + ["é", "→", "🤖"]


def run_tool(args: list[str], stdin: bytes) -> bytes:
    proc = subprocess.run(
        [str(TOOL), *args], input=stdin, capture_output=True, timeout=TIMEOUT_S, check=False
    )
    assert proc.returncode == 0, f"pete_codec_tool {args} failed: {proc.stderr.decode()}"
    return proc.stdout


def random_f32(rng: random.Random) -> float:
    pick = rng.random()
    if pick < 0.25:
        bits = rng.choice(_EDGE_F32)
    elif pick < 0.5:
        return struct.unpack("<f", struct.pack("<f", rng.uniform(-5.0, 5.0)))[0]
    else:
        bits = rng.getrandbits(32)
        while bits & 0x7F800000 == 0x7F800000:  # inf and NaN are never sent
            bits = rng.getrandbits(32)
    return struct.unpack("<f", struct.pack("<I", bits))[0]


def random_text(rng: random.Random, size: int) -> str:
    """Up to `size` UTF-8 bytes; Python's encoder cuts longer text at a character boundary, so
    ask for a little more now and then."""
    return "".join(rng.choice(_TEXT_ALPHABET) for _ in range(rng.randint(0, size + 4)))


def random_message(rng: random.Random, cls: type | None = None) -> Any:
    cls = cls or rng.choice([Hello, State, Command, Log])
    u32 = rng.getrandbits
    if cls is Hello:
        fingerprint = FINGERPRINT if rng.random() < 0.5 else u32(32)
        return Hello(fingerprint, u32(16), rng.choice(list(Role)), u32(32), random_text(rng, 16))
    if cls is State:
        return State(
            seq=u32(32),
            time_ms=u32(32),
            phase=rng.choice(list(MatchPhase)),
            phase_ms=u32(32),
            alliance=rng.choice(list(Alliance)),
            x=random_f32(rng),
            y=random_f32(rng),
            heading=random_f32(rng),
            gps_error=random_f32(rng),
            gps_status=rng.choice(list(GpsStatus)),
            left_speed=random_f32(rng),
            right_speed=random_f32(rng),
            last_command_seq=u32(32),
            faults=Fault(rng.getrandbits(6)),
        )
    if cls is Command:
        return Command(u32(32), random_f32(rng), random_f32(rng), rng.random() < 0.5, u32(16))
    return Log(rng.choice(list(LogLevel)), u32(32), random_text(rng, 48))


def python_decode(packet: bytes) -> tuple[str, bytes, bool]:
    """(verdict, re-encoded packet, whether all its text was valid UTF-8); the verdict is 'ok' or
    the error kind, as the tool names it."""
    try:
        msg, seq = framing.decode_packet(packet)
    except FrameError as exc:
        return str(exc.kind), b"", True
    # Python shows invalid UTF-8 as U+FFFD (and re-encodes that); C++ keeps the bytes as they were.
    clean = not any(isinstance(v, str) and "\ufffd" in v for v in vars_of(msg))
    return "ok", framing.encode_packet(msg, seq), clean


def vars_of(msg: Any) -> list[Any]:
    return [getattr(msg, f.name) for f in msg.FIELDS]


# --- Python -> C++ -> Python --------------------------------------------------------------------


def test_cpp_reencodes_python_packets_byte_for_byte() -> None:
    rng = random.Random(20240601)
    packets = [framing.encode_packet(random_message(rng), rng.getrandbits(8)) for _ in range(4000)]
    assert {p[0] for p in packets} == {Hello.ID, State.ID, Command.ID, Log.ID}
    out = run_tool(["roundtrip"], b"".join(p.hex().encode() + b"\n" for p in packets))
    assert out.decode().splitlines() == [p.hex() for p in packets]


def test_cpp_and_python_reject_damaged_packets_for_the_same_reason() -> None:
    rng = random.Random(77)
    packets: list[bytes] = []
    for _ in range(3000):
        p = bytearray(framing.encode_packet(random_message(rng), rng.getrandbits(8)))
        how = rng.randrange(6)
        if how == 0:  # one byte changed, CRC left alone
            p[rng.randrange(len(p))] ^= 1 << rng.randrange(8)
        elif how == 1:  # one byte changed and the CRC fixed: the value checks must catch it
            p[rng.randrange(len(p) - 2)] = rng.getrandbits(8)
            p[-2:] = struct.pack("<H", framing.crc16(bytes(p[:-2])))
        elif how == 2:  # cut short
            del p[rng.randrange(len(p)) :]
        elif how == 3:  # trailing bytes
            p += bytes(rng.getrandbits(8) for _ in range(rng.randint(1, 4)))
        elif how == 4:  # any id, re-sealed
            p[0] = rng.getrandbits(8)
            p[-2:] = struct.pack("<H", framing.crc16(bytes(p[:-2])))
        packets.append(bytes(p))
    lines = run_tool(["roundtrip"], b"".join(p.hex().encode() + b"\n" for p in packets))
    cpp = lines.decode().splitlines()
    assert len(cpp) == len(packets)
    verdicts: set[str] = set()
    for packet, got in zip(packets, cpp, strict=True):
        verdict, again, clean_text = python_decode(packet)
        verdicts.add(verdict)
        if verdict != "ok":
            assert got == f"error {verdict}", packet.hex()
            continue
        assert not got.startswith("error"), (packet.hex(), got)
        if clean_text:
            assert got == again.hex(), packet.hex()
    # Every way a packet can be bad came up, so the agreement above means something.
    assert verdicts >= {"ok", "truncated", "bad_crc", "bad_length", "unknown_id", "bad_value"}


# --- C++ -> Python ------------------------------------------------------------------------------


def tool_random(count: int, seed: int) -> list[bytes]:
    out = run_tool(["random", str(count), str(seed)], b"")
    return [bytes.fromhex(line) for line in out.decode().splitlines()]


def test_cpp_random_packets_decode_and_reencode_identically_in_python() -> None:
    packets = tool_random(3000, 12345)
    assert len(packets) == 3000
    assert {p[0] for p in packets} == {Hello.ID, State.ID, Command.ID, Log.ID}
    for packet in packets:
        msg, seq = framing.decode_packet(packet)
        assert framing.encode_packet(msg, seq) == packet, packet.hex()
    # Random, not a fixed handful: many distinct packets and sequence numbers.
    assert len(set(packets)) > 2900
    assert len({p[1] for p in packets}) > 200


def test_cpp_random_is_reproducible_from_its_seed() -> None:
    assert tool_random(50, 9) == tool_random(50, 9)
    assert tool_random(50, 9) != tool_random(50, 10)
    # Even a handful covers every message type.
    assert {p[0] for p in tool_random(4, 1)} == {Hello.ID, State.ID, Command.ID, Log.ID}


def test_uplink_frames_match() -> None:
    packets = tool_random(1000, 555)
    frames = run_tool(["uplink"], b"".join(p.hex().encode() + b"\n" for p in packets))
    expected = []
    for packet in packets:
        msg, seq = framing.decode_packet(packet)
        expected.append(framing.encode_uplink(msg, seq))
    assert frames == b"".join(expected)
    # And the Jetson's reader gets every message back out of the C++ frames.
    decoder = framing.UplinkDecoder()
    events = decoder.feed(frames)
    assert [framing.encode_packet(e.message, e.seq) for e in events if isinstance(e, Received)] == [
        p for p in packets if framing.decode_packet(p)[0].UPLINK
    ]
    assert decoder.stats.errors[ErrorKind.WRONG_DIRECTION.value] == sum(
        1 for p in packets if p[0] == Command.ID
    )


def test_stream_frames_match_for_any_payload_length() -> None:
    # COBS has its corner cases at 254-byte blocks: cover every length a packet can have.
    rng = random.Random(3)
    payloads = []
    for n in range(framing.MAX_PACKET + 1):
        payloads.append(bytes(rng.randint(1, 255) for _ in range(n)))
        payloads.append(bytes(rng.getrandbits(8) for _ in range(n)))
    payloads.append(b"\x00" * framing.MAX_PACKET)
    frames = run_tool(["uplink"], b"".join(p.hex().encode() + b"\n" for p in payloads))
    assert frames == b"".join(framing.stream_frame(b"pete", p) for p in payloads)


# --- a noisy downlink, decoded on both sides ----------------------------------------------------


def corrupt(stream: bytes, rate: float, rng: random.Random) -> bytes:
    """Roughly `rate` of the bytes damaged the ways a serial line does it."""
    out = bytearray()
    for b in stream:
        if rng.random() >= rate:
            out.append(b)
            continue
        how = rng.randrange(5)
        if how == 0:
            out.append(b ^ (1 << rng.randrange(8)))
        elif how == 1:
            out.append(rng.getrandbits(8))
        elif how == 2:
            pass  # dropped
        elif how == 3:
            out += bytes([b, rng.choice(b":\n\r")])  # a stray framing byte
        else:
            out += bytes([b, rng.getrandbits(8)])
    return bytes(out)


def test_noisy_downlink_gives_the_same_messages_in_both_languages() -> None:
    rng = random.Random(4242)
    sent: list[bytes] = []
    stream = bytearray()
    for i in range(3000):
        # Mostly what the Jetson sends, plus some Brain-only messages the decoders must refuse.
        cls = rng.choices([Command, Hello, State, Log], weights=[80, 10, 5, 5])[0]
        packet = framing.encode_packet(random_message(rng, cls), i)
        sent.append(packet)
        stream += b":" + packet.hex().encode() + b"\n"
    noisy = corrupt(bytes(stream), 0.01, rng)
    assert noisy != bytes(stream)

    out = run_tool(["downlink"], noisy).decode().splitlines()
    cpp_msgs = [bytes.fromhex(line.split()[1]) for line in out if line.startswith("msg ")]
    errors_line = next(line for line in out if line.startswith("errors"))
    cpp_errors = dict(item.split("=") for item in errors_line.split()[1:])
    summary = next(line for line in out if line.startswith("received")).split()
    assert len(out) == len(cpp_msgs) + 2

    decoder = DownlinkDecoder()
    py_msgs: list[bytes] = []
    at = 0
    while at < len(noisy):  # the Brain's reads cut the stream anywhere
        n = rng.randint(1, 200)
        for event in decoder.feed(noisy[at : at + n]):
            if isinstance(event, Received):
                py_msgs.append(framing.encode_packet(event.message, event.seq))
        at += n

    assert cpp_msgs == py_msgs
    assert int(summary[1]) == decoder.stats.received == len(py_msgs)
    assert int(summary[3]) == decoder.stats.lost
    # Nothing delivered differs from something actually sent, and only Jetson messages get through.
    sent_set = set(sent)
    assert all(m in sent_set for m in cpp_msgs)
    assert all(m[0] in (Command.ID, Hello.ID) for m in cpp_msgs)
    # The noise did something, and most frames still made it.
    downlink_sent = sum(1 for p in sent if p[0] in (Command.ID, Hello.ID))
    assert 0.5 * downlink_sent < len(cpp_msgs) < downlink_sent
    assert decoder.stats.lost > 0
    assert set(cpp_errors) <= {k.value for k in ErrorKind}
    assert int(cpp_errors.get("wrong_direction", 0)) > 0
    assert int(cpp_errors.get("bad_crc", 0)) > 0
    assert sum(int(v) for v in cpp_errors.values()) > 0.5 * (len(sent) - len(cpp_msgs))


def python_downlink(stream: bytes, chunk: int) -> list[bytes]:
    decoder = DownlinkDecoder()
    events = [
        e for at in range(0, len(stream), chunk) for e in decoder.feed(stream[at : at + chunk])
    ]
    return [framing.encode_packet(e.message, e.seq) for e in events if isinstance(e, Received)]


def test_a_frame_cut_by_the_next_colon_is_dropped_however_the_bytes_arrive() -> None:
    first = framing.encode_downlink(Command(1, 0.5, 0.5, True, 100), 1)
    second = framing.encode_downlink(Command(2, 0.5, 0.5, True, 100), 2)
    # The first frame loses its newline; the next ':' starts a frame too long for any packet.
    stream = first[:-1] + b":" + b"a" * 600 + b"\n" + second
    expected = [framing.encode_packet(Command(2, 0.5, 0.5, True, 100), 2)]
    cpp = run_tool(["downlink"], stream).decode().splitlines()
    assert [bytes.fromhex(line[4:]) for line in cpp if line.startswith("msg ")] == expected
    assert python_downlink(stream, len(stream)) == expected
    assert python_downlink(stream, 1) == expected


# --- the tool itself ----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("args", "stdin", "complaint"),
    [
        (["roundtrip"], b"03070fzz\n", b"not a hex digit"),
        (["roundtrip"], b"030\n", b"odd number"),
        (["uplink"], b"0102\nxy\n", b"line 2"),
        (["uplink"], b"00" * 300 + b"\n", b"longer than any packet"),
        (["random", "ten", "1"], b"", b"unsigned"),
        (["random", "-1", "1"], b"", b"unsigned"),
        (["random", "3"], b"", b"usage"),
        (["frobnicate"], b"", b"usage"),
        ([], b"", b"usage"),
    ],
)
def test_tool_refuses_bad_input_clearly(args: list[str], stdin: bytes, complaint: bytes) -> None:
    proc = subprocess.run(
        [str(TOOL), *args], input=stdin, capture_output=True, timeout=TIMEOUT_S, check=False
    )
    assert proc.returncode == 2
    assert complaint in proc.stderr


def test_tool_reports_decode_errors_by_kind() -> None:
    good = framing.encode_packet(Command(1, 0.5, -0.5, True, 100), 3)
    bad_crc = good[:-1] + bytes([good[-1] ^ 1])
    lines = [good.hex(), bad_crc.hex(), "", good[:4].hex(), good.hex().upper()]
    out = run_tool(["roundtrip"], "\n".join(lines).encode() + b"\n").decode().splitlines()
    assert out == [good.hex(), "error bad_crc", "error truncated", "error truncated", good.hex()]

"""Benchmark of the wire protocol: bytes on the wire, Python codec rates, C++ decode time.

    python -m bench.protocol [--cpp-bench build/host/bin/pete_codec_bench] [--strict]

Bytes are compared with the original team's ASCII link (their Brain printed
"B <time> <x> <y> 0 0 <i>" on stdout, which PROS frames like any stream write; their Jetson wrote
"J <v> <r> <i>" raw to the Brain's stdin). Python rates are one thread, so one core. The C++ numbers
come from pete_codec_bench, built by `make build`; this script never makes them up.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from bench.common import Result, median_ns, per_second, positive_number, run_json_tool
from protocol import framing
from protocol.messages import (
    FINGERPRINT,
    PROTOCOL_VERSION,
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

ROOT = Path(__file__).resolve().parent.parent
DEFAULT_CPP_BENCH = ROOT / "build" / "host" / "bin" / "pete_codec_bench"
CPP_KEYS = (
    "state_packet_encode_ns",
    "state_packet_decode_ns",
    "command_downlink_encode_ns",
    "command_downlink_decode_ns",
)
CPP_TIMEOUT_S = 60
# Each repeat takes ~10-30 ms, far above timer noise; the median of many repeats shrugs off the
# ones another process preempted (CI machines have 2 busy cores).
CALLS_PER_REPEAT = 10_000
REPEATS = 11

# Realistic mid-match values, the same ones in both formats.
TIME_S = 61.23
X_M = 0.512
Y_M = -1.204
COUNTER = 4711
LINEAR = 0.512
ANGULAR = -0.331


def sample_messages() -> dict[str, Any]:
    return {
        "hello": Hello(FINGERPRINT, PROTOCOL_VERSION, Role.BRAIN, 0x5EED1234, "0.1.0"),
        "state": State(
            seq=COUNTER,
            time_ms=round(TIME_S * 1000),
            phase=MatchPhase.AUTONOMOUS,
            phase_ms=12_480,
            alliance=Alliance.RED,
            x=X_M,
            y=Y_M,
            heading=93.7,
            gps_error=0.012,
            gps_status=GpsStatus.OK,
            left_speed=0.48,
            right_speed=0.52,
            last_command_seq=COUNTER - 1,
            faults=Fault(0),
        ),
        "command": Command(seq=COUNTER, linear=LINEAR, angular=ANGULAR, intake=True, valid_ms=250),
        "log": Log(LogLevel.WARNING, 61_230, "gps error 0.31 m, pose held"),
    }


# --- bytes on the wire ----------------------------------------------------------------------------


@dataclass(frozen=True)
class WireSize:
    what: str
    line: int  # the message before link framing (packet, or ASCII line)
    wire: int  # what crosses the USB cable
    carries: str


def wire_sizes(msgs: dict[str, Any]) -> list[WireSize]:
    seq = COUNTER & 0xFF
    state_packet = framing.encode_packet(msgs["state"], seq)
    command_packet = framing.encode_packet(msgs["command"], seq)
    their_b = f"B {TIME_S} {X_M} {Y_M} 0 0 {COUNTER}\n".encode()
    their_j = f"J {LINEAR} {ANGULAR} {COUNTER}\n".encode()
    return [
        WireSize(
            "ours: State (uplink)",
            len(state_packet),
            len(framing.encode_uplink(msgs["state"], seq)),
            "14 fields, CRC-16, seq",
        ),
        WireSize(
            "theirs: 'B ...' line (stdout)",
            len(their_b),
            len(framing.stream_frame(b"sout", their_b)),
            "time, x, y, counter",
        ),
        WireSize(
            "ours: Command (downlink)",
            len(command_packet),
            len(framing.encode_downlink(msgs["command"], seq)),
            "5 fields, CRC-16, seq",
        ),
        WireSize(
            "theirs: 'J ...' line (raw)",
            len(their_j),
            len(their_j),
            "v, r, counter",
        ),
    ]


def print_wire_sizes(sizes: list[WireSize]) -> None:
    head = ("message", "unframed", "on wire", "carries")
    rows = [head, *((s.what, str(s.line), str(s.wire), s.carries) for s in sizes)]
    w = [max(len(r[i]) for r in rows) for i in range(4)]
    for i, r in enumerate(rows):
        print(f"{r[0]:<{w[0]}}  {r[1]:>{w[1]}}  {r[2]:>{w[2]}}  {r[3]}")
        if i == 0:
            print("-" * (sum(w) + 6))
    print("(bytes; 'unframed' is our packet or their text line, 'on wire' adds the link framing)\n")


# --- Python rates ---------------------------------------------------------------------------------


def _checked(name: str, once: Callable[[], bytes | None], expected: bytes) -> None:
    """Refuse to time a path that does not give the right answer."""
    got = once()
    if got != expected:
        raise SystemExit(f"bench.protocol: {name} round trip is wrong: {got!r} != {expected!r}")


def packet_roundtrip(msg: Any) -> Callable[[], bytes]:
    encode, decode = framing.encode_packet, framing.decode_packet

    def once() -> bytes:
        decoded, seq = decode(encode(msg, 7))
        return encode(decoded, seq)

    _checked(msg.NAME, once, encode(msg, 7))

    def timed() -> bytes:
        return decode(encode(msg, 7))

    return timed


def uplink_roundtrip(msg: Any) -> Callable[[], object]:
    decoder = framing.UplinkDecoder()
    encode = framing.encode_uplink
    seq = [0]

    def timed() -> object:
        # Consecutive sequence numbers, so the decoder takes its normal (no-loss) path.
        seq[0] = (seq[0] + 1) & 0xFF
        return decoder.feed(encode(msg, seq[0]))

    _check_link(timed, decoder.stats, msg)
    return timed


def downlink_roundtrip(msg: Any) -> Callable[[], object]:
    decoder = framing.DownlinkDecoder()
    encode = framing.encode_downlink
    seq = [0]

    def timed() -> object:
        seq[0] = (seq[0] + 1) & 0xFF
        return decoder.feed(encode(msg, seq[0]))

    _check_link(timed, decoder.stats, msg)
    return timed


def _check_link(timed: Callable[[], object], stats: framing.LinkStats, msg: Any) -> None:
    events = [timed(), timed()]
    for batch in events:
        ok = (
            isinstance(batch, list)
            and len(batch) == 1
            and isinstance(batch[0], framing.Received)
            and framing.encode_packet(batch[0].message, 0) == framing.encode_packet(msg, 0)
        )
        if not ok:
            raise SystemExit(f"bench.protocol: {msg.NAME} link round trip gave {batch!r}")
    if stats.error_total or stats.lost:
        raise SystemExit(f"bench.protocol: {msg.NAME} link round trip counted {stats.as_dict()}")


def python_rates(msgs: dict[str, Any], result: Result) -> None:
    for key, msg in msgs.items():
        ns = median_ns(packet_roundtrip(msg), number=CALLS_PER_REPEAT, repeats=REPEATS)
        result.add(f"{key}_roundtrips_per_s", round(per_second(ns)))
    ns = median_ns(uplink_roundtrip(msgs["state"]), number=CALLS_PER_REPEAT, repeats=REPEATS)
    result.add("state_uplink_roundtrips_per_s", round(per_second(ns)))
    ns = median_ns(downlink_roundtrip(msgs["command"]), number=CALLS_PER_REPEAT, repeats=REPEATS)
    result.add("command_downlink_roundtrips_per_s", round(per_second(ns)))


# --- C++ ------------------------------------------------------------------------------------------


def cpp_times(binary: Path) -> dict[str, float]:
    """pete_codec_bench's JSON, checked: every key present, every value a positive number."""
    data = run_json_tool("protocol", [str(binary)], CPP_TIMEOUT_S)
    out = {}
    for key in CPP_KEYS:
        out[key] = positive_number("protocol", f"{binary} gave {key}", data.get(key))
    return out


# --- main -----------------------------------------------------------------------------------------


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.protocol", description=__doc__)
    parser.add_argument(
        "--cpp-bench",
        type=Path,
        default=DEFAULT_CPP_BENCH,
        help="the C++ codec benchmark binary (default: build/host/bin/pete_codec_bench)",
    )
    parser.add_argument("--strict", action="store_true", help="exit 1 if a target is missed")
    args = parser.parse_args(argv)

    # Checked first: a half-run benchmark is worse than a clear instruction.
    if not args.cpp_bench.is_file():
        print(
            f"bench.protocol: {args.cpp_bench} is missing: run `make build` first "
            "(it builds the C++ codec benchmark); no numbers were written.",
            file=sys.stderr,
        )
        return 2

    msgs = sample_messages()
    result = Result("protocol")

    sizes = wire_sizes(msgs)
    print_wire_sizes(sizes)
    ours_state, theirs_b, ours_cmd, theirs_j = sizes
    result.add("state_packet_bytes", ours_state.line)
    result.add("state_uplink_bytes", ours_state.wire)
    result.add("original_state_line_bytes", theirs_b.line)
    result.add("original_state_framed_bytes", theirs_b.wire)
    result.add("command_packet_bytes", ours_cmd.line)
    result.add("command_downlink_bytes", ours_cmd.wire)
    result.add("original_command_line_bytes", theirs_j.line)
    result.add("original_command_wire_bytes", theirs_j.wire)

    python_rates(msgs, result)
    result.target("state_roundtrips_per_s", 200_000, ">=")

    for key, value in cpp_times(args.cpp_bench).items():
        result.add(key, value)
    # A Command must be decoded long before the next one (20 ms at 50 Hz); 2 us on the host,
    # even in the sanitized Debug build, leaves the V5's slower core a wide margin.
    result.target("command_downlink_decode_ns", 2000, "<=")
    result.target("state_packet_decode_ns", 2000, "<=")

    print(
        "(C++: pete_codec_bench, built -O2 without sanitizers; this machine's CPU, not the V5's)\n"
    )
    result.report()
    if not result.all_met:
        missed = ", ".join(k for k, ok in result.met().items() if not ok)
        print(f"targets missed: {missed}", file=sys.stderr)
        return 1 if args.strict else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())

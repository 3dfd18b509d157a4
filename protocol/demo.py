"""End to end over the wire protocol: the Brain's C++ codec against the Jetson's Python codec.

    python -m protocol.demo --tool build/host/bin/pete_codec_tool

1. Uplink: States encoded by the C++ codec, framed as PROS puts them on the USB wire, mixed with
   the Brain's printf text, cut into arbitrary reads and decoded by the Jetson's UplinkDecoder.
2. Downlink: Commands encoded in Python, 1% of the bytes corrupted, decoded by the Brain's C++
   DownlinkDecoder; nothing corrupt may come out.
3. Handshake: a Hello from a Brain built from another schema, refused with both fingerprints named.

pete_codec_tool (built by `make build`) is the C++ codec behind a pipe; this module only drives it.
"""

from __future__ import annotations

import argparse
import random
import subprocess
import sys
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

from protocol import framing, messages
from protocol.errors import DemoError, FingerprintMismatch
from protocol.messages import Alliance, Command, Fault, GpsStatus, Hello, MatchPhase, Role, State

DEFAULT_TOOL = Path("build/host/bin/pete_codec_tool")
TOOL_TIMEOUT_S = 20
SEED = 2022
COMMANDS = 1000
CORRUPT_FRACTION = 0.01
RANDOM_PACKETS = 500


# --- the C++ side, through pete_codec_tool ------------------------------------------------------


@dataclass
class DownlinkReport:
    """What the C++ Brain decoder delivered and counted."""

    packets: list[bytes] = field(default_factory=list)
    errors: Counter[str] = field(default_factory=Counter)
    received: int = 0
    lost: int = 0


@dataclass(frozen=True)
class CodecTool:
    path: Path

    def _run(self, *args: str, data: bytes = b"") -> bytes:
        proc = subprocess.run(
            [str(self.path), *args],
            input=data,
            capture_output=True,
            timeout=TOOL_TIMEOUT_S,
            check=False,
        )
        if proc.returncode != 0:
            err = proc.stderr.decode(errors="replace").strip()
            raise DemoError(f"{self.path.name} {' '.join(args)} exited {proc.returncode}: {err}")
        return proc.stdout

    def roundtrip(self, packets: list[bytes]) -> list[bytes]:
        """Each packet decoded by the C++ codec and encoded again by it."""
        out = self._run("roundtrip", data=_hex_lines(packets)).decode().split()
        if len(out) != len(packets):
            raise DemoError(f"roundtrip answered {len(out)} lines for {len(packets)} packets")
        for line in out:
            if line.startswith("error"):
                raise DemoError(f"the C++ codec refused a packet: {line}")
        return [bytes.fromhex(h) for h in out]

    def random(self, count: int, seed: int) -> list[bytes]:
        return [
            bytes.fromhex(h) for h in self._run("random", str(count), str(seed)).decode().split()
        ]

    def uplink(self, packets: list[bytes]) -> bytes:
        """The PROS stream frames the Brain's write()s of these packets become."""
        return self._run("uplink", data=_hex_lines(packets))

    def downlink(self, wire: bytes) -> DownlinkReport:
        report = DownlinkReport()
        for line in self._run("downlink", data=wire).decode().splitlines():
            word, *rest = line.split()
            if word == "msg":
                report.packets.append(bytes.fromhex(rest[0]))
            elif word == "errors":
                for item in rest:
                    kind, _, n = item.partition("=")
                    report.errors[kind] = int(n)
            elif word == "received":
                report.received, report.lost = int(rest[0]), int(rest[2])
            else:
                raise DemoError(f"unexpected line from the downlink decoder: {line!r}")
        return report


def _hex_lines(packets: list[bytes]) -> bytes:
    return b"".join(p.hex().encode() + b"\n" for p in packets)


# --- output helpers -----------------------------------------------------------------------------


def _hexdump(data: bytes, limit: int = 20) -> str:
    shown = data[:limit].hex(" ")
    return shown + (f" ... ({len(data)} bytes)" if len(data) > limit else f" ({len(data)} bytes)")


def _printable(line: bytes) -> str:
    """One character per byte, so that a marker line lines up under it."""
    return "".join(chr(b) if 0x20 <= b < 0x7F else "?" for b in line.rstrip(b"\n")) + "\\n"


def _state_line(msg: State) -> str:
    return (
        f"State seq={msg.seq} t={msg.time_ms / 1000:.2f}s {msg.phase.name.lower()} "
        f"x={msg.x:+.3f} y={msg.y:+.3f} hdg={msg.heading:.1f} gps={msg.gps_status.name.lower()} "
        f"faults={[f.name.lower() for f in Fault if f in msg.faults]}"
    )


def _chunks(data: bytes, rng: random.Random, largest: int = 64) -> list[bytes]:
    """Cut `data` like a serial port's read() would: at arbitrary places."""
    out, at = [], 0
    while at < len(data):
        n = rng.randint(1, largest)
        out.append(data[at : at + n])
        at += n
    return out


# --- the three scenes ---------------------------------------------------------------------------


def brain_states() -> list[State]:
    """Three States 20 ms apart, robot driving forward in autonomous."""
    return [
        State(
            seq=3050 + i,
            time_ms=61_230 + 20 * i,
            phase=MatchPhase.AUTONOMOUS,
            phase_ms=11_230 + 20 * i,
            alliance=Alliance.RED,
            x=0.512 + 0.012 * i,
            y=-1.204,
            heading=90.0,
            gps_error=0.012,
            gps_status=GpsStatus.OK,
            left_speed=0.6,
            right_speed=0.6,
            last_command_seq=1520 + i,
            faults=Fault.GPS_FAULT if i == 2 else Fault(0),
        )
        for i in range(3)
    ]


def uplink_scene(tool: CodecTool, rng: random.Random) -> None:
    print("1. UPLINK  Brain -> Jetson: C++ encodes, PROS frames, Python decodes")
    states = brain_states()
    packets = tool.roundtrip([framing.encode_packet(s, 40 + i) for i, s in enumerate(states)])
    frames = tool.uplink(packets)
    # Cut the C++ output back into one frame per write(), to interleave the Brain's printf text.
    state_frames = [f + b"\x00" for f in frames.split(b"\x00")[:-1]]
    printf = [
        framing.stream_frame(b"sout", b"auton: heading for ring 3\n"),
        framing.stream_frame(b"sout", b"gps err"),  # one printf line split over two writes
        framing.stream_frame(b"sout", b"or 0.31 m\n"),
    ]
    wire = b"".join(
        [state_frames[0], printf[0], state_frames[1], printf[1], printf[2], state_frames[2]]
    )
    print(f"   C++ State packet  {_hexdump(packets[0])}")
    print(f"   PROS frame (pete) {_hexdump(state_frames[0])}")
    print(f"   printf 'sout'     {_hexdump(printf[0], 16)}")
    decoder = framing.UplinkDecoder()
    chunks = _chunks(wire, rng)
    print(f"   {len(wire)} bytes on the wire, read in {len(chunks)} pieces of 1-64 bytes:")
    decoded: list[State] = []
    for chunk in chunks:
        for event in decoder.feed(chunk):
            if isinstance(event, framing.Received):
                decoded.append(event.message)
                print(f"   <- [seq {event.seq}] {_state_line(event.message)}")
            elif isinstance(event, framing.TextLine):
                print(f"   <- [{event.stream}] {event.text}")
            else:
                print(f"   <- error {event.kind}: {event.detail}")
    if [framing.encode_packet(m, 0) for m in decoded] != [
        framing.encode_packet(s, 0) for s in states
    ]:
        raise DemoError("the States the Jetson decoded differ from the ones the Brain sent")
    stats = decoder.stats
    print(f"   Jetson counters: received {stats.received}, lost {stats.lost}, ", end="")
    print(f"text lines {stats.text_lines}, errors {stats.error_total}")

    randoms = tool.random(RANDOM_PACKETS, rng.randrange(2**32))
    # decode_packet gives (message, seq): exactly what encode_packet takes back.
    same = sum(framing.encode_packet(*framing.decode_packet(p)) == p for p in randoms)
    print(f"   + {same}/{len(randoms)} random C++ packets (all types, edge-case floats, text)")
    print("     decoded by Python and re-encoded to the same bytes")
    if same != len(randoms):
        raise DemoError("Python and C++ disagree on a random packet")


def downlink_scene(tool: CodecTool, rng: random.Random) -> None:
    print(
        f"\n2. DOWNLINK  Jetson -> Brain: Python encodes, {CORRUPT_FRACTION:.0%} of the bytes "
        "are corrupted, C++ decodes"
    )
    commands = [
        Command(
            seq=1 + i,
            linear=round(rng.uniform(-0.6, 0.6), 3),
            angular=round(rng.uniform(-4.8, 4.8), 3),
            intake=rng.random() < 0.5,
            valid_ms=250,
        )
        for i in range(COMMANDS)
    ]
    lines = [framing.encode_downlink(c, (1 + i) & 0xFF) for i, c in enumerate(commands)]
    sent_packets = {framing.encode_packet(c, (1 + i) & 0xFF) for i, c in enumerate(commands)}
    wire = bytearray(b"".join(lines))
    hit = rng.sample(range(len(wire)), round(CORRUPT_FRACTION * len(wire)))
    for at in hit:
        wire[at] ^= rng.randint(1, 255)  # never 0: every chosen byte really changes
    size = len(lines[0])  # every Command line is the same size
    damaged = len({at // size for at in hit})
    # Show one damaged line next to what was sent, with the changed bytes marked.
    first = min(hit) // size
    sent_line, got_line = lines[first], bytes(wire[first * size : (first + 1) * size])
    print(f"   sent     {_printable(sent_line)}")
    print(f"   on wire  {_printable(got_line)}")
    marks = "".join("^" if a != b else " " for a, b in zip(sent_line, got_line, strict=True))
    print(f"            {marks.rstrip()}")
    print(
        f"   sent {COMMANDS} Commands ({len(wire)} bytes); corrupted {len(hit)} bytes, "
        f"damaging {damaged} lines"
    )
    report = tool.downlink(bytes(wire))
    leaked = [p for p in report.packets if p not in sent_packets]
    errors = ", ".join(f"{k} {n}" for k, n in sorted(report.errors.items()))
    print(f"   Brain counters: received {report.received}, lost {report.lost}")
    print(f"                   errors: {errors}")
    print(
        f"   delivered {len(report.packets)} = {COMMANDS} sent - {damaged} damaged; "
        f"corrupt Commands delivered: {len(leaked)}"
    )
    if leaked or len(report.packets) != COMMANDS - damaged:
        raise DemoError("the Brain's decoder let a corrupt Command through or dropped a good one")


def handshake_scene(tool: CodecTool) -> None:
    print("\n3. HANDSHAKE  a Brain built from another schema says Hello (C++ encodes it)")
    foreign = Hello(
        fingerprint=0x1BADB002,
        protocol_version=3,
        role=Role.BRAIN,
        boot_id=0x5EED,
        software_version="0.2.0-dev",
    )
    wire = tool.uplink(tool.roundtrip([framing.encode_packet(foreign, 0)]))
    decoder = framing.UplinkDecoder()
    [event] = decoder.feed(wire)
    if not isinstance(event, framing.Received):
        raise DemoError(f"the Hello did not decode: {event}")
    try:
        framing.check_hello(event.message)
    except FingerprintMismatch as exc:
        print(f"   Jetson refuses: {exc}")
    else:
        raise DemoError("a Hello with a foreign fingerprint was accepted")
    ours = Hello(messages.FINGERPRINT, messages.PROTOCOL_VERSION, Role.BRAIN, 0x5EED, "0.1.0")
    framing.check_hello(ours)
    print(f"   (a Hello with our fingerprint 0x{messages.FINGERPRINT:08X} is accepted)")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m protocol.demo", description=__doc__)
    parser.add_argument(
        "--tool",
        type=Path,
        default=DEFAULT_TOOL,
        help="the C++ codec tool (default: build/host/bin/pete_codec_tool)",
    )
    parser.add_argument("--seed", type=int, default=SEED, help="corruption and chunking seed")
    args = parser.parse_args(argv)
    if not args.tool.is_file():
        print(
            f"protocol.demo: {args.tool} is missing: run `make build` first "
            "(it builds the C++ codec tool this demo drives).",
            file=sys.stderr,
        )
        return 2
    tool = CodecTool(args.tool)
    rng = random.Random(args.seed)
    print(
        f"pete wire protocol v{messages.PROTOCOL_VERSION}, schema fingerprint "
        f"0x{messages.FINGERPRINT:08X}; Brain side: {args.tool}\n"
    )
    try:
        uplink_scene(tool, rng)
        downlink_scene(tool, rng)
        handshake_scene(tool)
    except (DemoError, ValueError, subprocess.TimeoutExpired, OSError) as exc:
        print(f"\nprotocol.demo: FAILED: {exc}", file=sys.stderr)
        return 1
    print("\nAll three behaved as protocol/README.md says.")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""`pete-protocol`: generate the codecs, check they are current, and inspect traffic."""

from __future__ import annotations

import argparse
import json
import os
import stat
import sys
from pathlib import Path
from typing import Any

from protocol.cli_conventions import make_parser
from protocol.errors import SchemaError
from protocol.schema import DEFAULT_SCHEMA, load_schema

DESCRIPTION = """\
The Brain <-> Jetson wire protocol: one schema (protocol/schema.toml), two generated codecs.

  pete-protocol info                       messages, sizes and the schema fingerprint
  pete-protocol generate                   rewrite the C++ and Python codecs from the schema
  pete-protocol check                      fail if a generated file is stale (run by the tests)
  pete-protocol encode Command --json '{"linear": 0.5}' --link down
                                           the exact bytes one message becomes on a link
  pete-protocol decode --link up < capture.bin
                                           one JSON line per message, text line or error

Links: `up` is Brain -> Jetson (PROS stream frames: COBS(stream id + packet) + 0x00);
`down` is Jetson -> Brain (':' + hex(packet) + newline). protocol/README.md has every byte.
"""


def _cmd_info(args: argparse.Namespace) -> int:
    from protocol import framing

    schema = load_schema(args.schema)
    print(f"schema      {args.schema}")
    print(f"version     {schema.version}")
    print(f"fingerprint 0x{schema.fingerprint:08X}")
    print(f"stream      {schema.stream!r}")
    print()
    print(f"{'id':>3}  {'message':<10} {'direction':<14} {'body':>5} {'up':>5} {'down':>5}")
    for m in schema.messages:
        up = len(framing.stream_frame(b"xxxx", bytes(framing.OVERHEAD + m.body_size)))
        down = 2 + 2 * (framing.OVERHEAD + m.body_size)
        print(f"{m.id:>3}  {m.name:<10} {m.direction:<14} {m.body_size:>5} {up:>5} {down:>5}")
        for f in m.fields:
            unit = f" [{f.unit}]" if f.unit else ""
            print(f"       {f.name:<18} {f.type:<11} {f.doc}{unit}")
    print("\n(up/down: bytes on the wire, worst case for the uplink's COBS)")
    return 0


def _cmd_generate(args: argparse.Namespace) -> int:
    from protocol.generate import outputs, write

    changed = write(outputs(args.schema))
    for out in changed:
        print(f"wrote {out.relative()}")
    if not changed:
        print("generated files are up to date")
    return 0


def _cmd_check(args: argparse.Namespace) -> int:
    from protocol.generate import outputs, stale

    bad = stale(outputs(args.schema))
    for out in bad:
        print(f"stale: {out.relative()} (run `pete-protocol generate`)", file=sys.stderr)
    if not bad:
        print("generated files match the schema")
    return 1 if bad else 0


def _cmd_golden(args: argparse.Namespace) -> int:
    from protocol.generate import GOLDEN_VECTORS, compute_golden, outputs, write

    cases = json.loads(GOLDEN_VECTORS.read_text())
    GOLDEN_VECTORS.write_text(json.dumps(compute_golden(cases, args.schema), indent=2) + "\n")
    write(outputs(args.schema))
    print(f"rewrote {GOLDEN_VECTORS.name} and its C++ twin: review the diff before committing")
    return 0


def _cmd_encode(args: argparse.Namespace) -> int:
    from protocol import framing, messages

    cls = messages.BY_NAME.get(args.message)
    if cls is None:
        raise ValueError(f"unknown message {args.message!r} (known: {', '.join(messages.BY_NAME)})")
    try:
        data = json.loads(args.json)
    except json.JSONDecodeError as exc:
        raise ValueError(f"--json is not valid JSON: {exc}") from None
    if not isinstance(data, dict):
        raise ValueError("--json must be a JSON object of field values")
    msg = framing.message_from_dict(cls, data)
    if args.link == "up":
        wire = framing.encode_uplink(msg, args.seq)
    elif args.link == "down":
        wire = framing.encode_downlink(msg, args.seq)
    else:
        wire = framing.encode_packet(msg, args.seq)
    if args.raw:
        sys.stdout.buffer.write(wire)
    else:
        print(wire.hex(" ") if args.spaced else wire.hex())
    return 0


def _event_json(event: Any) -> dict[str, Any]:
    from protocol import framing

    if isinstance(event, framing.Received):
        return {
            "type": "message",
            "name": event.message.NAME,
            "seq": event.seq,
            "fields": framing.message_to_dict(event.message),
        }
    if isinstance(event, framing.TextLine):
        return {"type": "text", "stream": event.stream, "text": event.text}
    return {"type": "error", "kind": event.kind.value, "detail": event.detail}


class _SerialReader:
    """A serial device read like a file: raw 8N1 at 115200 baud (what pros-cli opens), returning
    whatever has arrived, so that decoding keeps up with a live Brain."""

    def __init__(self, path: str) -> None:
        try:
            import serial
        except ImportError:
            raise ValueError(
                f"{path} is a serial device: reading it needs pyserial "
                "(pip install 'pacman-pete[jetson]')"
            ) from None
        try:
            self._port = serial.Serial(path, 115200, timeout=0.1)
        except serial.SerialException as exc:
            raise ValueError(f"cannot open {path}: {exc}") from None

    def read(self, size: int) -> bytes:
        data = self._port.read(max(1, self._port.in_waiting or 1))
        while not data:  # a quiet link is not the end of the input
            data = self._port.read(1)
        return data[:size] if len(data) > size else data

    def __enter__(self) -> _SerialReader:
        return self

    def __exit__(self, *exc: object) -> None:
        self._port.close()


def _open_input(path: str) -> Any:
    if path == "-":
        return sys.stdin.buffer
    try:
        if stat.S_ISCHR(os.stat(path).st_mode) and not path.startswith("/dev/std"):
            return _SerialReader(path)
    except FileNotFoundError:
        raise ValueError(f"{path}: no such file or device") from None
    return open(path, "rb")  # closed by the caller's with-block


def _cmd_decode(args: argparse.Namespace) -> int:
    from protocol import framing

    decoder = framing.UplinkDecoder() if args.link == "up" else framing.DownlinkDecoder()
    source = _open_input(args.input)
    digits = ""  # --hex: a chunk may end between the two digits of a byte
    with source:
        while True:
            chunk = source.read1(4096) if hasattr(source, "read1") else source.read(4096)
            if not chunk:
                break
            if args.hex:
                digits += "".join(chunk.decode(errors="replace").split())
                even = len(digits) - len(digits) % 2
                try:
                    chunk = bytes.fromhex(digits[:even])
                except ValueError:
                    raise ValueError(f"--hex input is not hex: {digits[:even][:60]!r}") from None
                digits = digits[even:]
            for event in decoder.feed(chunk):
                print(json.dumps(_event_json(event)), flush=True)
    if digits:
        raise ValueError("--hex input ends in the middle of a byte")
    if args.stats:
        print(json.dumps({"type": "stats", **decoder.stats.as_dict()}), flush=True)
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = make_parser("pete-protocol", DESCRIPTION)
    parser.add_argument(
        "--schema", type=Path, default=DEFAULT_SCHEMA, help="schema file (default: the shipped one)"
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser(
        "info",
        help="list messages, wire sizes and the fingerprint",
        description="List every message, its fields and wire sizes, and the schema fingerprint.",
    )
    p.set_defaults(func=_cmd_info)
    p = sub.add_parser(
        "generate",
        help="write the C++ and Python codecs from the schema",
        description="Write the C++ and Python codecs from the schema (only files that changed).",
    )
    p.set_defaults(func=_cmd_generate)
    p = sub.add_parser(
        "check",
        help="exit 1 if any generated file differs from the schema's output",
        description="Exit 1, naming each stale file, if a generated file differs from what the "
        "schema produces now; run `pete-protocol generate` to fix it.",
    )
    p.set_defaults(func=_cmd_check)
    p = sub.add_parser(
        "golden",
        help="recompute golden vector bytes after a deliberate schema change (review the diff!)",
        description="Recompute the bytes of protocol/golden_vectors.json after a deliberate schema "
        "change. Review the diff: golden vectors must not follow the codec by themselves.",
    )
    p.set_defaults(func=_cmd_golden)

    p = sub.add_parser(
        "encode",
        help="print the wire bytes of one message as hex",
        description="Print the wire bytes of one message as hex. "
        "Fields left out of --json keep their zero/default values. Enums are given "
        'by name ("autonomous"), flags as a list of names, text as a string.',
    )
    p.add_argument("message", help="message name, e.g. State or Command")
    p.add_argument("--json", default="{}", help="field values as a JSON object")
    p.add_argument("--seq", type=int, default=0, help="packet sequence number (0-255)")
    p.add_argument(
        "--link",
        choices=("up", "down", "packet"),
        default="packet",
        help="up: PROS stream frame; down: hex line; packet: the bare packet",
    )
    p.add_argument("--raw", action="store_true", help="write raw bytes instead of hex")
    p.add_argument("--spaced", action="store_true", help="separate hex bytes with spaces")
    p.set_defaults(func=_cmd_encode)

    p = sub.add_parser(
        "decode",
        help="read raw wire bytes and print one JSON object per message, text line or error",
        description="Read wire bytes and print one JSON object per message, text line or error.",
    )
    p.add_argument(
        "--link", choices=("up", "down"), required=True, help="which link the bytes are from"
    )
    p.add_argument("--input", default="-", help="file or device to read (default: stdin)")
    p.add_argument("--hex", action="store_true", help="the input is hex text rather than raw bytes")
    p.add_argument("--stats", action="store_true", help="print link counters at the end")
    p.set_defaults(func=_cmd_decode)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if getattr(args, "seq", 0) and not 0 <= args.seq <= 255:
        print("pete-protocol: error: --seq must be 0..255", file=sys.stderr)
        return 2
    try:
        return args.func(args)
    except SchemaError as exc:
        print(f"pete-protocol: schema error: {exc}", file=sys.stderr)
        return 2
    except (ValueError, OSError) as exc:
        print(f"pete-protocol: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())

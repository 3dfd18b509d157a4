"""Packets and the two link framings, in Python; protocol/README.md documents every byte.

Packet:   id u8 | seq u8 | len u8 | body | crc16 u16 LE  (CRC-16/CCITT-FALSE over id..body)
Uplink:   PROS frames each write() on a serial stream as COBS(stream_id[4] || packet) || 0x00
Downlink: b":" + lowercase hex(packet) + b"\\n" (never contains b"pR", which PROS's daemon eats)

Decoders are incremental: feed bytes in any chunking, get events out. A corrupt frame is never
delivered as a message; it is counted by kind and decoding resumes at the next frame boundary.
"""

from __future__ import annotations

import binascii
import math
import struct
from collections import Counter
from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import IntEnum, IntFlag
from types import ModuleType
from typing import Any

from cobs import cobs

from protocol import messages as _default_codec
from protocol.errors import ErrorKind, FingerprintMismatch, FrameError
from protocol.schema import INTEGER_RANGES

HEADER_SIZE = 3
CRC_SIZE = 2
OVERHEAD = HEADER_SIZE + CRC_SIZE
MAX_BODY = 255
MAX_PACKET = OVERHEAD + MAX_BODY
MAX_LINE = 1 + 2 * MAX_PACKET + 1
# Longest uplink frame we buffer before giving up on finding its delimiter (PROS's stream buffer
# is 2047 bytes, so no real frame comes close).
MAX_UPLINK_FRAME = 4096
MAX_TEXT_LINE = 1024
TEXT_STREAMS = (b"sout", b"serr", b"kdbg", b"jinx")
_HEADER = struct.Struct("<BBB")
_CRC = struct.Struct("<H")
_HEX_DIGITS = b"0123456789abcdef"


def crc16(data: bytes, crc: int = 0xFFFF) -> int:
    """CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF); binascii implements it in C."""
    return binascii.crc_hqx(data, crc)


# --- events -------------------------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class Received:
    """A message that passed every check."""

    message: Any
    seq: int


@dataclass(frozen=True, slots=True)
class TextLine:
    """A line the Brain printed on a PROS text stream (stdout is 'sout', stderr 'serr')."""

    stream: str
    text: str


@dataclass(frozen=True, slots=True)
class LinkError:
    kind: ErrorKind
    detail: str


Event = Received | TextLine | LinkError


@dataclass
class LinkStats:
    received: int = 0
    lost: int = 0  # gaps in the packet sequence numbers
    text_lines: int = 0
    errors: Counter[str] = field(default_factory=Counter)

    @property
    def error_total(self) -> int:
        return sum(self.errors.values())

    def as_dict(self) -> dict[str, Any]:
        return {
            "received": self.received,
            "lost": self.lost,
            "text_lines": self.text_lines,
            "errors": {k.value: self.errors.get(k.value, 0) for k in ErrorKind},
        }


def _gap(last: int | None, seq: int) -> int:
    """Packets missing between two sequence numbers. A repeat (gap 255) is counted as no loss:
    a correct sender never repeats, and 255 lost packets in a row would look like a dead link."""
    if last is None:
        return 0
    gap = (seq - last - 1) & 0xFF
    return 0 if gap == 0xFF else gap


# --- packets ------------------------------------------------------------------------------------


def encode_packet(msg: Any, seq: int) -> bytes:
    body = msg.encode_body()
    head = _HEADER.pack(msg.ID, seq & 0xFF, len(body)) + body
    return head + _CRC.pack(binascii.crc_hqx(head, 0xFFFF))


def decode_packet(packet: bytes, codec: ModuleType = _default_codec) -> tuple[Any, int]:
    """(message, seq) from a packet, or FrameError naming what is wrong with it."""
    n = len(packet)
    if n < OVERHEAD:
        raise FrameError(ErrorKind.TRUNCATED, f"{n} bytes is shorter than a packet header")
    declared = packet[2]
    if n != OVERHEAD + declared:
        kind = ErrorKind.TRUNCATED if n < OVERHEAD + declared else ErrorKind.BAD_LENGTH
        raise FrameError(kind, f"length byte says {declared}-byte body, frame has {n - OVERHEAD}")
    end = HEADER_SIZE + declared
    if binascii.crc_hqx(packet[:end], 0xFFFF) != _CRC.unpack_from(packet, end)[0]:
        raise FrameError(ErrorKind.BAD_CRC, "CRC mismatch")
    cls = codec.MESSAGES.get(packet[0])
    if cls is None:
        raise FrameError(ErrorKind.UNKNOWN_ID, f"no message with id {packet[0]}")
    if declared != cls.BODY_SIZE:
        raise FrameError(
            ErrorKind.BAD_LENGTH, f"{cls.NAME} body is {cls.BODY_SIZE} bytes, got {declared}"
        )
    try:
        msg = cls.decode_body(packet[HEADER_SIZE:end])
    except (ValueError, KeyError) as exc:
        raise FrameError(ErrorKind.BAD_VALUE, f"{cls.NAME}: invalid value ({exc})") from None
    return msg, packet[1]


# --- uplink: Brain -> Jetson --------------------------------------------------------------------


def stream_frame(stream: bytes, payload: bytes) -> bytes:
    """What PROS's serial driver puts on the wire for one write() of `payload` to `stream`."""
    return cobs.encode(stream + payload) + b"\x00"


def encode_uplink(msg: Any, seq: int, codec: ModuleType = _default_codec) -> bytes:
    return stream_frame(codec.STREAM, encode_packet(msg, seq))


class UplinkDecoder:
    """The Jetson's reader: undoes PROS's stream framing, decodes our stream, and turns the Brain's
    stdout/stderr into text lines."""

    def __init__(self, codec: ModuleType = _default_codec) -> None:
        self._codec = codec
        self._stream = codec.STREAM
        self._buf = bytearray()
        self._text: dict[bytes, bytearray] = {}
        self._last_seq: int | None = None
        self._skipping = False
        self.stats = LinkStats()

    def feed(self, data: bytes) -> list[Event]:
        events: list[Event] = []
        self._buf += data
        start = 0
        while True:
            end = self._buf.find(0, start)
            if end < 0:
                break
            frame = bytes(self._buf[start:end])
            start = end + 1
            if self._skipping:
                self._skipping = False  # the rest of an oversize frame
                continue
            if len(frame) > MAX_UPLINK_FRAME:  # the same verdict as when it arrives in pieces
                self._error(events, ErrorKind.OVERSIZE, f"{len(frame)}-byte frame")
            elif frame:
                self._frame(frame, events)
        del self._buf[:start]
        if len(self._buf) > MAX_UPLINK_FRAME:
            self._error(events, ErrorKind.OVERSIZE, f"no frame delimiter in {len(self._buf)} bytes")
            self._buf.clear()
            self._skipping = True
        return events

    def _error(self, events: list[Event], kind: ErrorKind, detail: str) -> None:
        self.stats.errors[kind.value] += 1
        events.append(LinkError(kind, detail))

    def _frame(self, frame: bytes, events: list[Event]) -> None:
        try:
            raw = cobs.decode(frame)
        except cobs.DecodeError as exc:
            self._error(events, ErrorKind.BAD_COBS, str(exc))
            return
        stream, payload = raw[:4], raw[4:]
        if len(stream) < 4:
            self._error(events, ErrorKind.TRUNCATED, f"{len(raw)}-byte frame has no stream id")
        elif stream == self._stream:
            self._packet(payload, events)
        elif stream in TEXT_STREAMS:
            self._text_bytes(stream, payload, events)
        else:
            self._error(events, ErrorKind.UNKNOWN_STREAM, f"stream {stream!r}")

    def _packet(self, payload: bytes, events: list[Event]) -> None:
        try:
            msg, seq = decode_packet(payload, self._codec)
        except FrameError as exc:
            self._error(events, exc.kind, exc.detail)
            return
        if not msg.UPLINK:
            self._error(events, ErrorKind.WRONG_DIRECTION, f"{msg.NAME} is never sent by the Brain")
            return
        self.stats.lost += _gap(self._last_seq, seq)
        self._last_seq = seq
        self.stats.received += 1
        events.append(Received(msg, seq))

    def _text_bytes(self, stream: bytes, payload: bytes, events: list[Event]) -> None:
        pending = self._text.setdefault(stream, bytearray())
        pending += payload
        name = stream.decode()
        while True:
            nl = pending.find(b"\n")
            if nl < 0:
                break
            line = pending[:nl].rstrip(b"\r").decode(errors="replace")
            del pending[: nl + 1]
            self.stats.text_lines += 1
            events.append(TextLine(name, line))
        if len(pending) > MAX_TEXT_LINE:  # a runaway line without a newline: flush it as is
            self.stats.text_lines += 1
            events.append(TextLine(name, pending.decode(errors="replace")))
            pending.clear()


# --- downlink: Jetson -> Brain ------------------------------------------------------------------


def encode_downlink(msg: Any, seq: int) -> bytes:
    return b":" + encode_packet(msg, seq).hex().encode() + b"\n"


class DownlinkDecoder:
    """The Brain's reader, in Python: for tests, tools and the fake Brain. Mirrors
    pete::msg::DownlinkDecoder in messages.hpp."""

    def __init__(self, codec: ModuleType = _default_codec) -> None:
        self._codec = codec
        self._buf = bytearray()
        self._skipping = False
        self._last_seq: int | None = None
        self.stats = LinkStats()

    def feed(self, data: bytes) -> list[Event]:
        events: list[Event] = []
        self._buf += data
        while True:
            nl = self._buf.find(b"\n")
            if nl < 0:
                break
            line = bytes(self._buf[:nl])
            del self._buf[: nl + 1]
            skipping, self._skipping = self._skipping, False
            self._line(line, events, skipping)
        if len(self._buf) > MAX_LINE:
            # Keep only a frame start that may still be good; the rest can never become a frame.
            colon = self._buf.rfind(b":")
            if colon > 0 and len(self._buf) - colon <= MAX_LINE:
                # Whatever precedes that ':' was cut off by it: never a complete frame.
                self._line(bytes(self._buf[:colon]), events, self._skipping, terminated=False)
                self._skipping = False
                del self._buf[:colon]
            else:
                self._error(events, ErrorKind.OVERSIZE, f"line longer than {MAX_LINE} bytes")
                self._buf.clear()
                self._skipping = True
        return events

    def _error(self, events: list[Event], kind: ErrorKind, detail: str) -> None:
        self.stats.errors[kind.value] += 1
        events.append(LinkError(kind, detail))

    def _line(
        self, line: bytes, events: list[Event], skipping: bool, terminated: bool = True
    ) -> None:
        # Every ':' starts a frame; anything before the first is garbage, and a frame cut short by
        # the next ':' is truncated. Only the last one can be complete.
        parts = line.split(b":")
        head = parts[0].strip(b"\r ")
        if head and not skipping:
            self._error(events, ErrorKind.GARBAGE, f"{len(head)} bytes outside any frame")
        for cut in parts[1:-1]:
            self._error(events, ErrorKind.TRUNCATED, f"frame cut after {len(cut)} hex digits")
        if len(parts) == 1:
            return
        if terminated:
            self._hex(parts[-1], events)
        else:
            self._error(events, ErrorKind.TRUNCATED, "frame cut by the next frame's start")

    def _hex(self, digits: bytes, events: list[Event]) -> None:
        if digits.translate(None, _HEX_DIGITS):
            self._error(events, ErrorKind.GARBAGE, "character outside [0-9a-f] in a frame")
            return
        if len(digits) % 2:
            self._error(events, ErrorKind.TRUNCATED, "odd number of hex digits")
            return
        if len(digits) > 2 * MAX_PACKET:
            self._error(events, ErrorKind.OVERSIZE, f"{len(digits) // 2}-byte frame")
            return
        try:
            msg, seq = decode_packet(bytes.fromhex(digits.decode()), self._codec)
        except FrameError as exc:
            self._error(events, exc.kind, exc.detail)
            return
        if not msg.DOWNLINK:
            self._error(
                events, ErrorKind.WRONG_DIRECTION, f"{msg.NAME} is never sent by the Jetson"
            )
            return
        self.stats.lost += _gap(self._last_seq, seq)
        self._last_seq = seq
        self.stats.received += 1
        events.append(Received(msg, seq))


# --- handshake ----------------------------------------------------------------------------------


def check_hello(hello: Any, codec: ModuleType = _default_codec) -> None:
    """Raise FingerprintMismatch, naming both fingerprints, if the peer runs another schema."""
    if hello.fingerprint != codec.FINGERPRINT:
        raise FingerprintMismatch(
            f"schema fingerprint mismatch: peer has 0x{hello.fingerprint:08X} "
            f"(protocol v{hello.protocol_version}, software {hello.software_version!r}), "
            f"we have 0x{codec.FINGERPRINT:08X} (protocol v{codec.PROTOCOL_VERSION}); "
            "regenerate both sides from the same protocol/schema.toml"
        )


def message_to_dict(msg: Any) -> dict[str, Any]:
    """JSON-ready fields, named as in the schema: enums by name, flags as a list of names."""
    out: dict[str, Any] = {}
    for info in msg.FIELDS:
        value = getattr(msg, info.name)
        if isinstance(value, IntFlag):
            out[info.name] = [m.name.lower() for m in type(value) if m in value]
        elif isinstance(value, IntEnum):
            out[info.name] = value.name.lower()
        elif isinstance(value, tuple):
            out[info.name] = list(value)
        else:
            out[info.name] = value
    return out


def message_from_dict(
    cls: type, data: Mapping[str, Any], codec: ModuleType = _default_codec
) -> Any:
    """Build a message from JSON-like data, with errors that name the field. Missing fields keep
    their zero defaults."""
    known = {f.name: f for f in cls.FIELDS}
    unknown = set(data) - set(known)
    if unknown:
        raise ValueError(
            f"{cls.NAME} has no field {sorted(unknown)[0]!r} (fields: {', '.join(known)})"
        )
    kwargs: dict[str, Any] = {}
    for name, value in data.items():
        kwargs[name] = _coerce(cls, known[name], value, codec)
    msg = cls(**kwargs)
    try:
        encode_packet(msg, 0)
    except struct.error as exc:
        raise ValueError(f"{cls.NAME}: {exc}") from None
    return msg


def _coerce(cls: type, info: Any, value: Any, codec: ModuleType) -> Any:
    where = f"{cls.NAME}.{info.name} ({info.type})"
    ftype = info.type
    if ftype in codec.ENUMS:
        enum = codec.ENUMS[ftype]
        if issubclass(enum, IntFlag):
            names = [value] if isinstance(value, str) else value
            if isinstance(names, int) and not isinstance(names, bool):
                known_bits = sum(m.value for m in enum)
                if names < 0 or names & ~known_bits:
                    raise ValueError(f"{where}: {names:#x} sets bits that are not flags")
                return enum(names)
            if not isinstance(names, list | tuple):
                raise ValueError(f"{where}: expected a flag name, a list of names or an integer")
            result = enum(0)
            for n in names:
                try:
                    result |= enum[str(n).upper()]
                except KeyError:
                    raise ValueError(f"{where}: unknown flag {n!r}") from None
            return result
        if isinstance(value, str):
            try:
                return enum[value.upper()]
            except KeyError:
                choices = ", ".join(m.name.lower() for m in enum)
                raise ValueError(f"{where}: {value!r} is not one of {choices}") from None
        if isinstance(value, bool) or not isinstance(value, int):
            raise ValueError(f"{where}: expected a name or an integer, got {value!r}")
        try:
            return enum(value)
        except ValueError:
            raise ValueError(f"{where}: {value!r} is not a valid value") from None
    if ftype.startswith("char["):
        if not isinstance(value, str):
            raise ValueError(f"{where}: expected a string")
        size = int(ftype[5:-1])
        if "\0" in value:
            raise ValueError(f"{where}: NUL ends text on the wire; it cannot be inside it")
        if len(value.encode()) > size:
            raise ValueError(f"{where}: {len(value.encode())} bytes does not fit in {size}")
        return value
    if "[" in ftype:
        base, count = ftype[:-1].split("[")
        if not isinstance(value, list | tuple) or len(value) != int(count):
            raise ValueError(f"{where}: expected a list of {count} values")
        return tuple(_scalar(where, base, v) for v in value)
    return _scalar(where, ftype, value)


def _scalar(where: str, base: str, value: Any) -> Any:
    if base == "bool":
        if not isinstance(value, bool):
            raise ValueError(f"{where}: expected true or false")
        return value
    if base == "f32":
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ValueError(f"{where}: expected a number")
        if abs(value) > 3.4028234663852886e38 or not math.isfinite(value):
            raise ValueError(f"{where}: {value!r} is not a finite f32")
        return float(value)
    if isinstance(value, bool) or not isinstance(value, int):
        raise ValueError(f"{where}: expected an integer")
    lo, hi = INTEGER_RANGES[base]
    if not lo <= value <= hi:
        raise ValueError(f"{where}: {value} is outside {lo}..{hi}")
    return value

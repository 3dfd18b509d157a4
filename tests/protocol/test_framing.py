"""Packets, the two link framings and their decoders, by example: every way a frame can be bad."""

from __future__ import annotations

import math
import struct

import pytest

from protocol import framing
from protocol.errors import ErrorKind, FingerprintMismatch, FrameError
from protocol.framing import (
    MAX_LINE,
    MAX_TEXT_LINE,
    MAX_UPLINK_FRAME,
    DownlinkDecoder,
    Event,
    LinkError,
    Received,
    TextLine,
    UplinkDecoder,
    crc16,
    decode_packet,
    encode_downlink,
    encode_packet,
    encode_uplink,
    message_from_dict,
    message_to_dict,
    stream_frame,
)
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

STATE = State(
    seq=12,
    time_ms=34567,
    phase=MatchPhase.DRIVER,
    phase_ms=1000,
    alliance=Alliance.BLUE,
    x=1.5,
    y=-0.25,
    heading=90.0,
    gps_error=0.125,  # exact in f32, so decoded == sent
    gps_status=GpsStatus.OK,
    left_speed=0.5,
    right_speed=-0.5,
    last_command_seq=11,
    faults=Fault.GPS_FAULT | Fault.LOOP_OVERRUN,
)
COMMAND = Command(seq=5, linear=0.75, angular=-1.5, intake=True, valid_ms=200)
LOG = Log(level=LogLevel.WARNING, time_ms=99, text="battery low")
HELLO = Hello(FINGERPRINT, 1, Role.JETSON, 0xDEADBEEF, "0.1.0")


def raw_packet(msg_id: int, seq: int, body: bytes, length: int | None = None) -> bytes:
    """A packet with a correct CRC around whatever header and body we like."""
    head = bytes([msg_id, seq, len(body) if length is None else length]) + body
    return head + struct.pack("<H", crc16(head))


def up(packet: bytes) -> bytes:
    return stream_frame(b"pete", packet)


def down(packet: bytes) -> bytes:
    return b":" + packet.hex().encode() + b"\n"


def messages_of(events: list[Event]) -> list[object]:
    return [e.message for e in events if isinstance(e, Received)]


def errors_of(events: list[Event]) -> list[ErrorKind]:
    return [e.kind for e in events if isinstance(e, LinkError)]


def feed_in_chunks(decoder: UplinkDecoder | DownlinkDecoder, data: bytes, size: int) -> list[Event]:
    events: list[Event] = []
    for i in range(0, len(data), size):
        events += decoder.feed(data[i : i + size])
    return events


# --- packets ------------------------------------------------------------------------------------


def test_crc16_is_ccitt_false() -> None:
    assert crc16(b"123456789") == 0x29B1  # the catalogue check value
    assert crc16(b"") == 0xFFFF


def test_packet_layout() -> None:
    packet = encode_packet(COMMAND, 0x1FF)  # seq wraps to one byte
    assert packet[:3] == bytes([Command.ID, 0xFF, Command.BODY_SIZE])
    assert len(packet) == framing.OVERHEAD + Command.BODY_SIZE
    assert packet[3:-2] == COMMAND.encode_body()
    assert struct.unpack("<H", packet[-2:])[0] == crc16(packet[:-2])
    assert decode_packet(packet) == (COMMAND, 0xFF)


@pytest.mark.parametrize(
    ("packet", "kind"),
    [
        (b"\x03\x00", ErrorKind.TRUNCATED),
        (encode_packet(COMMAND, 1)[:-1], ErrorKind.TRUNCATED),
        (encode_packet(COMMAND, 1) + b"\x00", ErrorKind.BAD_LENGTH),
        (raw_packet(Command.ID, 1, bytes(Command.BODY_SIZE + 1)), ErrorKind.BAD_LENGTH),
        (raw_packet(Command.ID, 1, bytes(Command.BODY_SIZE - 1)), ErrorKind.BAD_LENGTH),
        (raw_packet(99, 1, b"abc"), ErrorKind.UNKNOWN_ID),
        (raw_packet(0, 1, b""), ErrorKind.UNKNOWN_ID),
    ],
)
def test_bad_packets_are_classified(packet: bytes, kind: ErrorKind) -> None:
    with pytest.raises(FrameError) as info:
        decode_packet(packet)
    assert info.value.kind == kind


def test_every_single_bit_flip_of_a_packet_is_refused() -> None:
    packet = encode_packet(STATE, 3)
    for i in range(len(packet) * 8):
        damaged = bytearray(packet)
        damaged[i // 8] ^= 1 << (i % 8)
        with pytest.raises(FrameError):
            decode_packet(bytes(damaged))


def _state_body(**changes: int | float) -> bytes:
    """State's body with raw values patched in, bypassing the dataclass's types."""
    values = list(State._S.unpack(STATE.encode_body()))
    names = [f.name for f in State.FIELDS]
    for name, value in changes.items():
        values[names.index(name)] = value
    return State._S.pack(*values)


@pytest.mark.parametrize(
    "body",
    [
        _state_body(phase=3),
        _state_body(alliance=255),
        _state_body(gps_status=4),
        _state_body(x=math.nan),
        _state_body(heading=math.inf),
        _state_body(right_speed=-math.inf),
    ],
    ids=["phase 3", "alliance 255", "gps_status 4", "x NaN", "heading inf", "speed -inf"],
)
def test_values_no_peer_sends_are_bad_value(body: bytes) -> None:
    with pytest.raises(FrameError) as info:
        decode_packet(raw_packet(State.ID, 0, body))
    assert info.value.kind == ErrorKind.BAD_VALUE
    assert "State" in info.value.detail


def test_bool_other_than_0_or_1_is_bad_value() -> None:
    good = bytearray(COMMAND.encode_body())
    intake_at = 12  # u32 seq, f32 linear, f32 angular
    assert good[intake_at] == 1
    for value in (0, 1):
        good[intake_at] = value
        assert decode_packet(raw_packet(Command.ID, 0, bytes(good)))[0].intake is bool(value)
    for value in (2, 0xFF):
        good[intake_at] = value
        with pytest.raises(FrameError) as info:
            decode_packet(raw_packet(Command.ID, 0, bytes(good)))
        assert info.value.kind == ErrorKind.BAD_VALUE


def test_unknown_flag_bits_are_kept_like_the_cpp_decoder_does() -> None:
    body = _state_body(faults=0x8001)
    msg, _ = decode_packet(raw_packet(State.ID, 0, body))
    assert int(msg.faults) == 0x8001


def test_text_is_cut_at_a_character_boundary_and_nul_padded() -> None:
    msg = Log(LogLevel.INFO, 1, "é" * 30)  # 60 bytes of UTF-8 into a 48-byte field
    body = msg.encode_body()
    assert body[5:] == ("é" * 24).encode()
    decoded, _ = decode_packet(encode_packet(msg, 0))
    assert decoded.text == "é" * 24
    short, _ = decode_packet(encode_packet(Log(text="hi"), 0))
    assert short.text == "hi"


# --- uplink -------------------------------------------------------------------------------------


def test_uplink_frame_is_cobs_of_stream_id_and_packet() -> None:
    frame = encode_uplink(STATE, 9)
    assert frame.endswith(b"\x00") and frame.count(0) == 1
    assert stream_frame(b"sout", b"hi\n") == bytes.fromhex("08736f757468690a00")  # PROS docs
    assert UplinkDecoder().feed(frame) == [Received(STATE, 9)]


@pytest.mark.parametrize("size", [1, 2, 3, 7, 64, 10_000])
def test_uplink_any_chunking_gives_the_same_events(size: int) -> None:
    data = encode_uplink(STATE, 1) + encode_uplink(LOG, 2) + encode_uplink(HELLO, 3)
    expected = [Received(STATE, 1), Received(LOG, 2), Received(HELLO, 3)]
    assert feed_in_chunks(UplinkDecoder(), data, size) == expected


def test_text_lines_interleave_with_messages_across_writes() -> None:
    data = (
        stream_frame(b"sout", b"hel")
        + encode_uplink(STATE, 1)
        + stream_frame(b"serr", b"oops: ")
        + stream_frame(b"sout", b"lo\nwor")
        + encode_uplink(LOG, 2)
        + stream_frame(b"serr", b"bad\r\n")
        + stream_frame(b"sout", b"ld\n\n")
    )
    decoder = UplinkDecoder()
    events = feed_in_chunks(decoder, data, 5)
    assert events == [
        Received(STATE, 1),
        TextLine("sout", "hello"),
        Received(LOG, 2),
        TextLine("serr", "oops: bad"),
        TextLine("sout", "world"),
        TextLine("sout", ""),
    ]
    assert decoder.stats.text_lines == 4
    assert decoder.stats.received == 2
    assert decoder.stats.error_total == 0


def test_runaway_text_line_is_flushed_not_buffered_forever() -> None:
    decoder = UplinkDecoder()
    events: list[Event] = []
    for _ in range(MAX_TEXT_LINE // 100 + 1):
        events += decoder.feed(stream_frame(b"sout", b"x" * 100))
    assert events == [TextLine("sout", "x" * (100 * (MAX_TEXT_LINE // 100 + 1)))]
    assert decoder.feed(stream_frame(b"sout", b"next\n")) == [TextLine("sout", "next")]


def test_invalid_utf8_text_is_replaced_not_raised() -> None:
    assert UplinkDecoder().feed(stream_frame(b"sout", b"\xff\xfe!\n")) == [
        TextLine("sout", "\ufffd\ufffd!")
    ]


def test_unknown_stream_is_reported_and_skipped() -> None:
    decoder = UplinkDecoder()
    events = decoder.feed(stream_frame(b"abcd", b"payload") + encode_uplink(STATE, 0))
    assert errors_of(events) == [ErrorKind.UNKNOWN_STREAM]
    assert "abcd" in events[0].detail
    assert messages_of(events) == [STATE]
    assert decoder.stats.errors["unknown_stream"] == 1


def test_frame_too_short_for_a_stream_id_is_truncated() -> None:
    events = UplinkDecoder().feed(stream_frame(b"pe", b"") + encode_uplink(STATE, 0))
    assert errors_of(events) == [ErrorKind.TRUNCATED]
    assert messages_of(events) == [STATE]


def test_bad_cobs_is_reported_and_the_next_frame_decoded() -> None:
    decoder = UplinkDecoder()
    events = decoder.feed(b"\x09pete\x00" + encode_uplink(STATE, 0))  # code 9 promises 8 bytes
    assert errors_of(events) == [ErrorKind.BAD_COBS]
    assert messages_of(events) == [STATE]
    assert decoder.stats.errors["bad_cobs"] == 1


@pytest.mark.parametrize(
    ("packet", "kind"),
    [
        (encode_packet(STATE, 0)[:-2] + b"\x00\x00", ErrorKind.BAD_CRC),
        (encode_packet(STATE, 0)[:20], ErrorKind.TRUNCATED),
        (raw_packet(State.ID, 0, bytes(10)), ErrorKind.BAD_LENGTH),
        (raw_packet(200, 0, bytes(10)), ErrorKind.UNKNOWN_ID),
        (raw_packet(State.ID, 0, _state_body(phase=9)), ErrorKind.BAD_VALUE),
        (raw_packet(State.ID, 0, _state_body(y=math.nan)), ErrorKind.BAD_VALUE),
        (encode_packet(COMMAND, 0), ErrorKind.WRONG_DIRECTION),
    ],
)
def test_uplink_errors_are_counted_by_kind_and_never_delivered(
    packet: bytes, kind: ErrorKind
) -> None:
    decoder = UplinkDecoder()
    events = decoder.feed(up(packet) + encode_uplink(LOG, 1))
    assert errors_of(events) == [kind]
    assert messages_of(events) == [LOG]
    assert decoder.stats.errors[kind.value] == 1
    assert decoder.stats.error_total == 1
    assert decoder.stats.received == 1
    assert decoder.stats.as_dict()["errors"][kind.value] == 1


@pytest.mark.parametrize("split", [True, False])
def test_uplink_oversize_frame_is_dropped_and_decoding_recovers(split: bool) -> None:
    junk = b"\x01" * (MAX_UPLINK_FRAME + 100)  # valid COBS, far too long for any frame
    decoder = UplinkDecoder()
    if split:
        events = feed_in_chunks(decoder, junk, 1000) + decoder.feed(b"\x00")
    else:
        events = decoder.feed(junk + b"\x00")
    events += decoder.feed(encode_uplink(STATE, 0))
    assert errors_of(events) == [ErrorKind.OVERSIZE]
    assert messages_of(events) == [STATE]


def test_uplink_stray_delimiters_are_not_errors() -> None:
    decoder = UplinkDecoder()
    events = decoder.feed(b"\x00\x00" + encode_uplink(STATE, 0) + b"\x00")
    assert events == [Received(STATE, 0)]
    assert decoder.stats.error_total == 0


def test_uplink_lost_packets_are_counted_from_seq_gaps_across_the_wrap() -> None:
    decoder = UplinkDecoder()
    seqs = [250, 251, 254, 255, 0, 3, 4]
    for seq in seqs:
        decoder.feed(encode_uplink(STATE, seq))
    assert decoder.stats.received == len(seqs)
    assert decoder.stats.lost == 2 + 2  # 252, 253 and 1, 2


def test_uplink_refused_frames_do_not_move_the_seq_tracking() -> None:
    decoder = UplinkDecoder()
    decoder.feed(encode_uplink(STATE, 10))
    decoder.feed(up(encode_packet(COMMAND, 11)))  # wrong direction
    decoder.feed(encode_uplink(STATE, 11))
    assert decoder.stats.lost == 0


# --- downlink -----------------------------------------------------------------------------------


def test_downlink_line_format() -> None:
    line = encode_downlink(COMMAND, 4)
    assert line == b":" + encode_packet(COMMAND, 4).hex().encode() + b"\n"
    assert set(line[1:-1]) <= set(b"0123456789abcdef")


@pytest.mark.parametrize("size", [1, 2, 5, 33, 10_000])
def test_downlink_any_chunking_gives_the_same_events(size: int) -> None:
    data = encode_downlink(COMMAND, 1) + encode_downlink(HELLO, 2) + encode_downlink(COMMAND, 3)
    expected = [Received(COMMAND, 1), Received(HELLO, 2), Received(COMMAND, 3)]
    assert feed_in_chunks(DownlinkDecoder(), data, size) == expected


@pytest.mark.parametrize(
    ("data", "kinds"),
    [
        (b"hello" + encode_downlink(COMMAND, 0), [ErrorKind.GARBAGE]),
        (b":0300" + encode_downlink(COMMAND, 0), [ErrorKind.TRUNCATED]),
        (b":030\n", [ErrorKind.TRUNCATED]),
        (b":03ZZ\n", [ErrorKind.GARBAGE]),
        (down(encode_packet(COMMAND, 0)).upper(), [ErrorKind.GARBAGE]),
        (down(encode_packet(COMMAND, 0)[:-1] + b"\x00"), [ErrorKind.BAD_CRC]),
        (down(encode_packet(COMMAND, 0)[:-3]), [ErrorKind.TRUNCATED]),
        (down(raw_packet(99, 0, b"xyz")), [ErrorKind.UNKNOWN_ID]),
        (down(raw_packet(Command.ID, 0, bytes(3))), [ErrorKind.BAD_LENGTH]),
        (down(encode_packet(STATE, 0)), [ErrorKind.WRONG_DIRECTION]),
        (down(encode_packet(LOG, 0)), [ErrorKind.WRONG_DIRECTION]),
        (down(b"\x00" * (framing.MAX_PACKET + 1)), [ErrorKind.OVERSIZE]),
    ],
    ids=[
        "garbage before",
        "cut by next frame",
        "odd digits",
        "not hex",
        "upper case",
        "bad crc",
        "short",
        "unknown id",
        "bad length",
        "State",
        "Log",
        "too long",
    ],
)
def test_downlink_errors_are_counted_and_the_next_frame_decoded(
    data: bytes, kinds: list[ErrorKind]
) -> None:
    decoder = DownlinkDecoder()
    events = decoder.feed(data) + decoder.feed(encode_downlink(HELLO, 7))
    assert errors_of(events) == kinds
    assert messages_of(events)[-1] == HELLO
    assert decoder.stats.error_total == len(kinds)


@pytest.mark.parametrize("value", [2, 0x80])
def test_downlink_command_with_bool_2_is_bad_value(value: int) -> None:
    body = bytearray(COMMAND.encode_body())
    body[12] = value
    decoder = DownlinkDecoder()
    events = decoder.feed(down(raw_packet(Command.ID, 0, bytes(body))))
    assert errors_of(events) == [ErrorKind.BAD_VALUE]
    assert decoder.stats.received == 0


@pytest.mark.parametrize(("offset", "value"), [(15, 3), (16, 3), (15, 0xFF)])
def test_downlink_command_with_an_unknown_clamp_or_lift_action_is_bad_value(
    offset: int, value: int
) -> None:
    body = bytearray(COMMAND.encode_body())
    body[offset] = value
    decoder = DownlinkDecoder()
    events = decoder.feed(down(raw_packet(Command.ID, 0, bytes(body))))
    assert errors_of(events) == [ErrorKind.BAD_VALUE]
    assert decoder.stats.received == 0


@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf])
def test_downlink_command_with_non_finite_speed_is_bad_value(value: float) -> None:
    body = struct.pack("<IffBHBB", 1, value, 0.0, 0, 100, 0, 0)
    events = DownlinkDecoder().feed(down(raw_packet(Command.ID, 0, body)))
    assert errors_of(events) == [ErrorKind.BAD_VALUE]


def test_blank_lines_and_carriage_returns_between_frames_are_not_errors() -> None:
    decoder = DownlinkDecoder()
    events = decoder.feed(b"\n\r\n \n" + encode_downlink(COMMAND, 0) + b"\r\n")
    assert events == [Received(COMMAND, 0)]
    assert decoder.stats.error_total == 0


@pytest.mark.parametrize("chunk", [1, 64, 4096])
def test_downlink_oversize_line_is_dropped_and_decoding_recovers(chunk: int) -> None:
    decoder = DownlinkDecoder()
    junk = b"x" * (3 * MAX_LINE)
    events = feed_in_chunks(decoder, junk + b"\n" + encode_downlink(COMMAND, 1), chunk)
    assert messages_of(events) == [COMMAND]
    assert set(errors_of(events)) <= {ErrorKind.OVERSIZE, ErrorKind.GARBAGE}
    assert errors_of(events)
    # the buffer never grows without bound
    assert len(decoder._buf) <= MAX_LINE


def test_downlink_frame_after_a_long_garbage_run_on_the_same_line_is_kept() -> None:
    decoder = DownlinkDecoder()
    data = b"y" * (2 * MAX_LINE) + encode_downlink(COMMAND, 2)
    events = feed_in_chunks(decoder, data, 100)
    assert messages_of(events) == [COMMAND]


def test_downlink_lost_packets_are_counted_across_the_wrap() -> None:
    decoder = DownlinkDecoder()
    for seq in (253, 255, 0, 1, 5):
        decoder.feed(encode_downlink(COMMAND, seq))
    assert decoder.stats.received == 5
    assert decoder.stats.lost == 1 + 3


def test_stats_dict_lists_every_error_kind() -> None:
    decoder = DownlinkDecoder()
    decoder.feed(b"junk\n")
    stats = decoder.stats.as_dict()
    assert set(stats["errors"]) == {k.value for k in ErrorKind}
    assert stats["errors"]["garbage"] == 1
    assert sum(stats["errors"].values()) == 1


# --- handshake ----------------------------------------------------------------------------------


def test_check_hello_accepts_our_fingerprint() -> None:
    framing.check_hello(HELLO)


def test_check_hello_names_both_fingerprints() -> None:
    other = Hello(0x12345678, 9, Role.BRAIN, 1, "9.9.9")
    with pytest.raises(FingerprintMismatch) as info:
        framing.check_hello(other)
    text = str(info.value)
    assert "0x12345678" in text
    assert f"0x{FINGERPRINT:08X}" in text
    assert "9.9.9" in text


# --- dicts --------------------------------------------------------------------------------------


def test_message_to_dict_uses_schema_names() -> None:
    d = message_to_dict(STATE)
    assert d["phase"] == "driver"
    assert d["alliance"] == "blue"
    assert d["faults"] == ["gps_fault", "loop_overrun"]
    assert d["x"] == 1.5
    assert list(d) == [f.name for f in State.FIELDS]


@pytest.mark.parametrize("msg", [STATE, COMMAND, LOG, HELLO, State(), Command()])
def test_message_dict_round_trip(msg: object) -> None:
    assert message_from_dict(type(msg), message_to_dict(msg)) == msg


def test_missing_fields_keep_their_defaults() -> None:
    msg = message_from_dict(Command, {"linear": 0.5})
    assert msg == Command(linear=0.5)
    assert msg.valid_ms == 0 and msg.intake is False


def test_enums_and_flags_accept_names_and_numbers() -> None:
    a = message_from_dict(State, {"phase": "AUTONOMOUS", "faults": "gps_fault"})
    b = message_from_dict(State, {"phase": 1, "faults": int(Fault.GPS_FAULT)})
    assert a == b == State(phase=MatchPhase.AUTONOMOUS, faults=Fault.GPS_FAULT)


@pytest.mark.parametrize(
    ("cls", "data", "names"),
    [
        (Command, {"speed": 1.0}, ["Command", "'speed'"]),
        (Command, {"valid_ms": 70000}, ["Command.valid_ms", "70000", "0..65535"]),
        (Command, {"valid_ms": -1}, ["Command.valid_ms", "-1"]),
        (Command, {"seq": 1.5}, ["Command.seq", "integer"]),
        (Command, {"seq": True}, ["Command.seq", "integer"]),
        (Command, {"linear": math.nan}, ["Command.linear", "nan"]),
        (Command, {"linear": math.inf}, ["Command.linear", "inf"]),
        (Command, {"linear": 1e39}, ["Command.linear", "f32"]),
        (Command, {"linear": 10**400}, ["Command.linear", "f32"]),
        (Command, {"linear": "fast"}, ["Command.linear", "number"]),
        (Command, {"intake": 1}, ["Command.intake", "true or false"]),
        (State, {"phase": "halftime"}, ["State.phase", "'halftime'", "disabled"]),
        (State, {"phase": 7}, ["State.phase", "7"]),
        (State, {"phase": True}, ["State.phase"]),
        (State, {"phase": [1]}, ["State.phase"]),
        (State, {"faults": ["gps_fault", "on_fire"]}, ["State.faults", "'on_fire'"]),
        (State, {"faults": 1.5}, ["State.faults"]),
        (State, {"faults": 0x8000}, ["State.faults", "0x8000"]),
        (Log, {"text": "x" * 49}, ["Log.text", "49 bytes", "48"]),
        (Log, {"text": "é" * 25}, ["Log.text", "50 bytes"]),
        (Log, {"text": 5}, ["Log.text", "string"]),
        (Log, {"text": "a\0b"}, ["Log.text", "NUL"]),
        (Hello, {"fingerprint": 2**32}, ["Hello.fingerprint", "4294967296"]),
    ],
)
def test_message_from_dict_errors_name_the_field(
    cls: type, data: dict[str, object], names: list[str]
) -> None:
    with pytest.raises(ValueError) as info:
        message_from_dict(cls, data)
    for name in names:
        assert name in str(info.value)


def test_message_from_dict_accepts_the_edges_of_every_range() -> None:
    msg = message_from_dict(
        State, {"seq": 0xFFFFFFFF, "x": 3.4028234663852886e38, "faults": 0x3F, "time_ms": 0}
    )
    decoded, _ = decode_packet(encode_packet(msg, 0))
    assert decoded == msg
    assert message_from_dict(Log, {"text": "x" * 48}).text == "x" * 48


@pytest.mark.parametrize("link", ["up", "down"])
def test_a_repeated_seq_is_not_counted_as_loss(link: str) -> None:
    decoder = UplinkDecoder() if link == "up" else DownlinkDecoder()
    msg = HELLO  # goes both ways
    encode = encode_uplink if link == "up" else encode_downlink
    for seq in (7, 7, 8, 10):
        decoder.feed(encode(msg, seq))
    assert decoder.stats.received == 4
    assert decoder.stats.lost == 1  # only 9


@pytest.mark.parametrize("chunk", [1, 7, 10_000])
def test_a_frame_cut_by_the_next_colon_is_never_delivered_however_it_arrives(chunk: int) -> None:
    # The first line loses its newline and the next ':' opens a run too long for any frame: the
    # decoder's overflow path must not treat the cut frame as complete.
    first, second = encode_downlink(COMMAND, 1), encode_downlink(HELLO, 2)
    stream = first[:-1] + b":" + b"a" * 600 + b"\n" + second
    decoder = DownlinkDecoder()
    events = feed_in_chunks(decoder, stream, chunk)
    assert messages_of(events) == [HELLO]
    assert ErrorKind.TRUNCATED in errors_of(events)

"""Properties of both link decoders under random traffic and random damage.

Messages are drawn from the generated classes' FIELDS, so these tests follow the schema: a new
message or field is exercised without touching this file.

The model of what must come out: a frame is delivered exactly when its own bytes reached the decoder
unharmed and it travels the right way; on the uplink it must also start a frame, i.e. follow a 0x00
delimiter (COBS frames carry no start marker, so a frame glued to junk is lost with it). Nothing
else is ever delivered: no corrupt frame, no message that was not sent.
"""

from __future__ import annotations

import functools
import itertools
import operator
import re
from dataclasses import dataclass
from enum import IntFlag
from typing import Any

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from protocol import messages
from protocol.framing import (
    MAX_LINE,
    DownlinkDecoder,
    Event,
    LinkError,
    Received,
    TextLine,
    UplinkDecoder,
    encode_downlink,
    encode_packet,
    encode_uplink,
    stream_frame,
)

SETTINGS = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
RANGES = {
    "u8": (0, 0xFF),
    "u16": (0, 0xFFFF),
    "u32": (0, 0xFFFFFFFF),
    "i8": (-0x80, 0x7F),
    "i16": (-0x8000, 0x7FFF),
    "i32": (-0x80000000, 0x7FFFFFFF),
}
ARRAY = re.compile(r"^(\w+)\[(\d+)\]$")
CLASSES = list(messages.MESSAGES.values())
LINKS = ("up", "down")


# --- strategies from the schema -----------------------------------------------------------------


def scalar_strategy(base: str) -> st.SearchStrategy[Any]:
    if base == "f32":
        # every f32 is exactly a Python float, so decoded == sent
        return st.floats(width=32, allow_nan=False, allow_infinity=False)
    if base == "bool":
        return st.booleans()
    lo, hi = RANGES[base]
    return st.integers(lo, hi)


def text_strategy(size: int) -> st.SearchStrategy[str]:
    chars = st.characters(codec="utf-8", exclude_characters="\0")
    # keep what fits, cut at a character boundary as the codec does
    return st.text(chars, max_size=size).map(
        lambda s: s.encode()[:size].decode("utf-8", errors="ignore")
    )


def field_strategy(ftype: str, codec: Any = messages) -> st.SearchStrategy[Any]:
    if ftype in codec.ENUMS:
        enum = codec.ENUMS[ftype]
        members = list(enum)
        if issubclass(enum, IntFlag):
            return st.lists(st.sampled_from(members), unique=True).map(
                lambda ms: functools.reduce(operator.or_, ms, enum(0))
            )
        return st.sampled_from(members)
    match = ARRAY.match(ftype)
    if match:
        base, count = match.group(1), int(match.group(2))
        if base == "char":
            return text_strategy(count)
        return st.tuples(*[scalar_strategy(base)] * count)
    return scalar_strategy(ftype)


def message_strategy(cls: type, codec: Any = messages) -> st.SearchStrategy[Any]:
    fields = {f.name: field_strategy(f.type, codec) for f in cls.FIELDS}
    return st.fixed_dictionaries(fields).map(lambda kw: cls(**kw))


any_message = st.sampled_from(CLASSES).flatmap(message_strategy)


def wire(link: str, msg: Any, seq: int) -> bytes:
    return encode_uplink(msg, seq) if link == "up" else encode_downlink(msg, seq)


def travels(link: str, msg: Any) -> bool:
    return msg.UPLINK if link == "up" else msg.DOWNLINK


def decoder_for(link: str) -> UplinkDecoder | DownlinkDecoder:
    return UplinkDecoder() if link == "up" else DownlinkDecoder()


@dataclass(frozen=True)
class Frame:
    data: bytes
    msg: Any  # None for a text frame
    seq: int


@st.composite
def frames(draw: st.DrawFn, link: str, min_size: int = 1, max_size: int = 10) -> list[Frame]:
    """A valid stream: messages of every kind (some going the wrong way), and on the uplink the
    Brain's stdout/stderr text in between. seq numbers are unique so each frame is recognisable."""
    out: list[Frame] = []
    for seq in range(draw(st.integers(min_size, max_size))):
        if link == "up" and draw(st.integers(0, 4)) == 0:
            stream = draw(st.sampled_from([b"sout", b"serr"]))
            text = draw(st.binary(max_size=40))
            out.append(Frame(stream_frame(stream, text), None, seq))
            continue
        msg = draw(any_message)
        out.append(Frame(wire(link, msg, seq), msg, seq))
    return out


def chunked(data: bytes, cuts: list[int]) -> list[bytes]:
    points = sorted({min(c, len(data)) for c in cuts})
    bounds = [0, *points, len(data)]
    return [data[a:b] for a, b in itertools.pairwise(bounds)]


def run(link: str, chunks: list[bytes]) -> tuple[list[Event], UplinkDecoder | DownlinkDecoder]:
    decoder = decoder_for(link)
    events: list[Event] = []
    for chunk in chunks:
        events += decoder.feed(chunk)
    return events, decoder


def delivered(events: list[Event]) -> list[tuple[Any, int]]:
    return [(e.message, e.seq) for e in events if isinstance(e, Received)]


def expected(link: str, sent: list[Frame]) -> list[tuple[Any, int]]:
    return [(f.msg, f.seq) for f in sent if f.msg is not None and travels(link, f.msg)]


# --- properties ---------------------------------------------------------------------------------


@SETTINGS
@given(
    link=st.sampled_from(LINKS), data=st.binary(max_size=600), cuts=st.lists(st.integers(0, 600))
)
def test_random_bytes_never_raise_and_deliver_nothing_unsent(
    link: str, data: bytes, cuts: list[int]
) -> None:
    events, decoder = run(link, chunked(data, cuts))
    for msg, seq in delivered(events):
        # the only way out is the exact encoding we would have produced
        assert wire(link, msg, seq) in data
    assert decoder.stats.received == len(delivered(events))
    assert decoder.stats.error_total == sum(isinstance(e, LinkError) for e in events)


@SETTINGS
@given(
    link=st.sampled_from(LINKS),
    parts=st.lists(
        st.one_of(
            st.binary(max_size=80),
            st.tuples(any_message, st.integers(0, 255)),
        ),
        max_size=12,
    ),
    cuts=st.lists(st.integers(0, 2000)),
)
def test_valid_frames_mixed_with_random_bytes(link: str, parts: list[Any], cuts: list[int]) -> None:
    data = b"".join(p if isinstance(p, bytes) else wire(link, *p) for p in parts)
    sent = [p for p in parts if not isinstance(p, bytes)]
    events, _ = run(link, chunked(data, cuts))
    for msg, seq in delivered(events):
        assert wire(link, msg, seq) in data
        assert (msg, seq) in sent
        assert travels(link, msg)


@SETTINGS
@given(link=st.sampled_from(LINKS), data=st.data())
def test_any_chunking_of_a_valid_stream_gives_the_same_events(
    link: str, data: st.DataObject
) -> None:
    sent = data.draw(frames(link))
    stream = b"".join(f.data for f in sent)
    cuts = data.draw(st.lists(st.integers(0, len(stream)), max_size=20))
    whole, _ = run(link, [stream])
    pieces, decoder = run(link, chunked(stream, cuts))
    assert pieces == whole
    assert delivered(pieces) == expected(link, sent)
    wrong_way = sum(f.msg is not None and not travels(link, f.msg) for f in sent)
    assert decoder.stats.errors["wrong_direction"] == wrong_way
    assert decoder.stats.error_total == wrong_way
    if link == "up":
        assert all(isinstance(e, Received | TextLine | LinkError) for e in pieces)


@SETTINGS
@given(link=st.sampled_from(LINKS), data=st.data())
def test_lost_packets_are_counted_from_seq_gaps(link: str, data: st.DataObject) -> None:
    cls = data.draw(st.sampled_from([c for c in CLASSES if travels(link, c)]))
    start = data.draw(st.integers(0, 255))
    gaps = data.draw(st.lists(st.integers(0, 20), min_size=1, max_size=15))
    msg = data.draw(message_strategy(cls))
    seqs = [start]
    for gap in gaps:
        seqs.append((seqs[-1] + gap + 1) & 0xFF)
    _, decoder = run(link, [wire(link, msg, s) for s in seqs])
    assert decoder.stats.received == len(seqs)
    assert decoder.stats.lost == sum(gaps)


@SETTINGS
@given(
    msg=st.sampled_from([c for c in CLASSES if c.DOWNLINK]).flatmap(message_strategy),
    seq=st.integers(0, 255),
)
def test_downlink_encoding_never_contains_p_or_pr(msg: Any, seq: int) -> None:
    line = encode_downlink(msg, seq)
    assert b"pR" not in line
    assert b"p" not in line and b"R" not in line
    assert line == b":" + encode_packet(msg, seq).hex().encode() + b"\n"


@SETTINGS
@given(msg=any_message, seq=st.integers(0, 255))
def test_every_message_round_trips_through_its_link(msg: Any, seq: int) -> None:
    for link in LINKS:
        events, _ = run(link, [wire(link, msg, seq)])
        if travels(link, msg):
            assert events == [Received(msg, seq)]
        else:
            assert [e.kind.value for e in events if isinstance(e, LinkError)] == ["wrong_direction"]


# --- damage -------------------------------------------------------------------------------------

DAMAGES = (
    "none",
    "truncate",
    "flip",
    "flips",
    "inject",
    "garbage_before",
    "pr_before",
    "long_junk_before",
)
# A frame start and more hex digits than any line holds: the downlink's overflow path.
LONG_JUNK = st.text("0123456789abcdef", min_size=MAX_LINE - 100, max_size=MAX_LINE + 300).map(
    lambda digits: ":" + digits
)


@dataclass(frozen=True)
class Piece:
    data: bytes
    frame: Frame | None  # set when these bytes are exactly one sent frame, unharmed
    # A frame cut short. The junk that follows may happen to supply exactly what was cut (a lone
    # 0x00 or newline, say); delivering it then is no error, since those are the bytes we sent.
    cut_from: Frame | None = None


@st.composite
def damaged(draw: st.DrawFn, link: str, keep_delimiters: bool) -> list[Piece]:
    """A valid stream with some frames damaged and junk injected between others. On the uplink
    `keep_delimiters` spares each frame's closing 0x00 (losing it costs the next frame too)."""
    sent = draw(frames(link, min_size=2))
    pieces: list[Piece] = []
    for frame in sent:
        damage = draw(st.sampled_from(DAMAGES))
        data = frame.data
        body = data[:-1] if link == "up" and keep_delimiters else data
        tail = data[len(body) :]
        if damage == "none":
            pieces.append(Piece(data, frame))
        elif damage == "truncate":
            # often just the last byte: a whole packet whose end never came
            cut = draw(st.one_of(st.just(len(body) - 1), st.integers(0, len(body) - 1)))
            pieces.append(Piece(body[:cut] + tail, None, None if tail else frame))
        elif damage in ("flip", "flips"):
            count = 1 if damage == "flip" else draw(st.integers(2, 8))
            bits = draw(
                st.lists(
                    st.integers(0, 8 * len(body) - 1), min_size=count, max_size=count, unique=True
                )
            )
            hurt = bytearray(body)
            for bit in bits:
                hurt[bit // 8] ^= 1 << (bit % 8)
            pieces.append(Piece(bytes(hurt) + tail, None))
        elif damage == "inject":
            # Inside the frame proper: next to its opening ':' or its terminator, another ':' or
            # terminator would leave the frame whole.
            core, end = data[:-1], data[-1:]
            at = draw(st.integers(2, len(core) - 1))
            junk = draw(st.sampled_from([b"pR", b"pRa", b"pRpR", b"\x00", b":", b"\n"]))
            pieces.append(Piece(core[:at] + junk + core[at:] + end, None))
        else:
            if damage == "garbage_before":
                junk = draw(st.binary(min_size=1, max_size=64))
            elif damage == "long_junk_before":
                junk = draw(LONG_JUNK).encode()
            else:
                junk = b"pR" * draw(st.integers(1, 4)) + draw(st.binary(max_size=2))
            if link == "up" and keep_delimiters:
                junk += b"\x00"  # junk that ends where a frame would
            pieces += [Piece(junk, None), Piece(data, frame)]
    return pieces


def must_deliver(link: str, pieces: list[Piece]) -> list[tuple[Any, int]]:
    out = []
    before = b""
    for piece in pieces:
        f = piece.frame
        starts_frame = link == "down" or before == b"" or before.endswith(b"\x00")
        if f is not None and f.msg is not None and travels(link, f.msg) and starts_frame:
            out.append((f.msg, f.seq))
        before += piece.data
    return out


def check_damage(link: str, pieces: list[Piece], cuts: list[int]) -> set[int]:
    """Feed the damaged stream; return the seq numbers delivered."""
    stream = b"".join(p.data for p in pieces)
    events, decoder = run(link, chunked(stream, cuts))  # no exception escapes
    got = delivered(events)
    required = must_deliver(link, pieces)
    restorable = [(p.cut_from.msg, p.cut_from.seq) for p in pieces if p.cut_from is not None]
    # the unharmed frames, in order (seq numbers follow stream order): nothing good is lost ...
    assert [seq for _, seq in got] == sorted({seq for _, seq in got})
    assert all(item in got for item in required)
    # ... and nothing corrupt, unsent or going the wrong way is accepted
    assert all(item in required or item in restorable for item in got)
    assert all(travels(link, msg) for msg, _ in got)
    assert decoder.stats.received == len(got)
    return {seq for _, seq in got}


def cuts_for(data: st.DataObject) -> list[int]:
    return data.draw(st.lists(st.integers(0, 3000), max_size=10))


def next_after_damage(pieces: list[Piece], link: str) -> list[Frame]:
    """Unharmed frames that directly follow a damaged frame or injected junk."""
    return [
        after.frame
        for piece, after in itertools.pairwise(pieces)
        if piece.frame is None
        and after.frame is not None
        and after.frame.msg is not None
        and travels(link, after.frame.msg)
    ]


@settings(SETTINGS, max_examples=150)  # the overflow path needs a rarer combination
@given(data=st.data())
def test_downlink_damage_costs_only_the_damaged_frames(data: st.DataObject) -> None:
    pieces = data.draw(damaged("down", keep_delimiters=False))
    got = check_damage("down", pieces, cuts_for(data))
    # ':' starts every frame, so the one right after the damage always gets through
    assert {f.seq for f in next_after_damage(pieces, "down")} <= got


@SETTINGS
@given(data=st.data())
def test_uplink_damage_costs_only_the_damaged_frames(data: st.DataObject) -> None:
    pieces = data.draw(damaged("up", keep_delimiters=True))
    got = check_damage("up", pieces, cuts_for(data))
    # with the 0x00 delimiters intact, the frame after a damaged one always gets through
    assert {f.seq for f in next_after_damage(pieces, "up")} <= got


@SETTINGS
@given(data=st.data())
def test_uplink_damage_to_delimiters_costs_at_most_one_more_frame(data: st.DataObject) -> None:
    pieces = data.draw(damaged("up", keep_delimiters=False))
    got = check_damage("up", pieces, cuts_for(data))
    # a lost delimiter glues the next frame to the damaged one; the frame after that is safe
    hurt = {i for i, piece in enumerate(pieces) if piece.frame is None}
    for i, piece in enumerate(pieces):
        f = piece.frame
        if f is not None and f.msg is not None and f.msg.UPLINK and i - 1 not in hurt:
            assert f.seq in got

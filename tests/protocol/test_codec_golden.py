"""The codec against protocol/golden_vectors.json: bytes written down once, by hand-checked cases,
so that a change to the codec or the schema that moves a byte fails here (and in the C++ twin,
tests/cpp/protocol/golden_vectors.inc)."""

from __future__ import annotations

import json
from typing import Any

import pytest

from protocol import framing, messages
from protocol.errors import ErrorKind
from protocol.framing import LinkError, Received
from protocol.generate import GOLDEN_VECTORS, golden_cpp, outputs, stale
from protocol.schema import load_schema

VECTORS: list[dict[str, Any]] = json.loads(GOLDEN_VECTORS.read_text())


def vector_id(v: dict[str, Any]) -> str:
    return v.get("note", v["message"])


def build(v: dict[str, Any]) -> Any:
    return framing.message_from_dict(messages.BY_NAME[v["message"]], v["fields"])


def test_vectors_cover_every_message() -> None:
    assert {v["message"] for v in VECTORS} == set(messages.BY_NAME)


@pytest.mark.parametrize("v", VECTORS, ids=vector_id)
def test_encoding_matches_the_vector(v: dict[str, Any]) -> None:
    msg = build(v)
    seq = v["seq"]
    assert framing.encode_packet(msg, seq).hex() == v["packet"]
    assert framing.encode_uplink(msg, seq).hex() == v["uplink"]
    assert framing.encode_downlink(msg, seq).decode() == v["downlink"]


@pytest.mark.parametrize("v", VECTORS, ids=vector_id)
def test_vector_fields_survive_the_dict_round_trip(v: dict[str, Any]) -> None:
    msg = build(v)
    as_dict = framing.message_to_dict(msg)
    for name, value in v["fields"].items():
        if isinstance(value, float):
            # f32 on the wire: the dict holds the Python float the caller gave
            assert as_dict[name] == pytest.approx(value)
        else:
            assert as_dict[name] == value, name
    assert framing.message_from_dict(type(msg), as_dict) == msg


@pytest.mark.parametrize("v", VECTORS, ids=vector_id)
def test_packet_decodes_to_the_same_message(v: dict[str, Any]) -> None:
    msg = build(v)
    decoded, seq = framing.decode_packet(bytes.fromhex(v["packet"]))
    assert seq == v["seq"]
    assert type(decoded) is type(msg)
    # the wire carries f32: compare after the same rounding
    assert framing.encode_packet(decoded, seq).hex() == v["packet"]
    for info in msg.FIELDS:
        expected, got = getattr(msg, info.name), getattr(decoded, info.name)
        if info.type == "f32":
            assert got == pytest.approx(expected, rel=1e-6, abs=1e-30)
        else:
            assert got == expected, info.name


@pytest.mark.parametrize("v", VECTORS, ids=vector_id)
def test_uplink_decoder_accepts_or_refuses_by_direction(v: dict[str, Any]) -> None:
    cls = messages.BY_NAME[v["message"]]
    decoder = framing.UplinkDecoder()
    events = decoder.feed(bytes.fromhex(v["uplink"]))
    assert len(events) == 1
    if cls.UPLINK:
        assert isinstance(events[0], Received)
        assert events[0].seq == v["seq"]
        assert framing.encode_packet(events[0].message, v["seq"]).hex() == v["packet"]
        assert decoder.stats.received == 1
    else:
        assert events[0] == LinkError(ErrorKind.WRONG_DIRECTION, events[0].detail)
        assert cls.NAME in events[0].detail
        assert decoder.stats.errors["wrong_direction"] == 1
        assert decoder.stats.received == 0


@pytest.mark.parametrize("v", VECTORS, ids=vector_id)
def test_downlink_decoder_accepts_or_refuses_by_direction(v: dict[str, Any]) -> None:
    cls = messages.BY_NAME[v["message"]]
    decoder = framing.DownlinkDecoder()
    events = decoder.feed(v["downlink"].encode())
    assert len(events) == 1
    if cls.DOWNLINK:
        assert isinstance(events[0], Received)
        assert events[0].seq == v["seq"]
        assert framing.encode_packet(events[0].message, v["seq"]).hex() == v["packet"]
    else:
        assert isinstance(events[0], LinkError)
        assert events[0].kind == ErrorKind.WRONG_DIRECTION
        assert cls.NAME in events[0].detail


def test_directions_are_what_the_schema_says() -> None:
    # If these flip, the direction tests above would pass for the wrong reason.
    assert messages.Command.DOWNLINK and not messages.Command.UPLINK
    assert messages.State.UPLINK and not messages.State.DOWNLINK
    assert messages.Log.UPLINK and not messages.Log.DOWNLINK
    assert messages.Hello.UPLINK and messages.Hello.DOWNLINK


def test_the_whole_vector_stream_decodes_in_order() -> None:
    up, down = framing.UplinkDecoder(), framing.DownlinkDecoder()
    up_events = up.feed(b"".join(bytes.fromhex(v["uplink"]) for v in VECTORS))
    down_events = down.feed(b"".join(v["downlink"].encode() for v in VECTORS))
    assert [type(e.message).NAME for e in up_events if isinstance(e, Received)] == [
        v["message"] for v in VECTORS if messages.BY_NAME[v["message"]].UPLINK
    ]
    assert [type(e.message).NAME for e in down_events if isinstance(e, Received)] == [
        v["message"] for v in VECTORS if messages.BY_NAME[v["message"]].DOWNLINK
    ]


def test_hello_vectors_carry_this_schemas_fingerprint() -> None:
    hellos = [v for v in VECTORS if v["message"] == "Hello"]
    assert hellos
    for v in hellos:
        assert v["fields"]["fingerprint"] == messages.FINGERPRINT
        framing.check_hello(build(v))  # raises FingerprintMismatch otherwise


def test_pr_pair_in_a_log_stays_out_of_the_downlink_alphabet() -> None:
    (v,) = [v for v in VECTORS if "pR" in str(v["fields"].get("text", ""))]
    assert "7052" in v["packet"]  # the pair is really in the bytes
    assert "p" not in v["downlink"] and "R" not in v["downlink"]


def test_generated_files_are_current() -> None:
    """`pete-protocol check`: fails when someone edits the schema and forgets to regenerate."""
    bad = stale(outputs())
    assert not bad, "stale: " + ", ".join(o.relative() for o in bad)


def test_cpp_golden_include_matches_the_json() -> None:
    text = golden_cpp(load_schema(), VECTORS)
    for v in VECTORS:
        assert f'"{v["packet"]}"' in text
        assert f'"{v["uplink"]}"' in text

"""Loading and validating protocol/schema.toml, and what its fingerprint depends on."""

from __future__ import annotations

import copy
import tomllib
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from protocol import messages
from protocol.errors import SchemaError
from protocol.schema import DEFAULT_SCHEMA, MAX_BODY, canonical_text, load_schema, parse_schema

Raw = dict[str, Any]


def shipped_raw() -> Raw:
    return tomllib.loads(DEFAULT_SCHEMA.read_text())


def message(raw: Raw, name: str) -> Raw:
    return next(m for m in raw["messages"] if m["name"] == name)


def field(raw: Raw, msg: str, name: str) -> Raw:
    return next(f for f in message(raw, msg)["fields"] if f["name"] == name)


def fingerprint_after(mutate: Callable[[Raw], None]) -> int:
    raw = shipped_raw()
    mutate(raw)
    return parse_schema(raw).fingerprint


# --- the shipped schema -------------------------------------------------------------------------


def test_shipped_schema_loads_with_the_expected_shape() -> None:
    schema = load_schema()
    assert schema.stream == "pete"
    assert [m.name for m in schema.messages] == [
        "Hello",
        "State",
        "Command",
        "Log",
        "Partner",
        "PartnerStatus",
    ]
    hello = schema.message("Hello")
    assert hello.fields[0].name == "fingerprint"
    assert hello.direction == "both"
    assert schema.message("Command").downlink and not schema.message("Command").uplink
    assert schema.message("State").uplink and not schema.message("State").downlink
    assert all(m.body_size <= MAX_BODY for m in schema.messages)
    # the generated codec carries the fingerprint and sizes of this schema
    assert schema.fingerprint == messages.FINGERPRINT
    for m in schema.messages:
        assert m.body_size == messages.BY_NAME[m.name].BODY_SIZE
        assert m.id == messages.BY_NAME[m.name].ID


def test_fingerprint_is_stable_across_loads() -> None:
    first, second = load_schema(), load_schema()
    assert first.fingerprint == second.fingerprint
    assert canonical_text(first) == canonical_text(second)
    assert parse_schema(shipped_raw()).fingerprint == first.fingerprint
    assert 0 <= first.fingerprint <= 0xFFFFFFFF


def test_asking_for_an_unknown_message_names_the_known_ones() -> None:
    with pytest.raises(SchemaError, match=r"'Nope'.*Hello, State, Command, Log"):
        load_schema().message("Nope")


def _rename_message(raw: Raw) -> None:
    message(raw, "Log")["name"] = "Diagnostic"


def _change_id(raw: Raw) -> None:
    message(raw, "Log")["id"] = 9


def _rename_field(raw: Raw) -> None:
    field(raw, "Command", "linear")["name"] = "forward"


def _retype_field(raw: Raw) -> None:
    field(raw, "Command", "valid_ms")["type"] = "u32"


def _resize_text(raw: Raw) -> None:
    field(raw, "Log", "text")["type"] = "char[47]"


def _swap_fields(raw: Raw) -> None:
    fields = message(raw, "Command")["fields"]
    fields[1], fields[2] = fields[2], fields[1]


def _change_enum_value(raw: Raw) -> None:
    raw["enums"]["GpsStatus"]["values"]["absent"] = 7


def _rename_enum_value(raw: Raw) -> None:
    values = raw["enums"]["Alliance"]["values"]
    values["green"] = values.pop("blue")


def _change_flag_bit(raw: Raw) -> None:
    raw["flags"]["Fault"]["bits"]["loop_overrun"] = 9


def _change_stream(raw: Raw) -> None:
    raw["protocol"]["stream"] = "pet2"


def _change_version(raw: Raw) -> None:
    raw["protocol"]["version"] += 1


def _change_direction(raw: Raw) -> None:
    message(raw, "Log")["direction"] = "both"


def _add_field(raw: Raw) -> None:
    message(raw, "Command")["fields"].append({"name": "extra", "type": "u8"})


@pytest.mark.parametrize(
    "mutate",
    [
        _rename_message,
        _change_id,
        _rename_field,
        _retype_field,
        _resize_text,
        _swap_fields,
        _change_enum_value,
        _rename_enum_value,
        _change_flag_bit,
        _change_stream,
        _change_version,
        _change_direction,
        _add_field,
    ],
)
def test_fingerprint_changes_with_anything_on_the_wire(mutate: Callable[[Raw], None]) -> None:
    assert fingerprint_after(mutate) != load_schema().fingerprint


def _change_docs(raw: Raw) -> None:
    message(raw, "Command")["doc"] = "something else entirely"
    field(raw, "Command", "linear")["doc"] = "reworded"
    raw["enums"]["Role"]["doc"] = "who said hello"
    raw["flags"]["Fault"]["doc"] = "what is wrong"


def _change_units(raw: Raw) -> None:
    field(raw, "Command", "linear")["unit"] = "furlong/fortnight"
    field(raw, "State", "x")["unit"] = ""


@pytest.mark.parametrize("mutate", [_change_docs, _change_units])
def test_fingerprint_ignores_docs_and_units(mutate: Callable[[Raw], None]) -> None:
    raw = shipped_raw()
    mutate(raw)
    assert raw != shipped_raw()  # the mutation did something
    assert parse_schema(raw).fingerprint == load_schema().fingerprint


# --- every validation error names what is wrong --------------------------------------------------


def _with(mutate: Callable[[Raw], None]) -> Raw:
    raw = shipped_raw()
    mutate(raw)
    return raw


def _set(path: tuple[Any, ...], value: Any) -> Callable[[Raw], None]:
    def mutate(raw: Raw) -> None:
        target: Any = raw
        for key in path[:-1]:
            target = (
                message(raw, key) if isinstance(key, str) and key[:1].isupper() else target[key]
            )
        target[path[-1]] = value

    return mutate


def _set_field(msg: str, name: str, key: str, value: Any) -> Callable[[Raw], None]:
    def mutate(raw: Raw) -> None:
        field(raw, msg, name)[key] = value

    return mutate


def _add_message(**entry: Any) -> Callable[[Raw], None]:
    def mutate(raw: Raw) -> None:
        raw["messages"].append(entry)

    return mutate


def _drop_hello(raw: Raw) -> None:
    raw["messages"] = [m for m in raw["messages"] if m["name"] != "Hello"]


def _fingerprint_second(raw: Raw) -> None:
    fields = message(raw, "Hello")["fields"]
    fields[0], fields[1] = fields[1], fields[0]


def _duplicate_field(raw: Raw) -> None:
    message(raw, "Command")["fields"].append({"name": "linear", "type": "f32"})


def _enum(name: str, table: Raw, section: str = "enums") -> Callable[[Raw], None]:
    def mutate(raw: Raw) -> None:
        raw.setdefault(section, {})[name] = table

    return mutate


BIG = [{"name": f"f{i}", "type": "u32"} for i in range(64)]  # 256 bytes

ERROR_CASES: list[tuple[str, Callable[[Raw], None], list[str]]] = [
    (
        "duplicate id",
        _add_message(name="Extra", id=3, direction="both", fields=[]),
        ["'Extra'", "id 3", "Command"],
    ),
    (
        "duplicate name",
        _add_message(name="Log", id=9, direction="both", fields=[]),
        ["'Log'", "used twice"],
    ),
    (
        "message named like a type",
        _add_message(name="Role", id=9, direction="both", fields=[]),
        ["'Role'", "used twice"],
    ),
    (
        "unknown type",
        _set_field("Command", "linear", "type", "f64"),
        ["'Command'", "'linear'", "unknown type 'f64'"],
    ),
    (
        "unknown array element",
        _set_field("Command", "linear", "type", "q7[3]"),
        ["'Command'", "'linear'", "'q7'"],
    ),
    (
        "array of enums",
        _set_field("State", "phase", "type", "MatchPhase[2]"),
        ["'State'", "'phase'", "arrays hold numeric types", "'MatchPhase'"],
    ),
    (
        "zero-length array",
        _set_field("Log", "text", "type", "char[0]"),
        ["'Log'", "'text'", "array length"],
    ),
    ("bare char", _set_field("Log", "text", "type", "char"), ["'Log'", "'text'", "char[N]"]),
    (
        "body > 255",
        _add_message(name="Huge", id=9, direction="both", fields=BIG),
        ["'Huge'", "256 bytes", "255"],
    ),
    ("bad direction", _set(("Log", "direction"), "sideways"), ["'Log'", "direction"]),
    ("id 0", _set(("Log", "id"), 0), ["'Log'", "id must be 1..255"]),
    ("id 256", _set(("Log", "id"), 256), ["'Log'", "id must be 1..255"]),
    ("id not an int", _set(("Log", "id"), "4"), ["'Log'", "`id` must be int"]),
    ("id a bool", _set(("Log", "id"), True), ["'Log'", "`id` must be int"]),
    ("message without fields", _set(("Log", "fields"), "none"), ["'Log'", "`fields`"]),
    (
        "message name not CamelCase",
        _add_message(name="bad_name", id=9, direction="both", fields=[]),
        ["'bad_name'", "CamelCase"],
    ),
    ("Hello missing", _drop_hello, ["Hello", "fingerprint"]),
    ("fingerprint not first", _fingerprint_second, ["Hello", "fingerprint"]),
    (
        "fingerprint not u32",
        _set_field("Hello", "fingerprint", "type", "u16"),
        ["'Hello'", "fingerprint is u32"],
    ),
    ("Hello one way", _set(("Hello", "direction"), "brain->jetson"), ["'Hello'", "both ways"]),
    ("stream too long", _set(("protocol", "stream"), "peter"), ["stream", "'peter'"]),
    ("stream not ASCII", _set(("protocol", "stream"), "péte"), ["stream", "4 ASCII"]),
    ("stream used by PROS", _set(("protocol", "stream"), "sout"), ["stream", "'sout'", "PROS"]),
    ("version too big", _set(("protocol", "version"), 70000), ["version", "u16"]),
    (
        "enum value out of range",
        _enum("Big", {"type": "u8", "values": {"a": 0, "b": 256}}),
        ["enum Big", "b = 256", "0..255"],
    ),
    (
        "negative enum value",
        _enum("Neg", {"type": "u8", "values": {"a": -1}}),
        ["enum Neg", "a = -1"],
    ),
    (
        "flag bit out of range",
        _enum("Bits", {"type": "u8", "bits": {"a": 8}}, "flags"),
        ["flags Bits", "a = 8", "0..7"],
    ),
    (
        "enum values shared",
        _enum("Twice", {"values": {"a": 1, "b": 1}}),
        ["enum Twice", "share the value 1"],
    ),
    (
        "signed enum base",
        _enum("Signed", {"type": "i8", "values": {"a": 1}}),
        ["enum Signed", "unsigned", "'i8'"],
    ),
    ("empty enum", _enum("Empty", {"values": {}}), ["enum Empty", "empty"]),
    ("enum name not CamelCase", _enum("lower", {"values": {"a": 1}}), ["enum lower", "CamelCase"]),
    (
        "enum and flags share a name",
        _enum("Role", {"bits": {"a": 1}}, "flags"),
        ["Role", "declared twice"],
    ),
    ("reserved enum value", _enum("Kw", {"values": {"class": 1}}), ["enum Kw", "'class'"]),
    (
        "reserved field name",
        _set_field("Command", "linear", "name", "return"),
        ["'Command'", "'return'", "keyword"],
    ),
    ("field named id", _set_field("Command", "linear", "name", "id"), ["'Command'", "'id'"]),
    (
        "field name not snake_case",
        _set_field("Command", "linear", "name", "Linear"),
        ["'Command'", "'Linear'", "lower_snake_case"],
    ),
    ("duplicate field", _duplicate_field, ["'Command'", "duplicate field 'linear'"]),
    (
        "field without type",
        _add_message(name="Typeless", id=9, direction="both", fields=[{"name": "a"}]),
        ["'Typeless'", "'a'", "`type`"],
    ),
]


@pytest.mark.parametrize(
    ("mutate", "expected"),
    [pytest.param(m, e, id=i) for i, m, e in ERROR_CASES],
)
def test_invalid_schema_is_refused_naming_the_culprit(
    mutate: Callable[[Raw], None], expected: list[str]
) -> None:
    with pytest.raises(SchemaError) as info:
        parse_schema(_with(mutate))
    for part in expected:
        assert part in str(info.value)


def test_missing_protocol_table_and_messages_are_refused() -> None:
    raw = shipped_raw()
    del raw["protocol"]
    with pytest.raises(SchemaError, match="missing `protocol`"):
        parse_schema(raw)
    raw = shipped_raw()
    raw["messages"] = []
    with pytest.raises(SchemaError, match=r"no \[\[messages\]\]"):
        parse_schema(raw)


def test_the_reserved_words_cover_both_generated_languages() -> None:
    # Python-only and C++-only keywords both break one of the generated codecs.
    for word in ("async", "lambda", "nonlocal", "namespace", "virtual", "operator", "typename"):
        raw = _with(_set_field("Command", "linear", "name", word))
        with pytest.raises(SchemaError, match=f"'{word}'"):
            parse_schema(raw)


def test_message_names_that_collide_in_the_generated_code_are_refused() -> None:
    # AnyMessage in messages.hpp has one member per message, named in lower case.
    for name in ("Seq", "Switch", "Class"):
        raw = _with(_add_message(name=name, id=9, direction="both", fields=[]))
        with pytest.raises(SchemaError, match=f"'{name}'"):
            parse_schema(raw)
    raw = _with(_add_message(name="LOG", id=9, direction="both", fields=[]))
    with pytest.raises(SchemaError, match="'LOG'"):
        parse_schema(raw)
    # Names the generated modules define themselves.
    for name in ("FieldInfo", "AnyMessage", "Direction"):
        raw = _with(_add_message(name=name, id=9, direction="both", fields=[]))
        with pytest.raises(SchemaError, match=f"'{name}'"):
            parse_schema(raw)


@pytest.mark.parametrize("text", ["two\nlines", "back\\slash", "bell\x07"])
def test_docs_and_units_that_would_break_generated_code_are_refused(text: str) -> None:
    raw = _with(_set_field("Command", "linear", "doc", text))
    with pytest.raises(SchemaError, match=r"'Command'.*'linear'"):
        parse_schema(raw)
    raw = _with(_set_field("Command", "linear", "unit", text))
    with pytest.raises(SchemaError, match=r"'Command'.*'linear'"):
        parse_schema(raw)
    raw = _with(_set(("Command", "doc"), text))
    with pytest.raises(SchemaError, match="'Command'"):
        parse_schema(raw)


# --- files --------------------------------------------------------------------------------------


def test_missing_file_names_the_path(tmp_path: Path) -> None:
    path = tmp_path / "nowhere.toml"
    with pytest.raises(SchemaError, match=r"nowhere\.toml: schema file not found"):
        load_schema(path)


def test_bad_toml_names_the_path(tmp_path: Path) -> None:
    path = tmp_path / "broken.toml"
    path.write_text('[protocol]\nversion = 1\nstream = "pete\n')
    with pytest.raises(SchemaError, match=r"broken\.toml: not valid TOML"):
        load_schema(path)


def test_errors_from_a_file_name_the_file_and_the_message(tmp_path: Path) -> None:
    text = DEFAULT_SCHEMA.read_text().replace('name = "Log"\nid = 4', 'name = "Log"\nid = 3')
    assert text != DEFAULT_SCHEMA.read_text()
    path = tmp_path / "dup.toml"
    path.write_text(text)
    with pytest.raises(SchemaError, match=r"dup\.toml: message 'Log': id 3 is already used"):
        load_schema(path)


def test_a_copy_of_the_schema_loads_identically(tmp_path: Path) -> None:
    path = tmp_path / "copy.toml"
    path.write_text(DEFAULT_SCHEMA.read_text())
    copied = load_schema(path)
    assert copied.fingerprint == load_schema().fingerprint
    assert copied.source == str(path)
    assert copy.deepcopy(copied.messages) == load_schema().messages

"""Load and validate the message schema, and compute its fingerprint.

Everything the generators need is turned into plain dataclasses here, so that a bad schema fails
once, with an error naming the message and field, before any code is written.
"""

from __future__ import annotations

import re
import zlib
from dataclasses import dataclass
from pathlib import Path

from protocol.compat import tomllib
from protocol.errors import SchemaError

DEFAULT_SCHEMA = Path(__file__).with_name("schema.toml")

# name -> (size in bytes, struct code, C++ type)
PRIMITIVES: dict[str, tuple[int, str, str]] = {
    "u8": (1, "B", "uint8_t"),
    "u16": (2, "H", "uint16_t"),
    "u32": (4, "I", "uint32_t"),
    "i8": (1, "b", "int8_t"),
    "i16": (2, "h", "int16_t"),
    "i32": (4, "i", "int32_t"),
    "f32": (4, "f", "float"),
    "bool": (1, "?", "bool"),
}
INTEGER_RANGES: dict[str, tuple[int, int]] = {
    "u8": (0, 0xFF),
    "u16": (0, 0xFFFF),
    "u32": (0, 0xFFFFFFFF),
    "i8": (-0x80, 0x7F),
    "i16": (-0x8000, 0x7FFF),
    "i32": (-0x80000000, 0x7FFFFFFF),
}
DIRECTIONS = ("brain->jetson", "jetson->brain", "both")
MAX_BODY = 255  # the packet's length field is one byte
_IDENT = re.compile(r"^[a-z][a-z0-9_]*$")
_TYPE_NAME = re.compile(r"^[A-Z][A-Za-z0-9]*$")
_ARRAY = re.compile(r"^(\w+)\[(\d+)\]$")
# Words that cannot be identifiers in the generated C++ or Python: both languages' keywords, plus
# `id` and `seq`, which the packet header and AnyMessage already use.
_RESERVED = {
    "alignas", "alignof", "and", "and_eq", "as", "asm", "assert", "async", "auto", "await",
    "bitand", "bitor", "bool", "break", "case", "catch", "char", "char16_t", "char32_t",
    "char8_t", "class", "co_await", "co_return", "co_yield", "compl", "concept", "const",
    "const_cast", "consteval", "constexpr", "constinit", "continue", "decltype", "def",
    "default", "del", "delete", "do", "double", "dynamic_cast", "elif", "else", "enum",
    "except", "explicit", "export", "extern", "false", "finally", "float", "for", "friend",
    "from", "global", "goto", "if", "import", "in", "inline", "int", "is", "lambda", "long",
    "mutable", "namespace", "new", "noexcept", "none", "nonlocal", "not", "not_eq", "nullptr",
    "operator", "or", "or_eq", "pass", "private", "protected", "public", "raise", "register",
    "reinterpret_cast", "requires", "return", "short", "signed", "sizeof", "static",
    "static_assert", "static_cast", "struct", "switch", "template", "this", "thread_local",
    "throw", "true", "try", "typedef", "typeid", "typename", "union", "unsigned", "using",
    "virtual", "void", "volatile", "wchar_t", "while", "with", "xor", "xor_eq", "yield",
    "id", "seq",
}  # fmt: skip
# Names the generated modules define next to the schema's types (messages.py and messages.hpp).
_RESERVED_TYPES = {
    "AnyMessage", "ClassVar", "Direction", "DownlinkDecoder", "ENUMS", "FINGERPRINT", "FieldInfo",
    "IntEnum", "IntFlag", "MESSAGES", "NamedTuple", "STREAM",
}  # fmt: skip
_RESERVED_FIELDS = (_RESERVED - {"seq"}) | {"encode_body", "decode_body"}  # own `seq` is fine


@dataclass(frozen=True)
class EnumDef:
    name: str
    doc: str
    base: str  # primitive integer type on the wire
    values: tuple[tuple[str, int], ...]  # (name, value), sorted by value
    is_flags: bool  # flags: `values` are bit positions and any combination is valid


@dataclass(frozen=True)
class FieldDef:
    name: str
    type: str  # as written in the schema, e.g. "f32", "MatchPhase", "char[48]", "i16[4]"
    doc: str
    unit: str
    base: str  # primitive of one element ("char" for text)
    count: int  # 1 for scalars, N for arrays and text
    enum: EnumDef | None

    @property
    def is_text(self) -> bool:
        return self.base == "char"

    @property
    def is_array(self) -> bool:
        return self.count > 1 or "[" in self.type

    @property
    def size(self) -> int:
        return self.count * (1 if self.is_text else PRIMITIVES[self.base][0])


@dataclass(frozen=True)
class MessageDef:
    name: str
    id: int
    direction: str
    doc: str
    fields: tuple[FieldDef, ...]

    @property
    def body_size(self) -> int:
        return sum(f.size for f in self.fields)

    @property
    def uplink(self) -> bool:
        """Sent by the Brain."""
        return self.direction in ("brain->jetson", "both")

    @property
    def downlink(self) -> bool:
        """Sent by the Jetson."""
        return self.direction in ("jetson->brain", "both")


@dataclass(frozen=True)
class Schema:
    version: int
    stream: str
    enums: tuple[EnumDef, ...]
    messages: tuple[MessageDef, ...]
    source: str  # path it was loaded from, for generated-file banners

    @property
    def fingerprint(self) -> int:
        return fingerprint(self)

    def message(self, name: str) -> MessageDef:
        for m in self.messages:
            if m.name == name:
                return m
        known = ", ".join(m.name for m in self.messages)
        raise SchemaError(f"no message named {name!r} in the schema (known: {known})")


def canonical_text(schema: Schema) -> str:
    """What the fingerprint hashes: all that changes the bytes or their meaning, in wire order.

    Docs and units are left out so that rewording a comment does not break a deployed robot.
    """
    lines = [f"pete-protocol {schema.version} stream={schema.stream}"]
    for e in schema.enums:
        kind = "flags" if e.is_flags else "enum"
        values = ",".join(f"{n}={v}" for n, v in e.values)
        lines.append(f"{kind} {e.name}:{e.base} {values}")
    for m in sorted(schema.messages, key=lambda m: m.id):
        fields = ",".join(f"{f.name}:{f.type}" for f in m.fields)
        lines.append(f"message {m.id} {m.name} {m.direction} {fields}")
    return "\n".join(lines) + "\n"


def fingerprint(schema: Schema) -> int:
    """CRC-32 of the canonical text: MAVLink's CRC_EXTRA idea applied to the whole schema."""
    return zlib.crc32(canonical_text(schema).encode()) & 0xFFFFFFFF


def load_schema(path: str | Path = DEFAULT_SCHEMA) -> Schema:
    path = Path(path)
    try:
        raw = tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise SchemaError(f"{path}: schema file not found") from None
    except tomllib.TOMLDecodeError as exc:
        raise SchemaError(f"{path}: not valid TOML: {exc}") from None
    try:
        return parse_schema(raw, source=str(path))
    except SchemaError as exc:
        raise SchemaError(f"{path}: {exc}") from None


def _require(table: dict, key: str, kind: type, where: str) -> object:
    if key not in table:
        raise SchemaError(f"{where}: missing `{key}`")
    value = table[key]
    if (kind is int and isinstance(value, bool)) or not isinstance(value, kind):
        raise SchemaError(f"{where}: `{key}` must be {kind.__name__}, got {value!r}")
    return value


def _note(table: dict, key: str, where: str) -> str:
    """A doc or unit: copied into comments and string literals of the generated code, where a line
    break or a backslash would end the comment or the literal early."""
    text = str(table.get(key, ""))
    if "\\" in text or any(not c.isprintable() for c in text):
        raise SchemaError(f"{where}: `{key}` must be one line without backslashes, got {text!r}")
    return text


def _parse_enum(name: str, table: dict, is_flags: bool) -> EnumDef:
    where = f"{'flags' if is_flags else 'enum'} {name}"
    if not _TYPE_NAME.match(name) or name in _RESERVED_TYPES:
        raise SchemaError(f"{where}: type names are CamelCase and not a generated name")
    base = table.get("type", "u8")
    if base not in INTEGER_RANGES or base.startswith("i"):
        raise SchemaError(f"{where}: `type` must be an unsigned integer type, got {base!r}")
    key = "bits" if is_flags else "values"
    values = _require(table, key, dict, where)
    if not values:
        raise SchemaError(f"{where}: `{key}` is empty")
    lo, hi = INTEGER_RANGES[base]
    if is_flags:
        hi = PRIMITIVES[base][0] * 8 - 1
    seen: dict[int, str] = {}
    for vname, v in values.items():
        if not _IDENT.match(vname) or vname in _RESERVED:
            raise SchemaError(f"{where}: {vname!r} is not a usable lower_snake_case name")
        if isinstance(v, bool) or not isinstance(v, int) or not lo <= v <= hi:
            raise SchemaError(f"{where}: {vname} = {v!r} is outside {lo}..{hi}")
        if v in seen:
            raise SchemaError(f"{where}: {vname} and {seen[v]} share the value {v}")
        seen[v] = vname
    ordered = tuple(sorted(values.items(), key=lambda kv: kv[1]))
    return EnumDef(name, _note(table, "doc", where), base, ordered, is_flags)


def _parse_field(raw: object, where: str, enums: dict[str, EnumDef]) -> FieldDef:
    if not isinstance(raw, dict):
        raise SchemaError(f"{where}: each field is a table with name and type")
    name = _require(raw, "name", str, where)
    where = f"{where} field {name!r}"
    if not _IDENT.match(name) or name in _RESERVED_FIELDS:
        raise SchemaError(f"{where}: field names are lower_snake_case and not a keyword")
    ftype = _require(raw, "type", str, where)
    count, base = 1, ftype
    match = _ARRAY.match(ftype)
    if match:
        base, count = match.group(1), int(match.group(2))
        if not 1 <= count <= MAX_BODY:
            raise SchemaError(f"{where}: array length must be 1..{MAX_BODY}")
        if base != "char" and base not in PRIMITIVES:
            raise SchemaError(f"{where}: arrays hold numeric types or char, not {base!r}")
    enum = None
    if base in enums:
        enum = enums[base]
        if match:
            raise SchemaError(f"{where}: arrays of enums are not supported")
        base = enum.base
    elif base != "char" and base not in PRIMITIVES:
        known = ", ".join([*PRIMITIVES, *enums])
        raise SchemaError(f"{where}: unknown type {ftype!r} (known: {known}, T[N], char[N])")
    if base == "char" and not match:
        raise SchemaError(f"{where}: text is char[N]")
    return FieldDef(
        name=name,
        type=ftype,
        doc=_note(raw, "doc", where),
        unit=_note(raw, "unit", where),
        base=base,
        count=count,
        enum=enum,
    )


def parse_schema(raw: dict, source: str = "<schema>") -> Schema:
    proto = _require(raw, "protocol", dict, "schema")
    version = _require(proto, "version", int, "[protocol]")
    if not 0 <= version <= 0xFFFF:
        raise SchemaError("[protocol]: version must fit in u16")
    stream = _require(proto, "stream", str, "[protocol]")
    if len(stream) != 4 or not stream.isascii() or "\0" in stream:
        raise SchemaError(f"[protocol]: stream must be 4 ASCII characters, got {stream!r}")
    if stream in ("sout", "serr", "kdbg", "jinx"):
        raise SchemaError(f"[protocol]: stream {stream!r} is used by PROS itself")

    enums: dict[str, EnumDef] = {}
    for section, is_flags in (("enums", False), ("flags", True)):
        for name, table in raw.get(section, {}).items():
            if name in enums:
                raise SchemaError(f"type {name} is declared twice")
            if not isinstance(table, dict):
                raise SchemaError(f"{section}.{name}: must be a table")
            enums[name] = _parse_enum(name, table, is_flags)

    raw_messages = raw.get("messages")
    if not isinstance(raw_messages, list) or not raw_messages:
        raise SchemaError("schema: no [[messages]]")
    messages: list[MessageDef] = []
    names: set[str] = set()
    ids: dict[int, str] = {}
    for i, rm in enumerate(raw_messages):
        where = f"message #{i + 1}"
        if not isinstance(rm, dict):
            raise SchemaError(f"{where}: must be a table")
        name = _require(rm, "name", str, where)
        where = f"message {name!r}"
        if not _TYPE_NAME.match(name) or name in _RESERVED_TYPES:
            raise SchemaError(f"{where}: message names are CamelCase and not a generated name")
        # messages.hpp's AnyMessage has one member per message, named in lower case
        if name.lower() in _RESERVED:
            raise SchemaError(f"{where}: {name.lower()!r} is a keyword in the generated code")
        if name.lower() in names or name in enums:
            raise SchemaError(f"{where}: the name is used twice")
        mid = _require(rm, "id", int, where)
        if not 1 <= mid <= 255:
            raise SchemaError(f"{where}: id must be 1..255, got {mid}")
        if mid in ids:
            raise SchemaError(f"{where}: id {mid} is already used by {ids[mid]}")
        direction = _require(rm, "direction", str, where)
        if direction not in DIRECTIONS:
            raise SchemaError(f"{where}: direction must be one of {', '.join(DIRECTIONS)}")
        raw_fields = _require(rm, "fields", list, where)
        fields = tuple(_parse_field(f, where, enums) for f in raw_fields)
        fnames = [f.name for f in fields]
        dup = {n for n in fnames if fnames.count(n) > 1}
        if dup:
            raise SchemaError(f"{where}: duplicate field {sorted(dup)[0]!r}")
        msg = MessageDef(name, mid, direction, _note(rm, "doc", where), fields)
        if msg.body_size > MAX_BODY:
            raise SchemaError(f"{where}: body is {msg.body_size} bytes, the limit is {MAX_BODY}")
        messages.append(msg)
        names.add(name.lower())
        ids[mid] = name

    hello = next((m for m in messages if m.name == "Hello"), None)
    if hello is None or not hello.fields or hello.fields[0].name != "fingerprint":
        raise SchemaError("schema: a Hello message whose first field is `fingerprint` is required")
    if hello.fields[0].type != "u32" or hello.direction != "both":
        raise SchemaError("message 'Hello': fingerprint is u32 and Hello goes both ways")
    return Schema(version, stream, tuple(enums.values()), tuple(messages), source)

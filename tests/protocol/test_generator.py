"""Both generators on a schema that uses every supported type (tests/data/all_types.toml): the
Python codec round-trips, and a C++ program built from the generated header (with the project's
strict warnings) produces and accepts exactly the bytes the Python codec does."""

from __future__ import annotations

import importlib.util
import math
import random
import shutil
import struct
import subprocess
import sys
from collections.abc import Iterator
from enum import IntFlag
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

from protocol import framing
from protocol.errors import ErrorKind, FrameError
from protocol.framing import Received
from protocol.gen_cpp import generate_cpp
from protocol.gen_python import generate_python
from protocol.schema import PRIMITIVES, FieldDef, MessageDef, Schema, load_schema

ROOT = Path(__file__).resolve().parents[2]
SCHEMA_PATH = Path(__file__).resolve().parents[1] / "data" / "all_types.toml"
WIRE_HPP = ROOT / "brain" / "include" / "pete" / "wire.hpp"
CXX = shutil.which("g++")
CXXFLAGS = [
    "-std=c++17",
    "-Wall",
    "-Wextra",
    "-Werror",
    "-Wpedantic",
    "-Wshadow",
    "-Wconversion",
    "-fno-exceptions",
    "-fno-rtti",
]
needs_cxx = pytest.mark.skipif(CXX is None, reason="g++ is not installed")
RANGES = {
    "u8": (0, 0xFF),
    "u16": (0, 0xFFFF),
    "u32": (0, 0xFFFFFFFF),
    "i8": (-0x80, 0x7F),
    "i16": (-0x8000, 0x7FFF),
    "i32": (-0x80000000, 0x7FFFFFFF),
}


@pytest.fixture(scope="module")
def schema() -> Schema:
    return load_schema(SCHEMA_PATH)


@pytest.fixture(scope="module")
def codec(schema: Schema, tmp_path_factory: pytest.TempPathFactory) -> Iterator[ModuleType]:
    path = tmp_path_factory.mktemp("py") / "all_types_codec.py"
    path.write_text(generate_python(schema, "tests/data/all_types.toml"))
    spec = importlib.util.spec_from_file_location("all_types_codec", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    # dataclasses resolves the ClassVar annotations through sys.modules
    sys.modules[spec.name] = module
    try:
        spec.loader.exec_module(module)
        yield module
    finally:
        del sys.modules[spec.name]


# --- random values ------------------------------------------------------------------------------


def random_scalar(rng: random.Random, base: str) -> Any:
    if base == "bool":
        return rng.random() < 0.5
    if base == "f32":
        special = [0.0, -0.0, 1.5, -3.4028234663852886e38, 1.401298464324817e-45]
        if rng.random() < 0.2:
            return rng.choice(special)
        # any finite f32 bit pattern
        while True:
            value = struct.unpack("<f", rng.getrandbits(32).to_bytes(4, "little"))[0]
            if math.isfinite(value):
                return value
    lo, hi = RANGES[base]
    return rng.choice([lo, hi, 0, rng.randint(lo, hi)])


def random_text(rng: random.Random, size: int) -> str:
    alphabet = "abcXYZ 09_-é€\"\\'\t"
    text = "".join(rng.choice(alphabet) for _ in range(rng.randint(0, size)))
    return text.encode()[:size].decode(errors="ignore")


def random_value(rng: random.Random, f: FieldDef, codec: ModuleType) -> Any:
    if f.enum is not None:
        enum = codec.ENUMS[f.enum.name]
        if issubclass(enum, IntFlag):
            result = enum(0)
            for member in enum:
                if rng.random() < 0.5:
                    result |= member
            return result
        return rng.choice(list(enum))
    if f.is_text:
        return random_text(rng, f.count)
    if f.is_array:
        return tuple(random_scalar(rng, f.base) for _ in range(f.count))
    return random_scalar(rng, f.base)


def random_message(rng: random.Random, m: MessageDef, codec: ModuleType) -> Any:
    cls = codec.BY_NAME[m.name]
    return cls(**{f.name: random_value(rng, f, codec) for f in m.fields})


def sample_cases(schema: Schema, codec: ModuleType, per_message: int) -> list[tuple[Any, int]]:
    rng = random.Random(20240501)
    cases = []
    for m in schema.messages:
        for _ in range(per_message):
            cases.append((random_message(rng, m, codec), rng.randint(0, 255)))
    return cases


# --- Python codec -------------------------------------------------------------------------------


def test_generated_module_describes_the_schema(schema: Schema, codec: ModuleType) -> None:
    assert schema.fingerprint == codec.FINGERPRINT
    assert codec.PROTOCOL_VERSION == 3
    assert codec.STREAM == b"tst1"
    assert sorted(codec.MESSAGES) == [1, 10, 200, 255]
    assert codec.BY_NAME["Sample"].BODY_SIZE == 64
    assert codec.BY_NAME["Control"].BODY_SIZE == 4 + 12 + 8 + 1 + 1 + 5
    assert codec.BY_NAME["Ping"].BODY_SIZE == 0
    assert codec.BY_NAME["Sample"].UPLINK and not codec.BY_NAME["Sample"].DOWNLINK
    assert codec.BY_NAME["Control"].DOWNLINK and not codec.BY_NAME["Control"].UPLINK
    assert [f.name for f in codec.BY_NAME["Sample"].FIELDS][-1] == "name"
    assert codec.BY_NAME["Sample"].FIELDS[6].unit == "°/s"
    # the quoted docs came through intact
    assert codec.Hello.__doc__ == 'Handshake; a "quoted" doc, to check that docstrings are escaped.'


def test_defaults_are_zero_and_first_enum_value(codec: ModuleType) -> None:
    sample = codec.Sample()
    assert sample.trio == (0, 0, 0) and sample.pair == (0.0, 0.0)
    assert sample.switches == (False, False) and sample.single == (0,)
    assert sample.mode == codec.Mode.IDLE and sample.wide == codec.Wide.LOW
    assert int(sample.bits) == 0 and sample.name == ""
    assert sample.encode_body() == bytes(20) + b"\x01\x00" + bytes(42)  # Wide.LOW is 1


def test_layout_is_packed_little_endian_in_schema_order(codec: ModuleType) -> None:
    sample = codec.Sample(
        a_u8=0x11,
        a_u16=0x2233,
        a_u32=0x44556677,
        a_i8=-2,
        a_i16=-3,
        a_i32=-4,
        a_f32=1.5,
        a_bool=True,
        mode=codec.Mode.HALT,
        wide=codec.Wide.HIGH,
        bits=codec.Bits.A | codec.Bits.TOP,
        wide_bits=codec.Wide32.HI,
        trio=(1, -1, 256),
        pair=(0.5, -2.0),
        switches=(False, True),
        single=(9,),
        words=(1, 0xFFFFFFFF),
        small=(-128, 127, 0, 1),
        name="abc",
    )
    expected = (
        bytes.fromhex("11332277665544fefdfffcffffff0000c03f01")
        + bytes.fromhex("ff409c8100000080")
        + bytes.fromhex("0100ffff00010000003f000000c0000109")
        + bytes.fromhex("01000000ffffffff807f0001")
        + b"abc\0\0\0\0\0"
    )
    assert sample.encode_body() == expected
    assert codec.Sample.decode_body(expected) == sample


def test_random_messages_round_trip_through_packets_and_both_links(
    schema: Schema, codec: ModuleType
) -> None:
    cases = sample_cases(schema, codec, per_message=40)
    up, down = framing.UplinkDecoder(codec), framing.DownlinkDecoder(codec)
    for msg, seq in cases:
        packet = framing.encode_packet(msg, seq)
        assert len(packet) == framing.OVERHEAD + msg.BODY_SIZE
        assert framing.decode_packet(packet, codec=codec) == (msg, seq)
        got_up = up.feed(framing.encode_uplink(msg, seq, codec))
        got_down = down.feed(framing.encode_downlink(msg, seq))
        assert (got_up == [Received(msg, seq)]) == msg.UPLINK
        assert (got_down == [Received(msg, seq)]) == msg.DOWNLINK
        # and through the JSON-like form the CLI uses
        as_dict = framing.message_to_dict(msg)
        assert framing.message_from_dict(type(msg), as_dict, codec) == msg


def test_uplink_decoder_uses_the_codecs_stream(codec: ModuleType) -> None:
    ping = codec.Ping()
    assert framing.UplinkDecoder(codec).feed(framing.encode_uplink(ping, 1, codec)) == [
        Received(ping, 1)
    ]
    # the same packet on the shipped schema's stream is someone else's
    events = framing.UplinkDecoder(codec).feed(framing.stream_frame(b"pete", b"x"))
    assert [e.kind for e in events] == [ErrorKind.UNKNOWN_STREAM]


def _sample_body(codec: ModuleType, **raw: Any) -> bytes:
    """Sample's body with raw bytes patched in at a field's offset."""
    body = bytearray(codec.Sample().encode_body())
    offsets = {"a_f32": 14, "a_bool": 18, "mode": 19, "wide": 20, "pair": 33, "switches": 41}
    for name, value in raw.items():
        body[offsets[name] : offsets[name] + len(value)] = value
    return bytes(body)


@pytest.mark.parametrize(
    "patch",
    [
        {"mode": b"\x03"},
        {"wide": b"\x02\x00"},
        {"a_bool": b"\x02"},
        {"switches": b"\x00\x02"},
        {"a_f32": struct.pack("<f", math.nan)},
        {"pair": struct.pack("<ff", 0.0, math.inf)},
    ],
    ids=["enum", "u16 enum", "bool", "bool array", "NaN", "inf in array"],
)
def test_generated_decoder_refuses_bad_values(codec: ModuleType, patch: dict[str, bytes]) -> None:
    body = _sample_body(codec, **patch)
    packet = bytes([10, 0, len(body)]) + body
    packet += struct.pack("<H", framing.crc16(packet))
    with pytest.raises(FrameError) as info:
        framing.decode_packet(packet, codec=codec)
    assert info.value.kind == ErrorKind.BAD_VALUE


def test_array_errors_name_the_field(codec: ModuleType) -> None:
    with pytest.raises(ValueError, match=r"Sample\.trio \(i16\[3\]\).*3 values"):
        framing.message_from_dict(codec.Sample, {"trio": [1, 2]}, codec)
    with pytest.raises(ValueError, match=r"Sample\.trio.*40000"):
        framing.message_from_dict(codec.Sample, {"trio": [1, 2, 40000]}, codec)
    with pytest.raises(ValueError, match=r"Sample\.switches.*true or false"):
        framing.message_from_dict(codec.Sample, {"switches": [1, 0]}, codec)
    with pytest.raises(ValueError, match=r"Sample\.pair.*nan"):
        framing.message_from_dict(codec.Sample, {"pair": [0.0, math.nan]}, codec)
    with pytest.raises(ValueError, match=r"Sample\.bits.*'c'"):
        framing.message_from_dict(codec.Sample, {"bits": ["a", "c"]}, codec)


def test_empty_message_refuses_a_body(codec: ModuleType) -> None:
    assert codec.Ping.decode_body(b"") == codec.Ping()
    with pytest.raises(ValueError):
        codec.Ping.decode_body(b"\x00")


# --- C++ codec ----------------------------------------------------------------------------------


def cpp_scalar(base: str, value: Any) -> str:
    if base == "bool":
        return "true" if value else "false"
    if base == "f32":
        return f"{float(value).hex()}f"
    ctype = PRIMITIVES[base][2]
    suffix = "LL" if base.startswith("i") else "ULL"
    return f"static_cast<{ctype}>({int(value)}{suffix})"


def cpp_string(text: str) -> str:
    # octal escapes stop after three digits, unlike \x
    return '"' + "".join(f"\\{b:03o}" for b in text.encode()) + '"'


def cpp_assignments(var: str, m: MessageDef, msg: Any) -> list[str]:
    lines = []
    for f in m.fields:
        value = getattr(msg, f.name)
        target = f"{var}.{f.name}"
        if f.enum is not None and f.enum.is_flags:
            ctype = PRIMITIVES[f.enum.base][2]
            lines.append(
                f"{target} = static_cast<{f.enum.name}>(static_cast<{ctype}>({int(value)}ULL));"
            )
        elif f.enum is not None:
            lines.append(f"{target} = {f.enum.name}::{value.name.lower()};")
        elif f.is_text:
            lines.append(f"pete::wire::set_text({target}, {cpp_string(value)});")
        elif f.is_array:
            lines += [f"{target}[{i}] = {cpp_scalar(f.base, v)};" for i, v in enumerate(value)]
        else:
            lines.append(f"{target} = {cpp_scalar(f.base, value)};")
    return lines


def cpp_program(schema: Schema, cases: list[tuple[Any, int]], bad_packet: bytes) -> str:
    """For each case: build the message field by field, print its packet and downlink line as hex,
    then decode the Python codec's packet and say whether it equals what we built."""
    body = []
    for msg, seq in cases:
        m = schema.message(msg.NAME)
        packet = framing.encode_packet(msg, seq)
        body.append("{")
        body.append(f"  {m.name} m;")
        body += ["  " + line for line in cpp_assignments("m", m, msg)]
        body.append(f"  emit(m, {seq});")
        body.append(f"  static const uint8_t py[] = {{{', '.join(str(b) for b in packet)}}};")
        body.append(f"  check_decode(py, sizeof py, m, m.kId, {seq});")
        body.append("}")
    bad = ", ".join(str(b) for b in bad_packet)
    return "\n".join(
        [
            "#include <cstdio>",
            "",
            '#include "pete/messages.hpp"',
            "",
            "using namespace pete::msg;",
            "",
            "static void hex(const uint8_t* p, std::size_t n) {",
            '  for (std::size_t i = 0; i < n; ++i) std::printf("%02x", p[i]);',
            "}",
            "",
            "template <class M>",
            "static void emit(const M& m, uint8_t seq) {",
            "  uint8_t packet[kMaxPacket];",
            "  const std::size_t n = encode_packet(m, seq, packet, sizeof packet);",
            "  char line[kMaxDownlinkLine];",
            "  const std::size_t k = encode_downlink(m, seq, line, sizeof line);",
            '  std::printf("packet ");',
            "  hex(packet, n);",
            '  std::printf(" line ");',
            "  hex(reinterpret_cast<const uint8_t*>(line), k);",
            "}",
            "",
            "template <class M>",
            "static const M& member(const AnyMessage& a);",
            *[
                f"template <> const {m.name}& member<{m.name}>(const AnyMessage& a) "
                f"{{ return a.{m.name.lower()}; }}"
                for m in schema.messages
            ],
            "",
            "template <class M>",
            "static void check_decode(const uint8_t* p, std::size_t n, const M& m, uint8_t id,",
            "                         uint8_t seq) {",
            "  AnyMessage a;",
            "  pete::wire::Error err{};",
            "  const bool ok = decode_packet(p, n, a, err);",
            "  const bool same = ok && a.id == id && a.seq == seq && member<M>(a) == m;",
            "  uint8_t again[kMaxPacket];",
            "  const std::size_t k = ok ? encode_packet(a, again, sizeof again) : 0;",
            '  std::printf(" decoded %d reencoded ", same ? 1 : 0);',
            "  hex(again, k);",
            '  std::printf("\\n");',
            "}",
            "",
            "int main() {",
            *body,
            "  {",
            f"    static const uint8_t bad[] = {{{bad}}};",
            "    AnyMessage a;",
            "    pete::wire::Error err{};",
            "    const bool ok = decode_packet(bad, sizeof bad, a, err);",
            '    std::printf("bad %d %s\\n", ok ? 1 : 0, pete::wire::error_name(err));',
            "  }",
            "  return 0;",
            "}",
            "",
        ]
    )


def compile_and_run(source: str, include: Path, workdir: Path) -> str:
    assert CXX is not None
    src, exe = workdir / "prog.cpp", workdir / "prog"
    src.write_text(source)
    build = subprocess.run(
        [CXX, *CXXFLAGS, "-I", str(include), str(src), "-o", str(exe)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert build.returncode == 0, build.stderr
    run = subprocess.run([str(exe)], capture_output=True, text=True, timeout=30)
    assert run.returncode == 0, run.stderr
    return run.stdout


@needs_cxx
def test_cpp_codec_agrees_with_python_byte_for_byte(
    schema: Schema, codec: ModuleType, tmp_path: Path
) -> None:
    (tmp_path / "pete").mkdir()
    (tmp_path / "pete" / "messages.hpp").write_text(generate_cpp(schema, "all_types.toml"))
    shutil.copy(WIRE_HPP, tmp_path / "pete" / "wire.hpp")
    cases = sample_cases(schema, codec, per_message=6)
    bad_body = _sample_body(codec, mode=b"\x05")  # a Mode value the schema does not define
    bad = bytes([10, 0, len(bad_body)]) + bad_body
    bad += struct.pack("<H", framing.crc16(bad))

    lines = compile_and_run(cpp_program(schema, cases, bad), tmp_path, tmp_path).splitlines()

    assert len(lines) == len(cases) + 1
    for (msg, seq), line in zip(cases, lines, strict=False):
        packet = framing.encode_packet(msg, seq).hex()
        downlink = framing.encode_downlink(msg, seq).hex()
        assert line == f"packet {packet} line {downlink} decoded 1 reencoded {packet}", msg
    assert lines[-1] == "bad 0 bad_value"


@needs_cxx
def test_shipped_messages_hpp_compiles_on_its_own_as_cpp17(tmp_path: Path) -> None:
    src = tmp_path / "only_messages.cpp"
    src.write_text('#include "pete/messages.hpp"\n#include "pete/messages.hpp"\n\nint main() {}\n')
    build = subprocess.run(
        [CXX, *CXXFLAGS, "-fsyntax-only", "-I", str(ROOT / "brain" / "include"), str(src)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert build.returncode == 0, build.stderr

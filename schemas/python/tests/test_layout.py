"""Bincode legacy layout rules and the wire checks, on hand-made bytes."""

import math
import struct
import zlib

import pytest

from wearnav_schemas import MAX_PAYLOAD_BYTES, WireError, decode, decode_header, encode
from wearnav_schemas.wire import reseal
from wearnav_schemas.layout import (
    BOOL,
    BYTES,
    F32,
    F64,
    I32,
    I64,
    STRING,
    U8,
    U16,
    U64,
    Array,
    Enum,
    Optional,
    Reader,
    Seq,
    Struct,
)


def written(kind, value):
    out = bytearray()
    kind.write(out, value, "v")
    return bytes(out)


def read_back(kind, raw):
    reader = Reader(memoryview(raw))
    value = kind.read(reader)
    assert reader.pos == len(raw)
    return value


@pytest.mark.parametrize(
    "kind, value, raw",
    [
        (U8, 200, b"\xc8"),
        (U16, 0x0102, b"\x02\x01"),
        (U64, 2**64 - 1, b"\xff" * 8),
        (I32, -2, b"\xfe\xff\xff\xff"),
        (I64, -1, b"\xff" * 8),
        (F32, 1.5, struct.pack("<f", 1.5)),
        (F32, math.inf, b"\x00\x00\x80\x7f"),
        (F64, -0.25, struct.pack("<d", -0.25)),
        (BOOL, True, b"\x01"),
        (STRING, "Tür", b"\x04" + b"\x00" * 7 + "Tür".encode()),
        (BYTES, b"\x00\x01", b"\x02" + b"\x00" * 7 + b"\x00\x01"),
        (Seq(U16), [1, 2], b"\x02" + b"\x00" * 7 + b"\x01\x00\x02\x00"),
        (Array(F32, 2), [0.5, 2.0], struct.pack("<2f", 0.5, 2.0)),
        (Optional(U16), None, b"\x00"),
        (Optional(U16), 7, b"\x01\x07\x00"),
    ],
)
def test_primitive_layout_is_bincode_legacy(kind, value, raw):
    assert written(kind, value) == raw
    assert read_back(kind, raw) == value


ENUM = Enum("E", {"Unit": None, "Pair": {"a": U16, "b": BOOL}})


def test_enum_is_u32_index_then_fields():
    assert written(ENUM, "Unit") == b"\x00\x00\x00\x00"
    assert written(ENUM, {"Pair": {"a": 3, "b": False}}) == b"\x01\x00\x00\x00\x03\x00\x00"
    assert read_back(ENUM, b"\x01\x00\x00\x00\x03\x00\x01") == {"Pair": {"a": 3, "b": True}}


def test_struct_is_fields_in_order_without_padding():
    kind = Struct("S", flag=BOOL, n=U64)
    assert written(kind, {"n": 1, "flag": True}) == b"\x01\x01" + b"\x00" * 7


@pytest.mark.parametrize(
    "kind, value, words",
    [
        (U16, 70000, "does not fit in u16"),
        (U64, -1, "does not fit in u64"),
        (U16, 1.0, "expected an integer"),
        (U16, True, "expected an integer"),
        (F32, 1e40, "does not fit in f32"),
        (BOOL, 1, "expected a bool"),
        (STRING, b"x", "expected a str"),
        (Array(F32, 3), [1.0, 2.0], "list of 3"),
        (ENUM, "Nope", "no variant 'Nope'"),
        (ENUM, "Pair", "struct variant"),
        (ENUM, {"Unit": {}}, "unit variant"),
        (Struct("S", a=U16), {"a": 1, "b": 2}, "no field 'b'"),
        (Struct("S", a=U16), {}, "field 'a' is missing"),
    ],
)
def test_encoding_a_value_that_does_not_fit_names_the_problem(kind, value, words):
    with pytest.raises(ValueError, match=words):
        written(kind, value)


def test_encode_error_names_the_field_path():
    with pytest.raises(ValueError, match=r"hazard\.ficf\.left"):
        encode("hazard", {"frame_seq": 0, "ficf": {"left": "x"}}, sender="t", seq=0, capture_ns=0)


def test_unknown_schema_name_lists_the_known_ones():
    with pytest.raises(ValueError, match="speech_intent"):
        encode("speach", {}, sender="t", seq=0, capture_ns=0)


def command(body="Repeat"):
    return encode("command", body, sender="t", seq=5, capture_ns=9, session=77)


def kind_of(payload, expected=None):
    with pytest.raises(WireError) as err:
        decode(payload, expected)
    return err.value.kind


def test_header_is_read_alone_with_its_length():
    header, used = decode_header(command())
    assert header == {"schema": 12, "version": 5, "sender": "t", "session": 77, "seq": 5,
                      "capture_ns": 9}
    assert used == 2 + 2 + 9 + 8 + 8 + 8


def test_the_payload_ends_with_the_zlib_crc32_of_the_rest():
    payload = command()
    assert payload[-4:] == zlib.crc32(payload[:-4]).to_bytes(4, "little")


def test_every_cut_is_corrupt_and_a_resealed_cut_truncated_never_a_crash():
    payload = command({"Destination": {"label": "kitchen"}})
    for end in range(len(payload)):
        assert kind_of(payload[:end]) == ("truncated" if end < 4 else "corrupt"), end
        if end >= 8:
            assert kind_of(reseal(payload[:end] + b"\0\0\0\0")[:end]) in {"corrupt", "truncated"}
            assert kind_of(reseal(payload[: end - 4] + b"\0\0\0\0")) == "truncated", end


def test_every_single_bit_flip_is_refused():
    payload = command({"Destination": {"label": "kitchen"}})
    for bit in range(len(payload) * 8):
        damaged = bytearray(payload)
        damaged[bit // 8] ^= 1 << (bit % 8)
        # a flip in the schema id may name another schema, whose version or checksum
        # then fails
        named = {"unknown_schema", "unknown_version", "corrupt"}
        want = {0: named, 1: named, 2: {"unknown_version"},
                3: {"unknown_version"}}.get(bit // 8, {"corrupt"})
        assert kind_of(bytes(damaged)) in want, bit


def test_version_1_is_refused_as_unknown_version():
    payload = bytearray(command())
    payload[2:4] = (1).to_bytes(2, "little")
    assert kind_of(reseal(bytes(payload))) == "unknown_version"


def test_unknown_schema_id_is_refused():
    payload = bytearray(command())
    payload[0:2] = (500).to_bytes(2, "little")
    assert kind_of(reseal(bytes(payload))) == "unknown_schema"


def test_other_schema_than_expected_is_wrong_schema():
    assert kind_of(command(), expected="hazard") == "wrong_schema"


def test_payload_over_the_global_limit_is_too_large_before_reading():
    assert kind_of(b"\x00" * (MAX_PAYLOAD_BYTES + 1)) == "too_large"


def test_payload_over_its_schema_limit_is_too_large():
    haptic = encode("haptic_intent", {"left": 1.0, "right": 0.0, "pattern": "Steady", "ttl_ms": 100},
                    sender="t", seq=0, capture_ns=0)
    assert kind_of(haptic + b"\x00" * 300) == "too_large"
    assert kind_of(haptic + b"\x00") == "corrupt"
    assert kind_of(reseal(haptic[:-4] + b"\x00" + haptic[-4:])) == "malformed"


def test_garbage_never_raises_anything_but_wire_error():
    seed = 12345
    for length in range(0, 200, 3):
        raw = bytearray()
        for _ in range(length):
            seed = (seed * 1103515245 + 12345) % 2**31
            raw.append(seed >> 16 & 0xFF)
        for prefix in (b"", command()[:4]):
            try:
                decode(prefix + bytes(raw))
            except WireError as err:
                assert err.kind in {"unknown_schema", "unknown_version", "too_large",
                                    "truncated", "corrupt", "malformed"}
            try:
                decode(reseal(prefix + bytes(raw) + b"\0\0\0\0"))
            except WireError as err:
                assert err.kind in {"unknown_schema", "unknown_version", "too_large",
                                    "truncated", "malformed"}


def test_numpy_numbers_and_arrays_encode_like_python_ones():
    np = pytest.importorskip("numpy")
    scan = {"angle_min_deg": np.float32(-2.0), "angle_increment_deg": 1.0,
            "ranges_m": np.array([1.5, np.inf], dtype=np.float32), "range_max_m": 4.0}
    plain = dict(scan, angle_min_deg=-2.0, ranges_m=[1.5, math.inf])
    assert encode("scan", scan, sender="t", seq=np.uint64(3), capture_ns=0) == \
        encode("scan", plain, sender="t", seq=3, capture_ns=0)

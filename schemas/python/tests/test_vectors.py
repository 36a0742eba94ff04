"""The golden vectors Rust writes (schemas/tests/golden.rs) decode, re-encode and
reject here exactly as in Rust. Regenerate them with
``UPDATE_VECTORS=1 cargo test -p schemas --test golden``."""

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

from wearnav_schemas import (
    MAX_PAYLOAD_BYTES,
    SCHEMA_NAMES,
    SCHEMAS,
    WireError,
    decode,
    depth_samples,
    encode,
    encoding_schema,
    schema,
    summarise,
)
from wearnav_schemas.layout import Array, Enum, Optional, Seq, Struct

VECTORS = Path(__file__).resolve().parents[2] / "vectors"
MESSAGE_BINS = sorted(VECTORS.glob("*.bin"))
REJECT_BINS = sorted((VECTORS / "reject").glob("*.bin"))


def expected(path):
    return json.loads(path.with_suffix(".json").read_text(encoding="utf-8"))


def test_vectors_are_present():
    assert len(MESSAGE_BINS) >= len(SCHEMAS), f"run the Rust golden test first ({VECTORS})"
    assert REJECT_BINS, f"no reject vectors in {VECTORS / 'reject'}"


@pytest.mark.parametrize("path", MESSAGE_BINS, ids=lambda p: p.stem)
def test_vector_decodes_to_its_json(path):
    want = expected(path)
    message = decode(path.read_bytes(), expected=want["schema"])
    got = message.to_json()
    assert got["schema"] == want["schema"]
    assert got["header"] == want["header"]
    assert got["body"] == want["body"]


@pytest.mark.parametrize("path", MESSAGE_BINS, ids=lambda p: p.stem)
def test_vector_reencodes_to_the_same_bytes(path):
    payload = path.read_bytes()
    message = decode(payload)
    h = message.header
    again = encode(
        message.schema, message.body, sender=h["sender"], seq=h["seq"], capture_ns=h["capture_ns"],
        session=h["session"],
    )
    assert again == payload


@pytest.mark.parametrize("path", MESSAGE_BINS, ids=lambda p: p.stem)
def test_vector_schema_identity_matches_rust(path):
    want = expected(path)
    found = schema(want["schema"])
    assert found.id == want["schema_id"] == want["header"]["schema"]
    assert found.max_bytes == want["max_bytes"]
    assert encoding_schema(found.name) == want["encoding_schema"]


@pytest.mark.parametrize("path", REJECT_BINS, ids=lambda p: p.stem)
def test_damaged_payload_is_rejected_with_the_same_kind_as_rust(path):
    want = expected(path)
    with pytest.raises(WireError) as err:
        decode(path.read_bytes(), expected=want["expect_schema"])
    assert err.value.kind == want["kind"], str(err.value)


def test_schema_table_matches_rust():
    table = json.loads((VECTORS / "schemas.json").read_text())
    assert table["max_payload_bytes"] == MAX_PAYLOAD_BYTES
    assert {s["id"]: s["name"] for s in table["schemas"]} == SCHEMA_NAMES
    assert {s["name"]: s["version"] for s in table["schemas"]} == {s.name: s.version for s in SCHEMAS}
    for s in table["schemas"]:
        assert encoding_schema(s["name"]) == s["encoding_schema"]


def test_scan_vector_carries_infinity_for_empty_bins():
    message = decode((VECTORS / "scan.bin").read_bytes())
    ranges = message.body["ranges_m"]
    assert ranges[0] == math.inf and ranges[-1] == math.inf
    assert ranges[1:4] == [1.75, 0.75, 2.5]


def test_non_ascii_speech_survives_the_round_trip():
    message = decode((VECTORS / "speech_intent_important.bin").read_bytes())
    assert message.body["text"] == "Achtung: Tür links, 1,5 m — stufe ↓ 出口"
    assert message.body["priority"] == "Important"


def _walk(kind, value, where, seen):
    """Record every (enum, variant) and (option field, Some/None) the value exercises."""
    if isinstance(kind, Struct):
        for field, sub in kind.fields.items():
            _walk(sub, value[field], f"{kind.name}.{field}", seen)
    elif isinstance(kind, Enum):
        variant = value if isinstance(value, str) else next(iter(value))
        seen.add((kind.name, variant))
        if kind.variants[variant] is not None:
            _walk(kind.variants[variant], value[variant], where, seen)
    elif isinstance(kind, Optional):
        seen.add((where, "None" if value is None else "Some"))
        if value is not None:
            _walk(kind.item, value, where, seen)
    elif isinstance(kind, (Seq, Array)):
        for item in value:
            _walk(kind.item, item, where, seen)


def _expect(kind, where, need):
    """Every (enum, variant) and (option field, Some/None) reachable from a layout."""
    if isinstance(kind, Struct):
        for field, sub in kind.fields.items():
            _expect(sub, f"{kind.name}.{field}", need)
    elif isinstance(kind, Enum):
        for variant, fields in kind.variants.items():
            need.add((kind.name, variant))
            if fields is not None:
                _expect(fields, where, need)
    elif isinstance(kind, Optional):
        need.update({(where, "Some"), (where, "None")})
        _expect(kind.item, where, need)
    elif isinstance(kind, (Seq, Array)):
        _expect(kind.item, where, need)


def test_vectors_cover_every_enum_variant_and_both_option_states():
    seen, need = set(), set()
    for found in SCHEMAS:
        _expect(found.body, found.name, need)
    for path in MESSAGE_BINS:
        message = decode(path.read_bytes())
        _walk(schema(message.schema).body, message.body, message.schema, seen)
    missing = sorted(" ".join(n) for n in need - seen)
    assert not missing, f"no golden vector exercises: {missing} (add one in golden.rs)"


def test_package_decodes_depth_frames_without_numpy_or_zstandard():
    # Pixels need the optional codec (depth.py); headers, sizes and bytes must not.
    code = (
        "import sys; sys.modules['numpy'] = None; sys.modules['zstandard'] = None\n"
        "from wearnav_schemas import decode\n"
        f"m = decode(open({str(VECTORS / 'depth_frame_lossless.bin')!r}, 'rb').read())\n"
        "print(m.body['width'], m.body['height'], m.body['encoding'])\n"
    )
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True,
                         cwd=Path(__file__).resolve().parents[1])
    assert out.stdout.split() == ["4", "3", "Lossless"]


@pytest.mark.parametrize(
    "name, line",
    [
        ("hazard_left", "rumble Left nearest 0.75 m at -10 deg ground Lost ttc 1.5 s body turning -4 deg/s"),
        ("hazard_right", "rumble Right nearest 1.25 m at 15 deg ground Degraded "
                         "(what the body turns into) body turning +45 deg/s"),
        ("hazard_clear", "rumble None nearest none ground Found"),
        ("applied_speech_started", "espeak: SpeechStarted Important 'stop'"),
        ("applied_offline_warning", "console: OfflineWarning OFFLINE 'perception/hazard stale'"),
        ("depth_frame_raw", "4x3 Raw 24 B"),
        ("command_mute", "Mute on"),
        ("scan", "5 bins, nearest 0.75 m at 0 deg"),
        ("pose", "Tracking x 12.50 y 3.25 yaw -29 deg floor 2"),
        ("pose_converging", "Converging (followed: guidance takes it) x 3.00 y 4.00 yaw 86 deg floor 1"),
        ("pose_lost", "Lost x 0.00 y 0.00 yaw 0 deg floor 0"),
    ],
)
def test_summary_says_what_matters(name, line):
    assert summarise(decode((VECTORS / f"{name}.bin").read_bytes())) == line


@pytest.mark.parametrize("path", MESSAGE_BINS, ids=lambda p: p.stem)
def test_every_vector_has_a_one_line_summary(path):
    line = summarise(decode(path.read_bytes()))
    assert line and "\n" not in line


@pytest.mark.parametrize("path", sorted(VECTORS.glob("depth_frame*.bin")), ids=lambda p: p.stem)
def test_depth_samples_of_a_vector_equal_what_the_rust_codec_unpacks(path):
    np = pytest.importorskip("numpy")
    pytest.importorskip("wearnav_schemas.depth", reason="pixel codec (depth.py) not present")
    frame = decode(path.read_bytes()).body
    samples = np.asarray(depth_samples(frame)).ravel().tolist()
    assert samples == expected(path)["depth_samples"]

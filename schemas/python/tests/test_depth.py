"""The Python depth codec decodes the payloads Rust's codec wrote
(``schemas/vectors/depth_codec/``, from ``depth_codec_vectors_match_the_committed_files``
in ``schemas/src/depth_codec.rs``) to the very samples Rust decodes, and refuses
damaged ones."""

import json
import random
from pathlib import Path

import pytest

np = pytest.importorskip("numpy")

from wearnav_schemas.depth import DepthCodecError, decode_depth  # noqa: E402

VECTORS = Path(__file__).resolve().parents[2] / "vectors" / "depth_codec"
BINS = sorted(VECTORS.glob("*.bin"))


def case(path):
    want = json.loads(path.with_suffix(".json").read_text(encoding="utf-8"))
    return path.read_bytes(), want


def test_codec_vectors_are_present():
    assert len(BINS) >= 5, f"run `UPDATE_VECTORS=1 cargo test -p schemas --lib depth_codec_vectors` ({VECTORS})"


@pytest.mark.parametrize("path", BINS, ids=lambda p: p.stem)
def test_vector_decodes_to_the_samples_rust_decodes(path):
    data, want = case(path)
    img = decode_depth(want["encoding"], data, want["width"], want["height"])
    assert img.dtype == np.uint16
    assert img.shape == (want["height"], want["width"])
    assert img.ravel().tolist() == want["samples"]


def test_frame_body_form_gives_the_same_image():
    data, want = case(VECTORS / "bounded_step5_scene.bin")
    frame = {"encoding": want["encoding"], "data": data, "width": want["width"], "height": want["height"]}
    assert decode_depth(frame).ravel().tolist() == want["samples"]


def test_raw_samples_are_little_endian():
    img = decode_depth("Raw", bytes([2, 1, 0, 0]), 2, 1)
    assert img.tolist() == [[0x0102, 0]]


def test_every_truncation_is_refused():
    data, want = case(VECTORS / "lossless_scene.bin")
    for cut in range(0, len(data), 7):
        with pytest.raises(DepthCodecError):
            decode_depth(want["encoding"], data[:cut], want["width"], want["height"])


def test_random_bit_flips_are_refused_or_decode_to_the_right_shape():
    data, want = case(VECTORS / "lossless_scene.bin")
    rng = random.Random(7)
    refused = 0
    for _ in range(60):
        bad = bytearray(data)
        i = rng.randrange(len(bad))
        bad[i] ^= 1 << rng.randrange(8)
        try:
            img = decode_depth(want["encoding"], bytes(bad), want["width"], want["height"])
            assert img.shape == (want["height"], want["width"])
        except DepthCodecError:
            refused += 1
    assert refused >= 55


def test_wrong_sizes_and_zero_step_are_refused():
    with pytest.raises(DepthCodecError):
        decode_depth("Raw", bytes(6), 2, 2)
    with pytest.raises(DepthCodecError):
        decode_depth({"Bounded": {"step": 0}}, bytes([0xD3]), 0, 0)
    with pytest.raises(DepthCodecError):
        decode_depth("Lossless", bytes([0xD3]), 1 << 16, 1 << 16)


def test_version_1_and_2_payloads_are_refused_as_an_unknown_format():
    with pytest.raises(DepthCodecError, match="unknown format"):
        decode_depth("Lossless", bytes([0xD1, 3, 1, 2, 0, 0]), 2, 2)
    data, want = case(VECTORS / "lossless_scene.bin")
    with pytest.raises(DepthCodecError, match="unknown format"):
        decode_depth(want["encoding"], bytes([0xD2]) + data[1:], want["width"], want["height"])

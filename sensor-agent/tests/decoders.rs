//! Property tests of every decoder of outside input in the sensor agent: PCD
//! (`formats::pcd::parse`), depth PNG (`formats::depth_png::parse`), LZF
//! (`formats::lzf::decompress`) and scene TOML (`sim::scene::parse_scene`). Mutated
//! valid inputs and random bytes must give a value or a named error: never a panic,
//! never an allocation beyond the reader's size limits, never a hang.
//!
//! The seeds are made here (small PCD files of every body kind, 16-bit PNGs, LZF
//! streams with back-references) or built in (the worlds' scene text). CI runs a
//! bounded number of cases (`CASES`, see `docs/fuzzing.md`); `wearnav fuzz` runs
//! millions on demand. `PROPTEST_CASES=N` sets the cases per property.

use std::sync::LazyLock;

use decoder_props::{config, measured, mutated, mutation, within, LargestAllocation};
use proptest::prelude::*;
use proptest::sample::Index;
use sensor_agent::formats::{depth_png, lzf, pcd, FormatProblem};
use sensor_agent::sim::scene::parse_scene;
use sensor_agent::sim::world::BUILTIN_WORLDS;

#[global_allocator]
static ALLOCATOR: LargestAllocation = LargestAllocation;

/// Cases per property in CI: 18 s for this file and the schemas' together, dev profile,
/// 2 cores (measured numbers in `docs/fuzzing.md`).
const CASES: u32 = 200_000;

// ---------------------------------------------------------------------------------
// Seeds.

/// A greedy LZF compressor (liblzf's format, searching back 64 bytes), so the seeds
/// hold back-references, overlapping ones included, and not only literal runs.
fn lzf_compress(input: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    let mut literals: Vec<u8> = Vec::new();
    let flush = |out: &mut Vec<u8>, literals: &mut Vec<u8>| {
        for chunk in literals.chunks(32) {
            out.push(chunk.len() as u8 - 1);
            out.extend_from_slice(chunk);
        }
        literals.clear();
    };
    let mut i = 0;
    while i < input.len() {
        let (mut best_len, mut best_off) = (0, 0);
        for off in 1..=i.min(64) {
            let len = (0..264.min(input.len() - i)).take_while(|&k| input[i + k] == input[i + k - off]).count();
            if len > best_len {
                (best_len, best_off) = (len, off);
            }
        }
        if best_len >= 3 {
            flush(&mut out, &mut literals);
            let (len, off) = (best_len - 2, best_off - 1);
            if len < 7 {
                out.push((len << 5 | off >> 8) as u8);
            } else {
                out.push((7 << 5 | off >> 8) as u8);
                out.push((len - 7) as u8);
            }
            out.push(off as u8);
            i += best_len;
        } else {
            literals.push(input[i]);
            i += 1;
        }
    }
    flush(&mut out, &mut literals);
    out
}

/// A 6x4 organized cloud: a floor, a box, holes.
fn cloud_points() -> Vec<[f32; 3]> {
    (0..24)
        .map(|i| {
            let (c, r) = ((i % 6) as f32, (i / 6) as f32);
            if i % 7 == 3 {
                [f32::NAN; 3]
            } else {
                [(c - 2.5) * 0.1, (r - 1.5) * 0.1, 1.0 + r * 0.25 + if c > 3.0 { -0.5 } else { 0.0 }]
            }
        })
        .collect()
}

const PCD_HEADER: &str = "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z rgba\nSIZE 4 4 4 4\n\
     TYPE F F F U\nCOUNT 1 1 1 1\nWIDTH 6\nHEIGHT 4\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 24\n";

/// PCD files of every body kind, one with doubles, padding and a multi-count field.
fn pcd_seeds() -> Vec<Vec<u8>> {
    let points = cloud_points();
    let mut ascii = format!("{PCD_HEADER}DATA ascii\n");
    for (i, p) in points.iter().enumerate() {
        ascii.push_str(&format!("{} {} {} {}\n", p[0], p[1], p[2], i * 1000));
    }
    let mut binary = format!("{PCD_HEADER}DATA binary\n").into_bytes();
    for (i, p) in points.iter().enumerate() {
        p.iter().for_each(|v| binary.extend_from_slice(&v.to_le_bytes()));
        binary.extend_from_slice(&(i as u32).to_le_bytes());
    }
    let mut soa = Vec::new();
    for axis in 0..3 {
        points.iter().for_each(|p| soa.extend_from_slice(&p[axis].to_le_bytes()));
    }
    (0..points.len()).for_each(|i| soa.extend_from_slice(&(i as u32 / 6).to_le_bytes()));
    let lzf = lzf_compress(&soa);
    let mut compressed = format!("{PCD_HEADER}DATA binary_compressed\n").into_bytes();
    compressed.extend_from_slice(&(lzf.len() as u32).to_le_bytes());
    compressed.extend_from_slice(&(soa.len() as u32).to_le_bytes());
    compressed.extend_from_slice(&lzf);
    let mut wide = "VERSION .7\nFIELDS _ x y z normal\nSIZE 2 8 8 8 4\nTYPE U F F F F\nCOUNT 3 1 1 1 2\n\
                    WIDTH 3\nHEIGHT 2\nDATA binary\n"
        .as_bytes()
        .to_vec();
    for p in &points[..6] {
        wide.extend_from_slice(&[0; 6]);
        p.iter().for_each(|&v| wide.extend_from_slice(&(v as f64).to_le_bytes()));
        wide.extend_from_slice(&[0; 8]);
    }
    vec![ascii.into_bytes(), binary, compressed, wide]
}

fn png_bytes(width: u32, height: u32, color: png::ColorType, depth: png::BitDepth, data: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    let mut encoder = png::Encoder::new(&mut out, width, height);
    encoder.set_color(color);
    encoder.set_depth(depth);
    let mut writer = encoder.write_header().expect("PNG header writes");
    writer.write_image_data(data).expect("PNG data writes");
    writer.finish().expect("PNG ends");
    out
}

/// 16-bit depth PNGs (big-endian samples), one 8-bit (refused as unsupported).
fn png_seeds() -> Vec<Vec<u8>> {
    let depth = |w: u32, h: u32| -> Vec<u8> {
        (0..w * h).flat_map(|i| if i % 9 == 4 { 0u16 } else { 900 + (i % w) as u16 * 7 }.to_be_bytes()).collect()
    };
    let sixteen = (png::ColorType::Grayscale, png::BitDepth::Sixteen);
    vec![
        png_bytes(8, 6, sixteen.0, sixteen.1, &depth(8, 6)),
        png_bytes(1, 1, sixteen.0, sixteen.1, &depth(1, 1)),
        png_bytes(40, 30, sixteen.0, sixteen.1, &depth(40, 30)),
        png_bytes(4, 2, png::ColorType::Grayscale, png::BitDepth::Eight, &[1, 2, 3, 4, 5, 6, 7, 8]),
    ]
}

/// (stream, decompressed length) of LZF streams with literal runs and back-references.
fn lzf_seeds() -> Vec<(Vec<u8>, usize)> {
    let texts: [Vec<u8>; 4] = [
        b"abcabcabcabcabcabcabcabc xyz xyz xyz".to_vec(),
        vec![7; 600],
        (0..300u32).flat_map(|i| (i % 17).to_le_bytes()).collect(),
        b"no repeats here: 0123456789".to_vec(),
    ];
    texts.iter().map(|t| (lzf_compress(t), t.len())).collect()
}

fn scene_seeds() -> Vec<Vec<u8>> {
    BUILTIN_WORLDS.iter().map(|(_, text)| text.as_bytes().to_vec()).collect()
}

/// Seeds are made once: making them took most of a case's time.
static PCD_SEEDS: LazyLock<Vec<Vec<u8>>> = LazyLock::new(pcd_seeds);
static PNG_SEEDS: LazyLock<Vec<Vec<u8>>> = LazyLock::new(png_seeds);
static LZF_SEEDS: LazyLock<Vec<(Vec<u8>, usize)>> = LazyLock::new(lzf_seeds);
static LZF_STREAMS: LazyLock<Vec<Vec<u8>>> = LazyLock::new(|| LZF_SEEDS.iter().map(|s| s.0.clone()).collect());
static SCENE_SEEDS: LazyLock<Vec<Vec<u8>>> = LazyLock::new(scene_seeds);

#[test]
fn every_seed_is_valid() {
    for (i, seed) in pcd_seeds().iter().enumerate() {
        let cloud = pcd::parse(seed).unwrap_or_else(|e| panic!("PCD seed {i}: {e}"));
        assert!(cloud.valid_count() > 0, "PCD seed {i}");
    }
    for (i, seed) in png_seeds().iter().enumerate().take(3) {
        depth_png::parse(seed).unwrap_or_else(|e| panic!("PNG seed {i}: {e}"));
    }
    for (stream, len) in lzf_seeds() {
        let mut out = Vec::new();
        lzf::decompress(&stream, len, &mut out).expect("LZF seed decompresses");
        assert!(stream.len() < len || len < 40, "the seeds use back-references");
    }
    for (name, text) in BUILTIN_WORLDS {
        parse_scene(text, name).unwrap_or_else(|e| panic!("world {name}: {e}"));
    }
}

// ---------------------------------------------------------------------------------
// PCD.

/// Largest single allocation a PCD parse may make: an LZF body decompresses to at most
/// `lzf::MAX_EXPANSION` times its size, and the cloud holds 12 bytes for every point,
/// which the body must cover; a few KiB more for the header's own vectors.
fn pcd_allocation_bound(input_len: usize) -> usize {
    lzf::MAX_EXPANSION * input_len + 64 * 1024
}

fn check_pcd(bytes: &[u8]) -> Result<(), String> {
    let (result, largest, took) = measured(|| pcd::parse(bytes));
    within("PCD", largest, pcd_allocation_bound(bytes.len()), took)?;
    if let Ok(cloud) = result {
        if cloud.points.len() != cloud.width as usize * cloud.height as usize {
            return Err(format!("{}x{} cloud of {} points", cloud.width, cloud.height, cloud.points.len()));
        }
    }
    Ok(())
}

// ---------------------------------------------------------------------------------
// Depth PNG.

/// Largest single allocation a depth PNG parse may make: the image (2 bytes a pixel,
/// at most `MAX_PIXELS`) or the decoder's own buffers, a few times the file.
fn png_allocation_bound(input_len: usize) -> usize {
    2 * schemas::depth_codec::MAX_PIXELS + 4 * input_len + (1 << 20)
}

fn check_png(bytes: &[u8]) -> Result<(), String> {
    let (result, largest, took) = measured(|| depth_png::parse(bytes));
    within("PNG", largest, png_allocation_bound(bytes.len()), took)?;
    if let Ok(img) = result {
        if img.samples.len() != img.width as usize * img.height as usize {
            return Err(format!("{}x{} image of {} samples", img.width, img.height, img.samples.len()));
        }
    }
    Ok(())
}

// ---------------------------------------------------------------------------------
// LZF.

/// Decompresses and checks the output never passes the announced length, and that
/// nothing allocates beyond it (the caller bounds it: the PCD reader by
/// `MAX_EXPANSION` times the stream).
fn check_lzf(stream: &[u8], expected_len: usize) -> Result<(), String> {
    let mut out = Vec::new();
    let (result, largest, took) = measured(|| lzf::decompress(stream, expected_len, &mut out));
    within("LZF", largest, expected_len + 64, took)?;
    match result {
        Ok(()) if out.len() != expected_len => Err(format!("{} bytes decoded, {expected_len} announced", out.len())),
        _ if out.len() > expected_len => Err(format!("output grew to {} past {expected_len}", out.len())),
        _ => Ok(()),
    }
}

// ---------------------------------------------------------------------------------
// Scene TOML.

/// Largest single allocation a scene parse may make: the parser's tables and strings
/// come from the text, so a multiple of it (the TOML parser keeps an event of about
/// 48 bytes per token: 100,000 nested `[` took 4.8 MB).
fn scene_allocation_bound(input_len: usize) -> usize {
    64 * input_len + 256 * 1024
}

fn check_scene(bytes: &[u8]) -> Result<(), String> {
    let text = String::from_utf8_lossy(bytes);
    let (_, largest, took) = measured(|| parse_scene(&text, "fuzz"));
    within("scene", largest, scene_allocation_bound(text.len()), took)
}

proptest! {
    #![proptest_config(config(CASES))]

    #[test]
    fn mutated_pcd_files_parse_or_are_refused(
        seed in any::<Index>(),
        mutations in prop::collection::vec(mutation(), 1..6),
    ) {
        let bytes = mutated(&PCD_SEEDS, &seed, &mutations);
        let outcome = check_pcd(&bytes);
        prop_assert!(outcome.is_ok(), "{:?}", outcome);
    }

    #[test]
    fn random_pcd_bodies_after_a_valid_header_are_refused_or_parse(
        kind in prop::sample::select(vec!["ascii", "binary", "binary_compressed"]),
        body in prop::collection::vec(any::<u8>(), 0..512),
    ) {
        let mut bytes = format!("{PCD_HEADER}DATA {kind}\n").into_bytes();
        bytes.extend_from_slice(&body);
        let outcome = check_pcd(&bytes);
        prop_assert!(outcome.is_ok(), "{:?}", outcome);
    }

    #[test]
    fn mutated_depth_pngs_parse_or_are_refused(
        seed in any::<Index>(),
        mutations in prop::collection::vec(mutation(), 1..6),
    ) {
        let bytes = mutated(&PNG_SEEDS, &seed, &mutations);
        let outcome = check_png(&bytes);
        prop_assert!(outcome.is_ok(), "{:?}", outcome);
    }

    #[test]
    fn mutated_lzf_streams_never_pass_the_announced_length(
        seed in any::<Index>(),
        mutations in prop::collection::vec(mutation(), 1..6),
        announced in prop_oneof![Just(None), (0..4096usize).prop_map(Some)],
    ) {
        let (_, len) = LZF_SEEDS[seed.index(LZF_SEEDS.len())];
        let stream = mutated(&LZF_STREAMS, &seed, &mutations);
        let outcome = check_lzf(&stream, announced.unwrap_or(len));
        prop_assert!(outcome.is_ok(), "{:?}", outcome);
    }

    #[test]
    fn random_lzf_streams_never_pass_the_announced_length(
        stream in prop::collection::vec(any::<u8>(), 0..512),
        announced in 0..65536usize,
    ) {
        let outcome = check_lzf(&stream, announced);
        prop_assert!(outcome.is_ok(), "{:?}", outcome);
    }

    #[test]
    fn mutated_scenes_parse_or_are_refused(
        seed in any::<Index>(),
        mutations in prop::collection::vec(mutation(), 1..6),
    ) {
        let bytes = mutated(&SCENE_SEEDS, &seed, &mutations);
        let outcome = check_scene(&bytes);
        prop_assert!(outcome.is_ok(), "{:?}", outcome);
    }
}

proptest! {
    // Random bytes rarely get past the first byte of any format: fewer cases.
    #![proptest_config(config(CASES / 4))]

    #[test]
    fn random_bytes_are_refused_by_every_reader(bytes in prop::collection::vec(any::<u8>(), 0..1024)) {
        for outcome in [check_pcd(&bytes), check_png(&bytes), check_scene(&bytes)] {
            prop_assert!(outcome.is_ok(), "{:?}", outcome);
        }
    }
}

// ---------------------------------------------------------------------------------
// Forged sizes: refused before allocating.

#[test]
fn pcd_headers_declaring_huge_clouds_are_refused_before_allocating() {
    for (size, body) in [("4096 8192", "ascii"), ("8192 4096", "binary"), ("5792 5792", "binary_compressed")] {
        let (w, h) = size.split_once(' ').expect("two numbers");
        let bytes = format!(
            "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH {w}\nHEIGHT {h}\nDATA {body}\n\
             \x00\x01\x00\x00\x00\x00\x00\x10 1 2 3\n"
        );
        let (result, largest, _) = measured(|| pcd::parse(bytes.as_bytes()));
        assert!(result.is_err(), "{size} {body}: {result:?}");
        assert!(largest <= pcd_allocation_bound(bytes.len()), "{size} {body}: allocated {largest} bytes at once");
    }
}

#[test]
fn pcd_field_counts_that_overflow_are_refused() {
    for counts in ["18446744073709551615 1 1 1", "1 1 1 18446744073709551615", "9223372036854775807 1 1 2"] {
        let bytes = format!(
            "FIELDS pad x y z\nSIZE 4 4 4 4\nTYPE U F F F\nCOUNT {counts}\nWIDTH 2\nHEIGHT 2\nDATA ascii\n1 2 3 4\n"
        );
        assert_eq!(check_pcd(bytes.as_bytes()), Ok(()), "COUNT {counts}");
        assert!(pcd::parse(bytes.as_bytes()).is_err(), "COUNT {counts}");
    }
}

/// A PNG's IHDR claiming `width` x `height` 16-bit samples, with a valid CRC and no
/// image data.
fn forged_png(width: u32, height: u32) -> Vec<u8> {
    let mut png = png_seeds().swap_remove(0);
    png[16..20].copy_from_slice(&width.to_be_bytes());
    png[20..24].copy_from_slice(&height.to_be_bytes());
    let crc = crc32(&png[12..29]);
    png[29..33].copy_from_slice(&crc.to_be_bytes());
    png
}

fn crc32(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in bytes {
        crc ^= b as u32;
        for _ in 0..8 {
            crc = if crc & 1 != 0 { crc >> 1 ^ 0xedb8_8320 } else { crc >> 1 };
        }
    }
    !crc
}

#[test]
fn pngs_declaring_huge_images_are_refused_before_allocating() {
    for (w, h) in [(65536, 65536), (1 << 20, 1 << 20), (0x7fff_ffff, 0x7fff_ffff), (4097, 4096), (1, 1 << 25)] {
        let png = forged_png(w, h);
        let (result, largest, _) = measured(|| depth_png::parse(&png));
        assert!(matches!(result, Err(FormatProblem::Unsupported(_))), "{w}x{h}: {result:?}");
        assert!(largest < 1 << 20, "{w}x{h}: allocated {largest} bytes at once");
    }
}

#[test]
fn deeply_nested_scene_text_is_refused_not_a_stack_overflow() {
    for depth in [1_000, 100_000] {
        let text = format!("name = {}", "[".repeat(depth));
        assert_eq!(check_scene(text.as_bytes()), Ok(()));
        assert!(parse_scene(&text, "nested").is_err());
        let text = format!("name = {}", "{a=".repeat(depth));
        assert_eq!(check_scene(text.as_bytes()), Ok(()));
    }
}

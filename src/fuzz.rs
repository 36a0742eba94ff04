//! `wearnav fuzz`: millions of damaged and random inputs through every decoder of
//! outside input, on stable Rust (nightly's `cargo fuzz` is not needed). CI runs a
//! bounded number of property-test cases (`schemas/tests/decoders.rs`,
//! `sensor-agent/tests/decoders.rs`, and `tests/decoders.rs` of the map, planning and
//! localization crates); this runs as many as you have time for.
//!
//! Each case starts from a valid seed (the golden wire vectors, depth images packed in
//! every mode, small PCD and PNG files, LZF streams, the built-in worlds' scenes, the
//! ROS map_saver map, semantic layers, CARMEN logs, Moving AI maps and scenarios) or
//! from random bytes, and applies a few seeded mutations: bit flips, byte overwrites,
//! truncations, random tails, overwritten runs, 0xff length fields, inserted tokens,
//! removed ranges and splices of another seed. Wire payloads are mostly resealed
//! (their CRC rewritten) so the decoder itself meets the damage. A case's generator
//! depends only on `--seed` and its number, so `--seed S --case N` replays it.
//!
//! Beyond "no panic", a case fails when a decoder breaks its contract: a wire payload
//! that decodes but does not re-encode to the same bytes, a sealed payload with one
//! flipped bit that decodes, a depth image or cloud that is not the size it declares,
//! LZF output past its announced length, a graymap or benchmark map without as many
//! cells as it declares, an accepted map YAML with thresholds out of order, a semantic
//! layer that does not read back as itself, a scan past `MAX_BEAMS` or with a negative
//! range. Results and how to reproduce: `docs/fuzzing.md`.

use std::collections::BTreeMap;
use std::fmt::Debug;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;
use std::time::{Duration, Instant};

use localization::carmen::{self, CarmenError};
use map::map_server::parse_map_yaml;
use map::pgm::decode_pgm;
use map::{MapError, SemanticLayer};
use planning::movingai::{parse_scenarios, MovingAiError, MovingAiMap};

use schemas::depth_codec::{self, CodecError};
use schemas::wire;
use schemas::*;
use sensor_agent::formats::{depth_png, lzf, pcd, FormatProblem};
use sensor_agent::sim::scene::{parse_scene, SceneError};
use sensor_agent::sim::world::BUILTIN_WORLDS;

/// A decoder to fuzz.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Target {
    /// Every decoder below, one after the other.
    All,
    /// The wire envelope and every schema (`schemas::decode`).
    Wire,
    /// The depth codec (`schemas::depth_codec::decode`), every mode, any size.
    DepthCodec,
    /// PCD point clouds: ascii, binary, binary_compressed.
    Pcd,
    /// 16-bit depth PNGs.
    Png,
    /// LZF streams (PCD's compressed bodies).
    Lzf,
    /// Scene TOML (simulated worlds).
    Scene,
    /// ROS map_server YAML (`map::map_server::parse_map_yaml`).
    MapYaml,
    /// Map graymaps: PGM P5 8 and 16 bit, P2 (`map::pgm::decode_pgm`).
    Pgm,
    /// Semantic layer TOML (`map::SemanticLayer::parse`).
    Semantic,
    /// CARMEN logs, plain text (`localization::carmen::parse_log`).
    Carmen,
    /// Moving AI benchmark maps and scenarios (`planning::movingai`).
    #[value(name = "movingai")]
    MovingAi,
    /// CAD floor plans, DXF text (`map::dxf::DxfImport::parse`).
    Dxf,
}

/// Every target `all` runs.
const TARGETS: [Target; 12] = [
    Target::Wire,
    Target::DepthCodec,
    Target::Pcd,
    Target::Png,
    Target::Lzf,
    Target::Scene,
    Target::MapYaml,
    Target::Pgm,
    Target::Semantic,
    Target::Carmen,
    Target::MovingAi,
    Target::Dxf,
];

/// Arguments of `wearnav fuzz`.
#[derive(Debug, clap::Args)]
#[command(long_about = "Feed millions of mutated and random inputs to every decoder of outside input \
(wire envelope and schemas, depth codec, PCD, depth PNG, LZF, scene TOML, map YAML, PGM, semantic \
layer, CARMEN log, Moving AI map and scenarios, DXF floor plan), catching panics.\n\n\
Prints per target the cases run, cases per second, the outcomes by error kind (`ok` when the input \
decoded), the slowest case, and every panic or broken contract with the seed and case number that \
replay it (`--seed S --case N`). Exits non-zero if any case panicked or broke a contract.\n\n\
Build it in release for speed: `cargo run --release -- fuzz --seconds 60`.")]
pub struct FuzzArgs {
    /// Decoder to fuzz.
    #[arg(long, value_enum, default_value_t = Target::All)]
    pub target: Target,
    /// Cases per target (instead of --seconds).
    #[arg(long, conflicts_with = "seconds")]
    pub cases: Option<u64>,
    /// Seconds per target.
    #[arg(long, default_value_t = 10.0)]
    pub seconds: f64,
    /// Seed of the mutator: the same seed runs the same cases.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Run only this case number (with the --seed that reported it), to reproduce it
    /// with the panic message and backtrace shown.
    #[arg(long)]
    pub case: Option<u64>,
}

/// Runs the fuzzer as `args` say; an error if any case panicked or broke a contract.
pub fn run(args: &FuzzArgs) -> anyhow::Result<()> {
    let targets: Vec<Target> = if args.target == Target::All { TARGETS.to_vec() } else { vec![args.target] };
    let seeds = Seeds::new();
    if let Some(case) = args.case {
        for &target in &targets {
            let mut rng = Rng::for_case(args.seed, case);
            let outcome = fuzz_case(target, &seeds, &mut rng);
            println!("{target:?} seed {} case {case}: {outcome:?}", args.seed);
        }
        return Ok(());
    }
    // A panic is reported once per case below, with how to replay it.
    let default_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let mut failed = 0;
    for &target in &targets {
        let report = fuzz_target(target, &seeds, args);
        report.print(target, args.seed);
        failed += report.failures.len();
    }
    std::panic::set_hook(default_hook);
    anyhow::ensure!(failed == 0, "{failed} case(s) panicked or broke a decoder's contract");
    Ok(())
}

/// What one target's run found.
#[derive(Default)]
struct Report {
    cases: u64,
    elapsed: Duration,
    outcomes: BTreeMap<&'static str, u64>,
    slowest: (Duration, u64),
    /// (case number, what went wrong); at most [`MAX_LISTED`] kept.
    failures: Vec<(u64, String)>,
}

/// Failures listed per target; more are counted.
const MAX_LISTED: usize = 20;

impl Report {
    fn print(&self, target: Target, seed: u64) {
        let rate = self.cases as f64 / self.elapsed.as_secs_f64().max(1e-9);
        println!(
            "{target:?}: {} cases in {:.1} s ({rate:.0}/s), {} panicked or broke a contract, slowest case {:.2} ms (#{})",
            self.cases,
            self.elapsed.as_secs_f64(),
            self.failures.len(),
            self.slowest.0.as_secs_f64() * 1e3,
            self.slowest.1,
        );
        let outcomes: Vec<String> = self.outcomes.iter().map(|(kind, n)| format!("{kind} {n}")).collect();
        println!("  outcomes: {}", outcomes.join(", "));
        for (case, what) in self.failures.iter().take(MAX_LISTED) {
            println!("  FAILED case {case}: {what}\n    replay: wearnav fuzz --target {target:?} --seed {seed} --case {case}");
        }
    }
}

fn fuzz_target(target: Target, seeds: &Seeds, args: &FuzzArgs) -> Report {
    let mut report = Report::default();
    let budget = Duration::from_secs_f64(args.seconds.max(0.0));
    let start = Instant::now();
    let mut case = 0u64;
    loop {
        match args.cases {
            Some(n) if case >= n => break,
            // the clock is read every 256 cases: a case takes microseconds
            None if case % 256 == 0 && start.elapsed() >= budget => break,
            _ => {}
        }
        let mut rng = Rng::for_case(args.seed, case);
        let began = Instant::now();
        let outcome = catch_unwind(AssertUnwindSafe(|| fuzz_case(target, seeds, &mut rng)));
        let took = began.elapsed();
        if took > report.slowest.0 {
            report.slowest = (took, case);
        }
        match outcome {
            Ok(Ok(kind)) => *report.outcomes.entry(kind).or_default() += 1,
            Ok(Err(broken)) => {
                *report.outcomes.entry("BROKEN CONTRACT").or_default() += 1;
                report.failures.push((case, broken));
            }
            Err(panic) => {
                *report.outcomes.entry("PANIC").or_default() += 1;
                let message = panic
                    .downcast_ref::<&str>()
                    .map(|s| s.to_string())
                    .or_else(|| panic.downcast_ref::<String>().cloned())
                    .unwrap_or_default();
                report.failures.push((case, format!("panic: {message}")));
            }
        }
        case += 1;
    }
    report.cases = case;
    report.elapsed = start.elapsed();
    report
}

/// One case of `target`: the outcome's kind (`ok` or the decoder's error kind), or
/// how the decoder broke its contract.
fn fuzz_case(target: Target, seeds: &Seeds, rng: &mut Rng) -> Result<&'static str, String> {
    match target {
        Target::All | Target::Wire => wire_case(seeds, rng),
        Target::DepthCodec => codec_case(seeds, rng),
        Target::Pcd => {
            let bytes = input(&seeds.pcd, rng);
            pcd_outcome(pcd::parse(&bytes).map(|c| (c.points.len(), c.width as usize * c.height as usize)))
        }
        Target::Png => {
            let bytes = input(&seeds.png, rng);
            pcd_outcome(depth_png::parse(&bytes).map(|i| (i.samples.len(), i.width as usize * i.height as usize)))
        }
        Target::Lzf => lzf_case(seeds, rng),
        Target::Scene => {
            let bytes = input(&seeds.scene, rng);
            Ok(match parse_scene(&String::from_utf8_lossy(&bytes), "fuzz") {
                Ok(_) => "ok",
                Err(SceneError::Syntax { .. }) => "syntax",
                Err(SceneError::Invalid { .. }) => "invalid",
                Err(SceneError::Io { .. }) => "io",
                Err(SceneError::UnknownWorld { .. }) => "unknown_world",
                Err(SceneError::Generate(_)) => "generate",
            })
        }
        Target::MapYaml => {
            let bytes = input(&seeds.map_yaml, rng);
            match parse_map_yaml(&String::from_utf8_lossy(&bytes), Path::new("fuzz.yaml")) {
                Err(e) => Ok(map_kind(&e)),
                Ok(m)
                    if m.free_thresh < 0.0
                        || m.free_thresh >= m.occupied_thresh
                        || m.occupied_thresh > 1.0
                        || !(m.resolution_m > 0.0 && m.resolution_m <= map::MAX_RESOLUTION_M)
                        || ![m.origin.x_m, m.origin.y_m, m.origin.yaw_rad].iter().all(|v| v.is_finite()) =>
                {
                    Err(format!("accepted {m:?}"))
                }
                Ok(_) => Ok("ok"),
            }
        }
        Target::Pgm => {
            let bytes = input(&seeds.pgm, rng);
            match decode_pgm(&bytes, Path::new("fuzz.pgm")) {
                Err(e) => Ok(map_kind(&e)),
                Ok(i) if i.pixels.len() != i.width * i.height => {
                    Err(format!("{}x{} graymap of {} pixels", i.width, i.height, i.pixels.len()))
                }
                Ok(_) => Ok("ok"),
            }
        }
        Target::Semantic => {
            let bytes = input(&seeds.semantic, rng);
            let file = Path::new("fuzz.toml");
            match SemanticLayer::parse(&String::from_utf8_lossy(&bytes), file) {
                Err(e) => Ok(map_kind(&e)),
                // what was accepted writes out and reads back (normals are normalised again)
                Ok(layer) => match SemanticLayer::parse(&layer.to_toml(), file) {
                    Ok(again) if again.labels == layer.labels && again.areas == layer.areas => Ok("ok"),
                    other => Err(format!("{layer:?} reads back as {other:?}")),
                },
            }
        }
        Target::Dxf => {
            let bytes = input(&seeds.dxf, rng);
            // 10 cm cells: the same code as the default's 5 cm, a quarter of the cells
            let import = map::dxf::DxfImport { resolution_m: 0.1, ..map::dxf::DxfImport::default() };
            match import.parse(&bytes, Path::new("fuzz.dxf")) {
                Err(e) => Ok(map_kind(&e)),
                Ok(f) if f.grid.cells().len() != f.grid.width() * f.grid.height() => {
                    Err(format!("{}x{} grid of {} cells", f.grid.width(), f.grid.height(), f.grid.cells().len()))
                }
                Ok(f) if f.semantic.labels.iter().any(|l| f.grid.world_to_cell(l.x, l.y).is_none()) => {
                    Err(format!("a label outside the {}x{} grid", f.grid.width(), f.grid.height()))
                }
                Ok(_) => Ok("ok"),
            }
        }
        Target::Carmen => {
            let bytes = input(&seeds.carmen, rng);
            match carmen::parse_log(bytes.as_slice(), Path::new("fuzz.log")) {
                Err(CarmenError::Io { .. }) => Ok("io"),
                Err(CarmenError::Parse { .. }) => Ok("parse"),
                Err(CarmenError::TooLarge { .. }) => Ok("too_large"),
                Ok(log)
                    if log.lasers().any(|l| {
                        l.ranges_m.len() > carmen::MAX_BEAMS || l.ranges_m.iter().any(|r| !(r.is_finite() && *r >= 0.0))
                    }) =>
                {
                    Err("a scan past MAX_BEAMS or with a range that is negative or not finite".into())
                }
                Ok(_) => Ok("ok"),
            }
        }
        Target::MovingAi => {
            let moving_ai = |e: MovingAiError| match e {
                MovingAiError::Io { .. } => "io",
                MovingAiError::Format { .. } => "format",
            };
            if rng.below(2) == 0 {
                let bytes = input(&seeds.movingai_maps, rng);
                match MovingAiMap::parse(&String::from_utf8_lossy(&bytes), Path::new("fuzz.map")) {
                    Err(e) => Ok(moving_ai(e)),
                    Ok(m) if m.passable.len() != m.width * m.height => {
                        Err(format!("{}x{} map of {} cells", m.width, m.height, m.passable.len()))
                    }
                    Ok(_) => Ok("ok map"),
                }
            } else {
                let bytes = input(&seeds.movingai_scenarios, rng);
                match parse_scenarios(&String::from_utf8_lossy(&bytes), Path::new("fuzz.scen")) {
                    Err(e) => Ok(moving_ai(e)),
                    Ok(_) => Ok("ok scenarios"),
                }
            }
        }
    }
}

/// The kind of a map reader's error.
fn map_kind(e: &MapError) -> &'static str {
    match e {
        MapError::Io { .. } => "io",
        MapError::FileTooLarge { .. } => "file_too_large",
        MapError::Yaml { .. } => "yaml",
        MapError::BadField { .. } => "bad_field",
        MapError::Thresholds { .. } => "thresholds",
        MapError::Resolution { .. } => "resolution",
        MapError::UnknownImageFormat { .. } => "unknown_image_format",
        MapError::Pgm { .. } => "pgm",
        MapError::Png { .. } => "png",
        MapError::Empty { .. } => "empty",
        MapError::TooLarge { .. } => "too_large",
        MapError::SizeMismatch { .. } => "size_mismatch",
        MapError::Semantic { .. } => "semantic",
        MapError::Building { .. } => "building",
        MapError::Dxf { .. } => "dxf",
    }
}

/// A mutated seed, or one time in eight random bytes.
fn input(seeds: &[Vec<u8>], rng: &mut Rng) -> Vec<u8> {
    if rng.below(8) == 0 {
        return rng.bytes(1024);
    }
    let mut bytes = seeds[rng.below(seeds.len() as u64) as usize].clone();
    for _ in 0..1 + rng.below(4) {
        mutate(&mut bytes, seeds, rng);
    }
    bytes
}

/// Text a header or TOML reader may trip on.
const TOKENS: [&str; 16] = [
    "4294967295",
    "18446744073709551615",
    "99999999999999999999",
    "-1",
    "0",
    "nan",
    "inf",
    "-1e400",
    "1e308",
    "\n",
    " ",
    "\"",
    "[",
    "]]",
    "=",
    "\nDATA binary\n",
];

/// One random change to `bytes`.
fn mutate(bytes: &mut Vec<u8>, seeds: &[Vec<u8>], rng: &mut Rng) {
    let pos = |rng: &mut Rng, len: usize| rng.below(len as u64 + 1) as usize;
    match rng.below(10) {
        0 | 1 if !bytes.is_empty() => {
            let i = rng.below(bytes.len() as u64) as usize;
            bytes[i] ^= 1 << rng.below(8);
        }
        2 if !bytes.is_empty() => {
            let i = rng.below(bytes.len() as u64) as usize;
            bytes[i] = [0, 0xff, 0x7f, 0x80, 1, rng.next() as u8][rng.below(6) as usize];
        }
        3 => bytes.truncate(pos(rng, bytes.len())),
        4 => {
            let mut tail = rng.bytes(31);
            tail.push(rng.next() as u8);
            bytes.extend_from_slice(&tail);
        }
        5 => {
            let start = pos(rng, bytes.len());
            let end = (start + 1 + rng.below(64) as usize).min(bytes.len());
            let v = rng.next() as u8;
            bytes[start..end].fill(v);
        }
        6 => {
            // a forged length or count: 1 to 8 bytes of 0xff
            let start = pos(rng, bytes.len());
            let end = (start + 1 + rng.below(8) as usize).min(bytes.len());
            bytes[start..end].fill(0xff);
        }
        7 => {
            let at = pos(rng, bytes.len());
            let token = TOKENS[rng.below(TOKENS.len() as u64) as usize];
            bytes.splice(at..at, token.bytes());
        }
        8 => {
            let start = pos(rng, bytes.len());
            let end = (start + 1 + rng.below(32) as usize).min(bytes.len());
            bytes.drain(start..end);
        }
        _ => {
            let other = &seeds[rng.below(seeds.len() as u64) as usize];
            let from = pos(rng, other.len());
            bytes.truncate(pos(rng, bytes.len()));
            bytes.extend_from_slice(&other[from..]);
        }
    }
}

fn wire_case(seeds: &Seeds, rng: &mut Rng) -> Result<&'static str, String> {
    let seed = &seeds.wire[rng.below(seeds.wire.len() as u64) as usize];
    let schema = schema_of(seed);
    let mut bytes = seed.clone();
    match rng.below(16) {
        // one flipped bit in a sealed payload: always refused
        0 => {
            let bit = rng.below(bytes.len() as u64 * 8) as usize;
            bytes[bit / 8] ^= 1 << (bit % 8);
            match wire_outcome(schema, &bytes)? {
                "ok" => Err(format!("{} payload with bit {bit} flipped decodes", schema.name())),
                kind => Ok(kind),
            }
        }
        // random bytes
        1 => wire_outcome(schema, &rng.bytes(512)),
        // damaged and left unsealed: the checksum's job
        2 | 3 => {
            for _ in 0..1 + rng.below(4) {
                mutate(&mut bytes, &seeds.wire, rng);
            }
            wire_outcome(schema, &bytes)
        }
        // damaged and resealed, sometimes read as another schema: the decoder's job
        _ => {
            for _ in 0..1 + rng.below(4) {
                mutate(&mut bytes, &seeds.wire, rng);
            }
            wire::reseal(&mut bytes);
            let schema =
                if rng.below(8) == 0 { SchemaId::ALL[rng.below(SchemaId::ALL.len() as u64) as usize] } else { schema };
            wire_outcome(schema, &bytes)
        }
    }
}

fn schema_of(payload: &[u8]) -> SchemaId {
    let (header, _) = decode_header(payload).expect("wire seeds are valid payloads");
    SchemaId::from_u16(header.schema).expect("wire seeds have known schemas")
}

fn wire_outcome(schema: SchemaId, bytes: &[u8]) -> Result<&'static str, String> {
    match schema {
        SchemaId::DepthFrame => decode_checked::<DepthFrame>(bytes),
        SchemaId::ImuBatch => decode_checked::<ImuBatch>(bytes),
        SchemaId::OdomIncrement => decode_checked::<OdomIncrement>(bytes),
        SchemaId::GroundTruth => decode_checked::<GroundTruth>(bytes),
        SchemaId::Scan => decode_checked::<Scan>(bytes),
        SchemaId::Hazard => decode_checked::<Hazard>(bytes),
        SchemaId::Pose => decode_checked::<Pose>(bytes),
        SchemaId::RouteState => decode_checked::<RouteState>(bytes),
        SchemaId::HapticIntent => decode_checked::<HapticIntent>(bytes),
        SchemaId::SpeechIntent => decode_checked::<SpeechIntent>(bytes),
        SchemaId::Applied => decode_checked::<Applied>(bytes),
        SchemaId::Command => decode_checked::<Command>(bytes),
        SchemaId::HealthStats => decode_checked::<HealthStats>(bytes),
        SchemaId::Destinations => decode_checked::<Destinations>(bytes),
        SchemaId::PhoneHaptic => decode_checked::<PhoneHaptic>(bytes),
        SchemaId::PhoneSpeech => decode_checked::<PhoneSpeech>(bytes),
        SchemaId::PhoneAck => decode_checked::<PhoneAck>(bytes),
        SchemaId::PhoneMotion => decode_checked::<PhoneMotion>(bytes),
        SchemaId::Pressure => decode_checked::<Pressure>(bytes),
        SchemaId::CameraPlace => decode_checked::<CameraPlace>(bytes),
    }
}

/// Decodes as `M`: the error's kind, or `ok` when what decoded re-encodes to the same
/// bytes (so it also decodes to the same value).
fn decode_checked<M: Message + Debug>(bytes: &[u8]) -> Result<&'static str, String> {
    match decode::<M>(bytes) {
        Err(e) => Ok(e.kind()),
        Ok((header, body)) => {
            let origin = Origin { sender: &header.sender, session: header.session };
            if encode(&origin, header.seq, header.capture_ns, &body) == bytes {
                Ok("ok")
            } else {
                Err(format!("{} decodes to {body:?} but re-encodes to other bytes", M::SCHEMA.name()))
            }
        }
    }
}

fn codec_case(seeds: &Seeds, rng: &mut Rng) -> Result<&'static str, String> {
    let (data, mut width, mut height, mut mode) = if rng.below(8) == 0 {
        let modes = [DepthEncoding::Raw, DepthEncoding::Lossless, DepthEncoding::Bounded { step: 5 }];
        let mut data = rng.bytes(2048);
        data.insert(0, 0xD3); // the format tag, so the decoder reads on
        (data, rng.below(100) as u32, rng.below(100) as u32, modes[rng.below(3) as usize])
    } else {
        let (seed, w, h, mode) = &seeds.codec[rng.below(seeds.codec.len() as u64) as usize];
        let mut data = seed.clone();
        for _ in 0..1 + rng.below(4) {
            mutate(&mut data, &seeds.codec_payloads, rng);
        }
        (data, *w, *h, *mode)
    };
    // Other sizes and modes than the payload's; the largest image rarely, as sizing
    // its 32 MB output takes a thousand ordinary cases' time.
    match rng.below(256) {
        0..16 => width = rng.next() as u32,
        16..32 => height = rng.below(70) as u32,
        32..48 => mode = DepthEncoding::Bounded { step: rng.next() as u16 },
        48 => (width, height) = (4096, 4096),
        _ => {}
    }
    let mut out = Vec::new();
    let result = depth_codec::decode(&data, width, height, mode, &mut out);
    let pixels = width as usize * height as usize;
    if out.len() > pixels || (result.is_ok() && out.len() != pixels) {
        return Err(format!("{width}x{height} {mode:?}: {} samples out ({result:?})", out.len()));
    }
    Ok(match result {
        Ok(()) => "ok",
        Err(CodecError::SizeMismatch { .. }) => "size_mismatch",
        Err(CodecError::Corrupt(_)) => "corrupt",
        Err(CodecError::ZeroStep) => "zero_step",
        Err(CodecError::TooLarge { .. }) => "too_large",
    })
}

/// The kind of a file reader's outcome, given (items read, items declared) on success.
fn pcd_outcome(result: Result<(usize, usize), FormatProblem>) -> Result<&'static str, String> {
    match result {
        Ok((got, declared)) if got != declared => Err(format!("{got} items read, {declared} declared")),
        Ok(_) => Ok("ok"),
        Err(FormatProblem::Io(_)) => Ok("io"),
        Err(FormatProblem::BadHeader { .. }) => Ok("bad_header"),
        Err(FormatProblem::MissingHeader(_)) => Ok("missing_header"),
        Err(FormatProblem::Unsupported(_)) => Ok("unsupported"),
        Err(FormatProblem::Truncated(_)) => Ok("truncated"),
        Err(FormatProblem::Corrupt(_)) => Ok("corrupt"),
    }
}

fn lzf_case(seeds: &Seeds, rng: &mut Rng) -> Result<&'static str, String> {
    let (stream, len) = &seeds.lzf[rng.below(seeds.lzf.len() as u64) as usize];
    let streams: Vec<Vec<u8>> = seeds.lzf.iter().map(|s| s.0.clone()).collect();
    let stream = if rng.below(8) == 0 {
        rng.bytes(512)
    } else {
        let mut bytes = stream.clone();
        for _ in 0..1 + rng.below(4) {
            mutate(&mut bytes, &streams, rng);
        }
        bytes
    };
    // the PCD reader never announces more than MAX_EXPANSION times the stream
    let announced = if rng.below(4) == 0 { rng.below(lzf::MAX_EXPANSION as u64 * 512) as usize } else { *len };
    let mut out = Vec::new();
    let result = lzf::decompress(&stream, announced, &mut out);
    if out.len() > announced || (result.is_ok() && out.len() != announced) {
        return Err(format!("{} bytes out, {announced} announced ({result:?})", out.len()));
    }
    Ok(match result {
        Ok(()) => "ok",
        Err(lzf::LzfError::InputEnds(_)) => "input_ends",
        Err(lzf::LzfError::BadReference { .. }) => "bad_reference",
        Err(lzf::LzfError::Overflow(_)) => "overflow",
        Err(lzf::LzfError::Underflow { .. }) => "underflow",
    })
}

// ---------------------------------------------------------------------------------
// Seeds.

/// Valid inputs of every decoder, made once.
struct Seeds {
    wire: Vec<Vec<u8>>,
    /// (payload, width, height, mode)
    codec: Vec<(Vec<u8>, u32, u32, DepthEncoding)>,
    codec_payloads: Vec<Vec<u8>>,
    pcd: Vec<Vec<u8>>,
    png: Vec<Vec<u8>>,
    /// (stream, decompressed length)
    lzf: Vec<(Vec<u8>, usize)>,
    scene: Vec<Vec<u8>>,
    map_yaml: Vec<Vec<u8>>,
    pgm: Vec<Vec<u8>>,
    semantic: Vec<Vec<u8>>,
    carmen: Vec<Vec<u8>>,
    dxf: Vec<Vec<u8>>,
    movingai_maps: Vec<Vec<u8>>,
    movingai_scenarios: Vec<Vec<u8>>,
}

/// The golden vectors (`schemas/vectors`, kept current by `schemas/tests/golden.rs`):
/// representative values of every message as `encode` writes them.
const GOLDEN: [&[u8]; 53] = [
    include_bytes!("../schemas/vectors/applied_device_status.bin"),
    include_bytes!("../schemas/vectors/applied_offline_warning.bin"),
    include_bytes!("../schemas/vectors/applied_rumble.bin"),
    include_bytes!("../schemas/vectors/applied_speech_dropped.bin"),
    include_bytes!("../schemas/vectors/applied_speech_finished.bin"),
    include_bytes!("../schemas/vectors/applied_speech_interrupted.bin"),
    include_bytes!("../schemas/vectors/applied_speech_started.bin"),
    include_bytes!("../schemas/vectors/camera_place.bin"),
    include_bytes!("../schemas/vectors/command_cancel.bin"),
    include_bytes!("../schemas/vectors/command_destination.bin"),
    include_bytes!("../schemas/vectors/command_floor.bin"),
    include_bytes!("../schemas/vectors/command_mute.bin"),
    include_bytes!("../schemas/vectors/command_repeat.bin"),
    include_bytes!("../schemas/vectors/command_where_am_i.bin"),
    include_bytes!("../schemas/vectors/destinations.bin"),
    include_bytes!("../schemas/vectors/depth_frame_bounded.bin"),
    include_bytes!("../schemas/vectors/depth_frame_lossless.bin"),
    include_bytes!("../schemas/vectors/depth_frame_raw.bin"),
    include_bytes!("../schemas/vectors/ground_truth.bin"),
    include_bytes!("../schemas/vectors/haptic_intent_pulses.bin"),
    include_bytes!("../schemas/vectors/haptic_intent_steady.bin"),
    include_bytes!("../schemas/vectors/hazard_both.bin"),
    include_bytes!("../schemas/vectors/hazard_clear.bin"),
    include_bytes!("../schemas/vectors/hazard_left.bin"),
    include_bytes!("../schemas/vectors/hazard_right.bin"),
    include_bytes!("../schemas/vectors/health_stats.bin"),
    include_bytes!("../schemas/vectors/imu_batch.bin"),
    include_bytes!("../schemas/vectors/imu_batch_empty.bin"),
    include_bytes!("../schemas/vectors/odom_increment.bin"),
    include_bytes!("../schemas/vectors/phone_ack_ended.bin"),
    include_bytes!("../schemas/vectors/phone_ack_failed.bin"),
    include_bytes!("../schemas/vectors/phone_ack_interrupted.bin"),
    include_bytes!("../schemas/vectors/phone_ack_started.bin"),
    include_bytes!("../schemas/vectors/phone_ack_vibrated.bin"),
    include_bytes!("../schemas/vectors/phone_haptic.bin"),
    include_bytes!("../schemas/vectors/phone_haptic_stop.bin"),
    include_bytes!("../schemas/vectors/phone_motion.bin"),
    include_bytes!("../schemas/vectors/phone_motion_unknown.bin"),
    include_bytes!("../schemas/vectors/phone_speech_cut.bin"),
    include_bytes!("../schemas/vectors/phone_speech_say.bin"),
    include_bytes!("../schemas/vectors/pose.bin"),
    include_bytes!("../schemas/vectors/pose_lost.bin"),
    include_bytes!("../schemas/vectors/pressure.bin"),
    include_bytes!("../schemas/vectors/route_state_active.bin"),
    include_bytes!("../schemas/vectors/route_state_idle.bin"),
    include_bytes!("../schemas/vectors/route_state_preview.bin"),
    include_bytes!("../schemas/vectors/scan.bin"),
    include_bytes!("../schemas/vectors/scan_empty.bin"),
    include_bytes!("../schemas/vectors/speech_intent_important.bin"),
    include_bytes!("../schemas/vectors/speech_intent_message.bin"),
    include_bytes!("../schemas/vectors/speech_intent_notification.bin"),
    include_bytes!("../schemas/vectors/speech_intent_progress.bin"),
    include_bytes!("../schemas/vectors/speech_intent_text.bin"),
];

impl Seeds {
    fn new() -> Seeds {
        let codec = codec_seeds();
        Seeds {
            wire: wire_seeds(),
            codec_payloads: codec.iter().map(|s| s.0.clone()).collect(),
            codec,
            pcd: pcd_seeds(),
            png: png_seeds(),
            lzf: lzf_seeds(),
            scene: BUILTIN_WORLDS.iter().map(|(_, text)| text.as_bytes().to_vec()).collect(),
            map_yaml: texts(&MAP_YAMLS),
            pgm: pgm_seeds(),
            semantic: texts(&SEMANTIC_LAYERS),
            carmen: carmen_seeds(),
            dxf: vec![FLOOR_DXF.to_vec(), SMALL_DXF.as_bytes().to_vec()],
            movingai_maps: texts(&MOVINGAI_MAPS),
            movingai_scenarios: texts(&MOVINGAI_SCENARIOS),
        }
    }
}

fn texts(texts: &[&str]) -> Vec<Vec<u8>> {
    texts.iter().map(|t| t.as_bytes().to_vec()).collect()
}

/// ROS map_saver's YAML for the TurtleBot3 world, and one of every other mode.
const MAP_YAMLS: [&str; 4] = [
    include_str!("../compute-agent/map/tests/data/map.yaml"),
    "image: m.png\nmode: raw\nresolution: 0.1\norigin: [0.5, -2.25, 1.5707963]\nnegate: true\n\
     occupied_thresh: 0.9\nfree_thresh: 0.1\n",
    "# a comment\nimage: \"floor 2/map.pgm\"\nresolution: 5e-2\norigin:\n  - -1.0\n  - 2\n  - 0\n\
     negate: 1\noccupied_thresh: 0.65\nfree_thresh: 0.196\nmode: scale\n",
    "{image: m.pgm, resolution: 1, origin: [0, 0, 0], negate: 0, occupied_thresh: 1, free_thresh: 0}\n",
];

/// The ROS map_saver graymap (384 x 384), small P5 ones of 8 and 16 bits and an odd
/// maxval, P2 ones with comments.
fn pgm_seeds() -> Vec<Vec<u8>> {
    let mut p5 = b"P5\n# CREATOR: map_saver.cpp 0.050 m/pix\n6 4\n255\n".to_vec();
    p5.extend((0..24).map(|i| [254, 0, 205][i % 3]));
    let mut p5_16 = b"P5 3 2 65535\n".to_vec();
    p5_16.extend([0u16, 65535, 1000, 40000, 205 * 257, 7].iter().flat_map(|v| v.to_be_bytes()));
    let mut p5_15 = b"P5\n2 3\n15\n".to_vec();
    p5_15.extend([0, 15, 7, 3, 15, 0]);
    vec![
        include_bytes!("../compute-agent/map/tests/data/map.pgm").to_vec(),
        p5,
        p5_16,
        p5_15,
        b"P2\n# a comment\n4 3 # trailing\n# another\n255\n254 0 205 254\n 0 0 254\n205 254 254 0 1\n".to_vec(),
        b"P2 2 2 65535 0 65535 300 40000\n".to_vec(),
    ]
}

/// The semantic layer of `map::semantic`'s documentation, and smaller ones.
/// The office floor ezdxf wrote (R2013, millimetres; `compute-agent/map/tests/data`).
const FLOOR_DXF: &[u8] = include_bytes!("../compute-agent/map/tests/data/floor.dxf");

/// A drawing in metres: a closed polyline with a bulge, an arc, a text.
const SMALL_DXF: &str = "0\nSECTION\n2\nHEADER\n9\n$INSUNITS\n70\n6\n0\nENDSEC\n0\nSECTION\n2\nENTITIES\n\
0\nLWPOLYLINE\n8\nWALLS\n90\n4\n70\n1\n10\n0\n20\n0\n10\n8\n20\n0\n42\n0.4\n10\n8\n20\n6\n10\n0\n20\n6\n\
0\nARC\n8\nW\n10\n4\n20\n3\n40\n0.5\n50\n10\n51\n300\n\
0\nTEXT\n8\nT\n10\n1\n20\n1\n1\nroom 1\n0\nENDSEC\n0\nEOF\n";

const SEMANTIC_LAYERS: [&str; 3] = [
    "[[label]]\nname = \"room 214\"\nx = 12.5\ny = 3.0\nfloor = 2\n\n\
     [[door]]\nnumber = \"214\"\nx = 12.0\ny = 2.0\nfloor = 2\nnormal = [0.0, 2.0]\n\n\
     [[corner]]\nx = 20.0\ny = 2.0\nfloor = 2\n\n\
     [[area]]\nname = \"east wing\"\nfloor = 2\npolygon = [[10.0, 0.0], [30.0, 0.0], [30.0, 20.0], [10.0, 20.0]]\n\n\
     [[area]]\nname = \"room 214\"\nfloor = 2\nparent = \"east wing\"\n\
     polygon = [[11.0, 2.0], [14.0, 2.0], [14.0, 5.0], [11.0, 5.0]]\n\n\
     [[gateway]]\nname = \"main elevator\"\ntype = \"elevator\"\n\
     stops = [ { floor = 0, x = 5.0, y = 5.0 }, { floor = 2, x = 5.0, y = 5.2 } ]\n",
    "label = [{ name = \"toilets\", x = 1, y = 2.5, floor = 0 }]\ncorner = [{ x = -3.0, y = 4e1, floor = 0 }]\n",
    "[[gateway]]\nname = \"stairs A\"\ntype = \"stairs\"\n\
     stops = [{ floor = -1, x = 0.0, y = 0.0 }, { floor = 0, x = 0.5, y = 0.0 }, { floor = 1, x = 1.0, y = 0.0 }]\n\
     [[door]]\nnumber = 'B1.07'\nx = 1.0\ny = 1.0\nfloor = -1\nnormal = [1e-3, -1e-3]\n",
];

/// Logs in the Intel lab log's shape (its header, `ODOM` lines, 180-beam `FLASER` scans
/// with `NEFF` after each; the property tests read the real log's first 10 KB), and a
/// small one with CRLF lines and the messages the reader skips.
fn carmen_seeds() -> Vec<Vec<u8>> {
    let mut intel = String::from(
        "# message formats defined: PARAM SYNC ODOM FLASER RLASER TRUEPOS \n# PARAM param_name param_value\n\
         PARAM robot_frontlaser_offset 0.0 nohost 0\nPARAM robot_rearlaser_offset 0.0 nohost 0\n",
    );
    for k in 0..4 {
        let t = 0.2 * k as f64;
        intel.push_str(&format!("ODOM 0 0 0 0 0 0 {t:.6} pippo {t:.6}\n"));
        let ranges: Vec<String> = (0..180).map(|i| format!("{}", 1.09 + 0.01 * ((i + k) % 37) as f64)).collect();
        intel.push_str(&format!(
            "FLASER 180 {} 0.0{k} 0 0 0.0{k} 0 0 {t:.6} nohost {t:.6}\nNEFF 30\n",
            ranges.join(" ")
        ));
    }
    let small = "# comment\r\nPARAM robot_frontlaser_offset 0.0 nohost 0\r\nODOM 1 2 0.5 0.1 0.2 0 10.5 pippo 10.5\r\n\
                 FLASER 3 1.0 2.0 3.0 0.5 -0.5 0.1 0.5 -0.5 0.1 11.0 pippo 11.0\r\nNEFF 15\r\n\r\n\
                 FLASER 0 0 0 0 0 0 0 12 h 12\nRLASER 1 2 3\nODOM -1e3 2E-2 3.14 0 0 0 13 h 13";
    vec![intel.into_bytes(), small.as_bytes().to_vec()]
}

/// Moving AI benchmark maps (`compute-agent/planning/tests/data`) and small ones.
const MOVINGAI_MAPS: [&str; 4] = [
    include_str!("../compute-agent/planning/tests/data/arena.map"),
    include_str!("../compute-agent/planning/tests/data/den312d.map"),
    "type octile\r\nheight 2\r\nwidth 3\r\nmap\r\n.@G\r\nS.T\r\n",
    "type octile\nwidth 5\nheight 3\nmap\n..W..\nT@.GS\n.....\ncited: Sturtevant 2012\n",
];

/// Their scenario files, and a small one.
const MOVINGAI_SCENARIOS: [&str; 3] = [
    include_str!("../compute-agent/planning/tests/data/arena.map.scen"),
    include_str!("../compute-agent/planning/tests/data/den312d.map.scen"),
    "version 1\r\n0\tm.map\t3\t2\t0\t1\t2\t0\t2.41421356\r\ncitation line\n3\tm.map\t3\t2\t2\t1\t0\t0\t1e0\n",
];

/// A synthetic depth image: a floor ramp, a box, holes, noise and far outliers.
fn depth_image(w: u32, h: u32, seed: u64) -> Vec<u16> {
    let mut rng = Rng::for_case(seed, 0);
    (0..w * h)
        .map(|i| {
            let x = rng.next();
            let (c, r) = (i % w, i / w);
            if x % 13 == 0 || (c > w * 2 / 3 && r < h / 4) {
                0
            } else if (w / 4..w / 2).contains(&c) && (h / 3..h * 2 / 3).contains(&r) {
                800 + (x % 3) as u16
            } else if x % 97 == 0 {
                (x >> 20) as u16 | 1
            } else {
                4000u16.saturating_sub(r as u16 * 60) + c as u16 * 3 + (x % 5) as u16
            }
        })
        .collect()
}

/// The golden vectors plus a 32x24 depth frame in each encoding.
fn wire_seeds() -> Vec<Vec<u8>> {
    let mut seeds: Vec<Vec<u8>> = GOLDEN.iter().map(|b| b.to_vec()).collect();
    let (w, h) = (32, 24);
    for encoding in [DepthEncoding::Raw, DepthEncoding::Lossless, DepthEncoding::Bounded { step: 5 }] {
        let mut data = Vec::new();
        depth_codec::encode(&depth_image(w, h, 5), w, h, encoding, &mut data).expect("seed image packs");
        let frame = DepthFrame {
            width: w,
            height: h,
            depth_scale_m: 0.001,
            intrinsics: Intrinsics { fx: 28.0, fy: 28.0, cx: 15.5, cy: 11.5 },
            gravity_camera: Some([0.0, 0.87, 0.5]),
            mount: Some(MountGuess { height_m: 0.8, pitch_deg: 30.0 }),
            encoding,
            data,
        };
        seeds.push(encode(&Origin { sender: "fuzz", session: 7 }, 3, 1_763_776_800_000_000_000, &frame));
    }
    seeds
}

/// Depth images of odd shapes packed in every mode, an empty and an all-invalid one.
fn codec_seeds() -> Vec<(Vec<u8>, u32, u32, DepthEncoding)> {
    let modes = [
        DepthEncoding::Raw,
        DepthEncoding::Lossless,
        DepthEncoding::Bounded { step: 5 },
        DepthEncoding::Bounded { step: 1000 },
    ];
    let mut seeds = Vec::new();
    for (k, (w, h)) in [(1, 1), (4, 3), (13, 9), (32, 24), (64, 48), (3, 40)].into_iter().enumerate() {
        for mode in modes {
            let mut data = Vec::new();
            depth_codec::encode(&depth_image(w, h, k as u64), w, h, mode, &mut data).expect("seed image packs");
            seeds.push((data, w, h, mode));
        }
    }
    for (samples, w, h) in [(vec![], 0, 0), (vec![0; 40], 8, 5)] {
        let mut data = Vec::new();
        depth_codec::encode(&samples, w, h, DepthEncoding::Lossless, &mut data).expect("seed image packs");
        seeds.push((data, w, h, DepthEncoding::Lossless));
    }
    seeds
}

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

fn lzf_seeds() -> Vec<(Vec<u8>, usize)> {
    let texts: [Vec<u8>; 4] = [
        b"abcabcabcabcabcabcabcabc xyz xyz xyz".to_vec(),
        vec![7; 600],
        (0..300u32).flat_map(|i| (i % 17).to_le_bytes()).collect(),
        b"no repeats here: 0123456789".to_vec(),
    ];
    texts.iter().map(|t| (lzf_compress(t), t.len())).collect()
}

const PCD_HEADER: &str = "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z rgba\nSIZE 4 4 4 4\n\
     TYPE F F F U\nCOUNT 1 1 1 1\nWIDTH 6\nHEIGHT 4\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 24\n";

/// A 6x4 cloud in every body kind, and a 3x2 one with doubles, padding and a field of
/// COUNT 2.
fn pcd_seeds() -> Vec<Vec<u8>> {
    let points: Vec<[f32; 3]> = (0..24)
        .map(|i| {
            let (c, r) = ((i % 6) as f32, (i / 6) as f32);
            if i % 7 == 3 {
                [f32::NAN; 3]
            } else {
                [(c - 2.5) * 0.1, (r - 1.5) * 0.1, 1.0 + r * 0.25 + if c > 3.0 { -0.5 } else { 0.0 }]
            }
        })
        .collect();
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

fn png_bytes(width: u32, height: u32, depth: png::BitDepth, data: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    let mut encoder = png::Encoder::new(&mut out, width, height);
    encoder.set_color(png::ColorType::Grayscale);
    encoder.set_depth(depth);
    let mut writer = encoder.write_header().expect("seed PNG header writes");
    writer.write_image_data(data).expect("seed PNG data writes");
    writer.finish().expect("seed PNG ends");
    out
}

/// 16-bit depth PNGs of three sizes, and an 8-bit one (refused as unsupported).
fn png_seeds() -> Vec<Vec<u8>> {
    let depth = |w: u32, h: u32| -> Vec<u8> {
        (0..w * h).flat_map(|i| if i % 9 == 4 { 0u16 } else { 900 + (i % w) as u16 * 7 }.to_be_bytes()).collect()
    };
    vec![
        png_bytes(8, 6, png::BitDepth::Sixteen, &depth(8, 6)),
        png_bytes(1, 1, png::BitDepth::Sixteen, &depth(1, 1)),
        png_bytes(40, 30, png::BitDepth::Sixteen, &depth(40, 30)),
        png_bytes(4, 2, png::BitDepth::Eight, &[1, 2, 3, 4, 5, 6, 7, 8]),
    ]
}

// ---------------------------------------------------------------------------------

/// Marsaglia's xorshift64: fast, and a case's stream depends only on (seed, case).
struct Rng(u64);

impl Rng {
    fn for_case(seed: u64, case: u64) -> Rng {
        // splitmix64 of the pair, so neighbouring cases start far apart (never 0)
        let mut z = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ case.wrapping_add(0x6a09_e667_f3bc_c909);
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        Rng((z ^ (z >> 31)) | 1)
    }

    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }

    /// Uniform-enough in `0..n` (0 when n is 0).
    fn below(&mut self, n: u64) -> u64 {
        if n == 0 {
            0
        } else {
            self.next() % n
        }
    }

    /// Random bytes, up to `max_len` of them.
    fn bytes(&mut self, max_len: u64) -> Vec<u8> {
        let len = self.below(max_len + 1);
        (0..len).map(|_| self.next() as u8).collect()
    }
}

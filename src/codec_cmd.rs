//! `wearnav codec FILE`: how well a depth frame compresses on the wire, and how fast,
//! so a user can pick `lossless` or `bounded` for their Wi-Fi. Reads a 16-bit depth
//! PNG (units given by `--depth-scale`) or an organized PCD (converted to millimetres).

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Context;
use schemas::depth_codec::{DepthDecoder, DepthEncoder};
use schemas::DepthEncoding;
use sensor_agent::formats::{depth_png, pcd};
use sensor_agent::replay::organized_depth;
use sensor_agent::run::WireCodec;

/// Packing to measure.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum CodecMode {
    /// Exact samples.
    Lossless,
    /// Each sample within half of --step-mm of the truth.
    Bounded,
    /// Uncompressed little-endian u16.
    Raw,
}

/// Arguments of `wearnav codec`.
#[derive(Debug, clap::Args)]
pub struct CodecArgs {
    /// A 16-bit depth PNG or an organized PCD.
    pub file: PathBuf,
    /// Packing to measure.
    #[arg(long, value_enum, default_value_t = CodecMode::Lossless)]
    pub mode: CodecMode,
    /// Quantisation step of --mode bounded, millimetres (max error is half of it).
    #[arg(long, default_value_t = 5)]
    pub step_mm: u16,
    /// Metres per unit of a PNG (0.001 millimetres; 0.0002 for TUM's 5000 per metre).
    #[arg(long, default_value_t = 0.001)]
    pub depth_scale: f32,
    /// Timed repetitions; medians are reported.
    #[arg(long, default_value_t = 100)]
    pub runs: usize,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
}

/// What one file and mode measured.
#[derive(Debug, serde::Serialize)]
struct Report {
    file: String,
    width: u32,
    height: u32,
    encoding: String,
    raw_bytes: usize,
    packed_bytes: usize,
    ratio: f64,
    encode_median_us: f64,
    decode_median_us: f64,
    max_error_units: u16,
    max_error_mm: f64,
    runs: usize,
}

fn median_us(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(0.0)
}

/// Runs `wearnav codec`.
pub fn run(args: &CodecArgs) -> anyhow::Result<()> {
    anyhow::ensure!(args.runs >= 1, "--runs must be at least 1");
    anyhow::ensure!(args.depth_scale.is_finite() && args.depth_scale > 0.0, "--depth-scale must be positive");
    let is_pcd = args.file.extension().is_some_and(|e| e.eq_ignore_ascii_case("pcd"));
    let (width, height, samples, scale_m) = if is_pcd {
        let cloud = pcd::read(&args.file)?;
        let mut depth = Vec::new();
        organized_depth::depth_mm(&cloud, &mut depth);
        (cloud.width, cloud.height, depth, organized_depth::CLOUD_DEPTH_SCALE_M)
    } else {
        let img = depth_png::read(&args.file)?;
        (img.width, img.height, img.samples, args.depth_scale)
    };
    let encoding = match args.mode {
        CodecMode::Lossless => DepthEncoding::Lossless,
        CodecMode::Raw => DepthEncoding::Raw,
        CodecMode::Bounded => {
            anyhow::ensure!(args.step_mm >= 1, "--step-mm must be at least 1");
            WireCodec::BoundedMm(args.step_mm).encoding_for(scale_m)
        }
    };
    let mut enc = DepthEncoder::new();
    let mut dec = DepthDecoder::new();
    let (mut packed, mut back) = (Vec::new(), Vec::new());
    let (mut enc_us, mut dec_us) = (Vec::with_capacity(args.runs), Vec::with_capacity(args.runs));
    for _ in 0..args.runs {
        let t = Instant::now();
        enc.encode(&samples, width, height, encoding, &mut packed).context("packing")?;
        enc_us.push(t.elapsed().as_secs_f64() * 1e6);
        let t = Instant::now();
        dec.decode(&packed, width, height, encoding, &mut back).context("unpacking")?;
        dec_us.push(t.elapsed().as_secs_f64() * 1e6);
    }
    let max_error_units = samples.iter().zip(&back).map(|(a, b)| a.abs_diff(*b)).max().unwrap_or(0);
    let raw_bytes = samples.len() * 2;
    let report = Report {
        file: args.file.display().to_string(),
        width,
        height,
        encoding: format!("{encoding:?}"),
        raw_bytes,
        packed_bytes: packed.len(),
        ratio: raw_bytes as f64 / packed.len().max(1) as f64,
        encode_median_us: median_us(enc_us),
        decode_median_us: median_us(dec_us),
        max_error_units,
        max_error_mm: max_error_units as f64 * scale_m as f64 * 1000.0,
        runs: args.runs,
    };
    if args.json {
        println!("{}", serde_json::to_string(&report)?);
    } else {
        println!(
            "{}: {}x{} {}: {} -> {} bytes ({:.2}x), encode {:.0} us, decode {:.0} us (medians of {}), max error {} units = {:.2} mm",
            report.file,
            width,
            height,
            report.encoding,
            raw_bytes,
            report.packed_bytes,
            report.ratio,
            report.encode_median_us,
            report.decode_median_us,
            args.runs,
            max_error_units,
            report.max_error_mm,
        );
    }
    Ok(())
}

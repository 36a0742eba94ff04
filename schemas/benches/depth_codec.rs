//! Codec speed and ratio on the real depth PNGs in `tests/data/real/` (one core).
//! `cargo bench -p schemas --bench depth_codec` prints, per file and mode, the packed
//! size, the ratio to raw u16 and the median (and minimum) encode / decode time over
//! 200 runs. For a profiler, `RUNS=n` changes the run count and `ONLY=encode` or
//! `ONLY=decode` runs just that half, untimed:
//! `RUNS=500 ONLY=decode perf record target/release/deps/depth_codec-<hash>`.

use std::time::Instant;

use schemas::depth_codec::{DepthDecoder, DepthEncoder};
use schemas::DepthEncoding;

/// Median and minimum: on a shared machine the minimum is the closest to the cost
/// of the code alone.
fn median_min_us(mut v: Vec<f64>) -> (f64, f64) {
    v.sort_by(f64::total_cmp);
    (v[v.len() / 2], v[0])
}

fn main() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../tests/data/real");
    let runs = std::env::var("RUNS").ok().and_then(|r| r.parse().ok()).unwrap_or(200);
    let only = std::env::var("ONLY").unwrap_or_default();
    // 5 mm in each file's units: TUM stores 5000 per metre, Redwood millimetres.
    for (name, step_5mm) in [("tum_depth_640x480_u16_5000perm.png", 25), ("redwood_00000_depth_640x480_u16_mm.png", 5)]
    {
        let path = format!("{dir}/{name}");
        // Part of the checkout: a missing or broken file is a broken checkout.
        let file = std::fs::File::open(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
        let mut reader =
            png::Decoder::new(std::io::BufReader::new(file)).read_info().unwrap_or_else(|e| panic!("{path}: {e}"));
        let mut buf = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut buf).unwrap_or_else(|e| panic!("{path}: {e}"));
        let samples: Vec<u16> = buf.chunks_exact(2).map(|b| u16::from_be_bytes([b[0], b[1]])).collect();
        let (w, h) = (info.width, info.height);
        for mode in [DepthEncoding::Lossless, DepthEncoding::Bounded { step: step_5mm }] {
            let mut enc = DepthEncoder::new();
            let mut dec = DepthDecoder::new();
            let mut packed = Vec::new();
            let mut back = Vec::new();
            if only == "encode" || only == "decode" {
                enc.encode(&samples, w, h, mode, &mut packed).expect("real frame packs");
                for _ in 0..runs {
                    if only == "encode" {
                        enc.encode(&samples, w, h, mode, &mut packed).expect("real frame packs");
                    } else {
                        dec.decode(&packed, w, h, mode, &mut back).expect("own payload unpacks");
                    }
                }
                continue;
            }
            let mut enc_us = Vec::with_capacity(runs);
            let mut dec_us = Vec::with_capacity(runs);
            for _ in 0..runs {
                let t = Instant::now();
                enc.encode(&samples, w, h, mode, &mut packed).expect("real frame packs");
                enc_us.push(t.elapsed().as_secs_f64() * 1e6);
                let t = Instant::now();
                dec.decode(&packed, w, h, mode, &mut back).expect("own payload unpacks");
                dec_us.push(t.elapsed().as_secs_f64() * 1e6);
            }
            if runs == 0 {
                continue;
            }
            let (enc_med, enc_min) = median_min_us(enc_us);
            let (dec_med, dec_min) = median_min_us(dec_us);
            let max_err = samples.iter().zip(&back).map(|(a, b)| a.abs_diff(*b)).max().unwrap_or(0);
            println!(
                "{name:42} {mode:?}: {} bytes, {:.2}x, encode {enc_med:.0} us (min {enc_min:.0}), \
                 decode {dec_med:.0} us (min {dec_min:.0}), max error {max_err}",
                packed.len(),
                (samples.len() * 2) as f64 / packed.len() as f64,
            );
        }
    }
}

//! What the wire's integrity check costs per depth frame (one core): `cargo bench -p
//! schemas --bench wire` prints the median (and minimum) time to encode and to decode a
//! real frame's payload (the TUM frame, packed lossless, as the sensor agent sends it),
//! and of the CRC-32 over it alone, and of the receiver's freshness and sequence check
//! (`schemas::guard`), over 2000 runs (`RUNS=n` to change).

use std::time::{Duration, Instant};

use schemas::depth_codec::DepthEncoder;
use schemas::guard::{Clocks, Freshness, Guard};
use schemas::{DepthEncoding, DepthFrame, Header, Intrinsics, Origin};

fn median_min_us(mut v: Vec<f64>) -> (f64, f64) {
    v.sort_by(f64::total_cmp);
    (v[v.len() / 2], v[0])
}

fn time_us(runs: usize, mut f: impl FnMut()) -> (f64, f64) {
    let mut us = Vec::with_capacity(runs);
    for _ in 0..runs {
        let t = Instant::now();
        f();
        us.push(t.elapsed().as_secs_f64() * 1e6);
    }
    median_min_us(us)
}

fn main() {
    let runs = std::env::var("RUNS").ok().and_then(|r| r.parse().ok()).unwrap_or(2000);
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../tests/data/real/tum_depth_640x480_u16_5000perm.png");
    // Part of the checkout: a missing or broken file is a broken checkout.
    let file = std::fs::File::open(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let mut reader =
        png::Decoder::new(std::io::BufReader::new(file)).read_info().unwrap_or_else(|e| panic!("{path}: {e}"));
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap_or_else(|e| panic!("{path}: {e}"));
    let samples: Vec<u16> = buf.chunks_exact(2).map(|b| u16::from_be_bytes([b[0], b[1]])).collect();
    let mut data = Vec::new();
    DepthEncoder::new()
        .encode(&samples, info.width, info.height, DepthEncoding::Lossless, &mut data)
        .expect("real frame packs");
    let frame = DepthFrame {
        width: info.width,
        height: info.height,
        depth_scale_m: 0.0002,
        intrinsics: Intrinsics { fx: 525.0, fy: 525.0, cx: 319.5, cy: 239.5 },
        gravity_camera: Some([0.0, 0.88, 0.48]),
        mount: None,
        encoding: DepthEncoding::Lossless,
        data,
    };
    let origin = Origin { sender: "sensor-agent", session: 7 };
    let mut payload = Vec::new();
    schemas::encode_into(&origin, 1, 2, &frame, &mut payload);
    let body = &payload[..payload.len() - schemas::wire::CHECKSUM_BYTES];

    println!("depth frame payload: {} bytes (TUM frame, lossless), {runs} runs, microseconds", payload.len());
    let (med, min) = time_us(runs, || {
        std::hint::black_box(crc32fast::hash(std::hint::black_box(body)));
    });
    println!("  crc32 alone     median {med:8.1}  min {min:8.1}");
    let mut out = Vec::with_capacity(payload.len());
    let (med, min) = time_us(runs, || {
        out.clear();
        schemas::encode_into(&origin, 1, 2, &frame, &mut out);
    });
    println!("  encode          median {med:8.1}  min {min:8.1}");
    let (med, min) = time_us(runs, || {
        std::hint::black_box(schemas::decode::<DepthFrame>(&payload).expect("own payload decodes"));
    });
    println!("  decode          median {med:8.1}  min {min:8.1}");
    let (header, _) = schemas::decode::<DepthFrame>(&payload).expect("own payload decodes");
    let mut guard = Guard::new(Some(Freshness::within(Duration::from_millis(150))));
    let mut clocks = Clocks::default();
    clocks.observe("sensor-agent", 1_000, 1_500);
    let mut seq = 0;
    let (med, min) = time_us(runs, || {
        seq += 1;
        let h = Header { seq, ..header.clone() };
        let offset = clocks.offset_ns(&h.sender);
        std::hint::black_box(guard.check("wearnav/u/sensor/cane/depth", &h, h.capture_ns + 1_000_000, offset)).ok();
    });
    println!("  guard check     median {med:8.1}  min {min:8.1}");
}

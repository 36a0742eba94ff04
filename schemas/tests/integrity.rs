//! Every single-bit flip of a real depth frame's payload is refused: the codec alone
//! turned about 3 % of them into a different depth image that was perceived as real
//! (issue 36); the checksum trailer refuses them all before the codec sees them.

use schemas::depth_codec::DepthEncoder;
use schemas::{DepthEncoding, DepthFrame, Intrinsics, Origin, WireError};

fn tum_frame() -> DepthFrame {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../tests/data/real/tum_depth_640x480_u16_5000perm.png");
    let file = std::fs::File::open(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let mut reader =
        png::Decoder::new(std::io::BufReader::new(file)).read_info().unwrap_or_else(|e| panic!("{path}: {e}"));
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap_or_else(|e| panic!("{path}: {e}"));
    let samples: Vec<u16> = buf.chunks_exact(2).map(|b| u16::from_be_bytes([b[0], b[1]])).collect();
    let mut data = Vec::new();
    DepthEncoder::new()
        .encode(&samples, info.width, info.height, DepthEncoding::Bounded { step: 25 }, &mut data)
        .expect("real frame packs");
    DepthFrame {
        width: info.width,
        height: info.height,
        depth_scale_m: 0.0002,
        intrinsics: Intrinsics { fx: 525.0, fy: 525.0, cx: 319.5, cy: 239.5 },
        gravity_camera: Some([0.0, 0.88, 0.48]),
        mount: None,
        encoding: DepthEncoding::Bounded { step: 25 },
        data,
    }
}

#[test]
fn every_single_bit_flip_of_a_real_depth_payload_is_refused() {
    let payload = schemas::encode(&Origin { sender: "sensor-agent", session: 11 }, 5, 1_800_000_000, &tum_frame());
    let (_, back) = schemas::decode::<DepthFrame>(&payload).expect("the payload decodes undamaged");
    assert_eq!(back, tum_frame());
    let bits = payload.len() * 8;
    assert!(bits >= 10_000, "{bits} bits");
    let mut damaged = payload.clone();
    let mut kinds = std::collections::BTreeMap::new();
    for bit in 0..bits {
        damaged[bit / 8] ^= 1 << (bit % 8);
        let err = schemas::decode::<DepthFrame>(&damaged).expect_err("a flipped bit decoded");
        match (bit / 8, &err) {
            // schema id and version are read first, to name another build's layout
            (0 | 1, WireError::UnknownSchema(_) | WireError::WrongSchema { .. }) => {}
            (2 | 3, WireError::UnknownVersion { .. }) => {}
            (4.., WireError::Corrupt { .. }) => {}
            _ => panic!("bit {bit}: {err}"),
        }
        *kinds.entry(err.kind()).or_insert(0usize) += 1;
        damaged[bit / 8] ^= 1 << (bit % 8);
    }
    assert_eq!(kinds.values().sum::<usize>(), bits);
    println!("{bits} single-bit flips of a {}-byte depth payload, all refused: {kinds:?}", payload.len());
}

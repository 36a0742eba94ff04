//! From an organized point cloud to what the wire carries: a u16 depth image in
//! millimetres (depth = z, the optical-axis distance) and the pinhole intrinsics,
//! recovered from the cloud itself by least squares over its valid points
//! (u = fx * x/z + cx and v = fy * y/z + cy hold exactly for an organized cloud that
//! was projected from a depth image, as OpenNI and PCL grabbers do).

use schemas::Intrinsics;

use crate::formats::pcd::OrganizedCloud;

/// Depth unit of images made from clouds: millimetres.
pub const CLOUD_DEPTH_SCALE_M: f32 = 0.001;

/// Fewest valid points for an intrinsics fit.
const MIN_FIT_POINTS: usize = 100;
/// Largest RMS pixel residual of a fit accepted as a pinhole projection.
const MAX_FIT_RMS_PX: f64 = 1.0;

/// Writes the cloud's z in millimetres into `depth` (resized), 0 where invalid or out
/// of the u16 range.
pub fn depth_mm(cloud: &OrganizedCloud, depth: &mut Vec<u16>) {
    depth.clear();
    depth.extend(cloud.points.iter().map(|p| {
        let mm = (p[2] as f64 * 1000.0).round();
        if mm.is_finite() && mm >= 1.0 && mm <= u16::MAX as f64 {
            mm as u16
        } else {
            0
        }
    }));
}

/// Least-squares intrinsics of an organized cloud, with the RMS pixel residual.
/// Refuses clouds with too few valid points or that are not a pinhole projection
/// (transformed or filtered clouds): give intrinsics for those.
pub fn fit_intrinsics(cloud: &OrganizedCloud) -> Result<Intrinsics, String> {
    let w = cloud.width as usize;
    // Sums for two independent line fits: pixel column on x/z, pixel row on y/z.
    let mut sx = [0f64; 5];
    let mut sy = [0f64; 5];
    let mut n = 0usize;
    for (i, p) in cloud.points.iter().enumerate() {
        if !(p[2].is_finite() && p[2] > 0.0) {
            continue;
        }
        let (u, v) = ((i % w) as f64, (i / w) as f64);
        for (s, (a, b)) in [(&mut sx, (p[0] as f64 / p[2] as f64, u)), (&mut sy, (p[1] as f64 / p[2] as f64, v))] {
            s[0] += a;
            s[1] += b;
            s[2] += a * a;
            s[3] += a * b;
            s[4] += b * b;
        }
        n += 1;
    }
    if n < MIN_FIT_POINTS {
        return Err(format!("only {n} valid points: too few to recover intrinsics; give them"));
    }
    let nf = n as f64;
    let line = |s: &[f64; 5]| -> Option<(f64, f64, f64)> {
        let var = s[2] - s[0] * s[0] / nf;
        if var <= 1e-12 {
            return None;
        }
        let slope = (s[3] - s[0] * s[1] / nf) / var;
        let offset = (s[1] - slope * s[0]) / nf;
        // Residual sum of squares of b - (slope a + offset), from the sums.
        let sse = s[4] - 2.0 * slope * s[3] - 2.0 * offset * s[1]
            + slope * slope * s[2]
            + 2.0 * slope * offset * s[0]
            + offset * offset * nf;
        Some((slope, offset, (sse.max(0.0) / nf).sqrt()))
    };
    let ((fx, cx, rms_x), (fy, cy, rms_y)) = match (line(&sx), line(&sy)) {
        (Some(x), Some(y)) => (x, y),
        _ => return Err("valid points do not spread across the image: give intrinsics".into()),
    };
    if rms_x.max(rms_y) > MAX_FIT_RMS_PX {
        return Err(format!(
            "cloud is not a pinhole projection (fit residual {:.2} px): give intrinsics",
            rms_x.max(rms_y)
        ));
    }
    let k = Intrinsics { fx: fx as f32, fy: fy as f32, cx: cx as f32, cy: cy as f32 };
    if !k.is_valid() {
        return Err(format!("fitted intrinsics {k:?} are not a camera: give intrinsics"));
    }
    Ok(k)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn projected_cloud(k: Intrinsics, w: u32, h: u32) -> OrganizedCloud {
        let points = (0..w * h)
            .map(|i| {
                let (u, v) = ((i % w) as f32, (i / w) as f32);
                if i % 7 == 0 {
                    return [f32::NAN; 3];
                }
                let z = 1.0 + (u + 2.0 * v) * 0.01;
                [(u - k.cx) * z / k.fx, (v - k.cy) * z / k.fy, z]
            })
            .collect();
        OrganizedCloud { width: w, height: h, points }
    }

    #[test]
    fn intrinsics_of_a_projected_cloud_are_recovered() {
        let k = Intrinsics { fx: 570.3, fy: 565.1, cx: 319.5, cy: 241.0 };
        let fit = fit_intrinsics(&projected_cloud(k, 64, 48)).unwrap();
        assert!((fit.fx - k.fx).abs() < 0.05 && (fit.fy - k.fy).abs() < 0.05, "{fit:?}");
        assert!((fit.cx - k.cx).abs() < 0.05 && (fit.cy - k.cy).abs() < 0.05, "{fit:?}");
    }

    #[test]
    fn transformed_clouds_are_refused() {
        let k = Intrinsics { fx: 500.0, fy: 500.0, cx: 32.0, cy: 24.0 };
        // Rotated 180 degrees: a projection, but with negative focal lengths.
        let mut rotated = projected_cloud(k, 64, 48);
        rotated.points.reverse();
        assert!(fit_intrinsics(&rotated).unwrap_err().contains("not a camera"));
        // Rows shuffled: no pinhole maps these points to their pixels.
        let mut shuffled = projected_cloud(k, 64, 48);
        for r in 0..24 {
            for c in 0..64 {
                shuffled.points.swap(r * 64 + c, (47 - r) * 64 + (c * 7) % 64);
            }
        }
        let err = fit_intrinsics(&shuffled).unwrap_err();
        assert!(err.contains("not a pinhole projection"), "{err}");
    }

    #[test]
    fn depth_is_z_in_millimetres_and_invalid_is_zero() {
        let cloud = OrganizedCloud {
            width: 2,
            height: 2,
            points: vec![[0.1, 0.2, 1.2345], [f32::NAN; 3], [0.0, 0.0, 70.0], [0.0, 0.0, -1.0]],
        };
        let mut depth = Vec::new();
        depth_mm(&cloud, &mut depth);
        assert_eq!(depth, [1235, 0, 0, 0]);
    }

    #[test]
    fn kinect_frame_has_kinect_intrinsics() {
        // PCL projected this cloud from a Kinect depth image with fx = fy = 525,
        // cx = 319.5, cy = 239.5 (x and y agree with that to 6e-7 m).
        let path = crate::test_data::real_capture("five_people.pcd");
        let cloud = crate::formats::pcd::read(&path).unwrap();
        let k = fit_intrinsics(&cloud).unwrap();
        assert!((k.fx - 525.0).abs() < 0.1 && (k.fy - 525.0).abs() < 0.1, "{k:?}");
        assert!((k.cx - 319.5).abs() < 0.1 && (k.cy - 239.5).abs() < 0.1, "{k:?}");
        let mut depth = Vec::new();
        depth_mm(&cloud, &mut depth);
        assert_eq!(depth.iter().filter(|&&d| d > 0).count(), 239_075);
    }
}

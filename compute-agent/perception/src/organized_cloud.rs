//! Stage 1: from an organized depth image (or organized xyz cloud) to a strided sample
//! of 3-D points in the camera optical frame.
//!
//! Replaces the thesis's approximate voxel grid (Taylor 2017, sec. 2.2, 1 cm leaf): on
//! an organized image, keeping every n-th pixel of every n-th row gives the same
//! thinning without hashing, keeps each point's pixel (for rays and visibility) and
//! back-projects with two table look-ups per pixel instead of a division.

use schemas::Intrinsics;

use super::PerceptionError;

/// Pinhole view of the frame, for stages that reason about what the camera can see.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewGeometry {
    /// Half the horizontal field of view, radians.
    pub half_hfov_rad: f32,
    /// Half the vertical field of view, radians.
    pub half_vfov_rad: f32,
}

/// The strided sample of one frame. Buffers are reused across frames.
#[derive(Debug, Default)]
pub struct SampledCloud {
    /// Sampled points, row-major over the sampled grid, camera frame; NaN when invalid.
    pub points: Vec<[f32; 3]>,
    /// Indices into `points` of the valid ones.
    pub valid: Vec<u32>,
    /// Sampled grid width.
    pub cols: usize,
    /// Sampled grid height.
    pub rows: usize,
    /// Per sampled column, `(u - cx) / fx` (depth input only; empty for xyz).
    pub col_ray: Vec<f32>,
    /// Per sampled row, `(v - cy) / fy` (depth input only; empty for xyz).
    pub row_ray: Vec<f32>,
    /// Field of view of this frame.
    pub view: Option<ViewGeometry>,
    /// Valid pixels in the full image, estimated from the sample (`valid * stride^2`,
    /// exact at stride 1): counting all 307,200 pixels would cost more than the sample.
    pub points_valid: usize,
    ray_key: Option<(u32, u32, u32, [u32; 4])>,
}

impl SampledCloud {
    /// Back-projects a u16 depth image (0 = invalid) with a pinhole model.
    pub fn from_depth(
        &mut self,
        samples: &[u16],
        width: u32,
        height: u32,
        depth_scale_m: f32,
        k: Intrinsics,
        stride: u32,
    ) -> Result<(), PerceptionError> {
        check_size(samples.len(), width, height)?;
        if !k.is_valid() {
            return Err(PerceptionError::BadIntrinsics(k));
        }
        if !(depth_scale_m.is_finite() && depth_scale_m > 0.0) {
            return Err(PerceptionError::BadDepthScale(depth_scale_m));
        }
        let stride = stride.max(1);
        let key = (width, height, stride, [k.fx.to_bits(), k.fy.to_bits(), k.cx.to_bits(), k.cy.to_bits()]);
        if self.ray_key != Some(key) {
            self.col_ray.clear();
            self.col_ray.extend((0..width).step_by(stride as usize).map(|u| (u as f32 - k.cx) / k.fx));
            self.row_ray.clear();
            self.row_ray.extend((0..height).step_by(stride as usize).map(|v| (v as f32 - k.cy) / k.fy));
            self.ray_key = Some(key);
        }
        self.cols = self.col_ray.len();
        self.rows = self.row_ray.len();
        let left = ((k.cx + 0.5) / k.fx).atan();
        let right = ((width as f32 - 0.5 - k.cx) / k.fx).atan();
        let top = ((k.cy + 0.5) / k.fy).atan();
        let bottom = ((height as f32 - 0.5 - k.cy) / k.fy).atan();
        self.view = Some(ViewGeometry { half_hfov_rad: left.max(right), half_vfov_rad: top.max(bottom) });
        let w = width as usize;
        let stride = stride as usize;
        // Points are appended a row at a time and every index is written, the count
        // moving on only for valid pixels: no branch per pixel.
        self.points.clear();
        self.valid.clear();
        self.valid.resize(self.rows * self.cols, 0);
        let mut valid = 0;
        for (r, &b) in self.row_ray.iter().enumerate() {
            let row = samples[r * stride * w..][..w].iter().step_by(stride);
            let first = self.points.len();
            self.points.extend(row.zip(&self.col_ray).map(|(&s, &a)| {
                let z = s as f32 * depth_scale_m;
                if s == 0 {
                    [f32::NAN; 3]
                } else {
                    [a * z, b * z, z]
                }
            }));
            for (c, p) in (first..).zip(&self.points[first..]) {
                self.valid[valid] = c as u32;
                valid += usize::from(p[2] > 0.0);
            }
        }
        self.valid.truncate(valid);
        self.points_valid = estimate_full(self.valid.len(), stride, samples.len());
        Ok(())
    }

    /// Samples an organized xyz cloud (camera frame, NaN or non-positive z = invalid).
    /// With no intrinsics, the horizontal field of view is `hfov_deg` or, when `None`,
    /// measured from the widest valid ray of the frame.
    pub fn from_xyz(
        &mut self,
        points: &[[f32; 3]],
        width: u32,
        height: u32,
        stride: u32,
        hfov_deg: Option<f32>,
        vfov_deg: f32,
    ) -> Result<(), PerceptionError> {
        check_size(points.len(), width, height)?;
        let stride = stride.max(1) as usize;
        self.col_ray.clear();
        self.row_ray.clear();
        self.ray_key = None;
        self.cols = (width as usize).div_ceil(stride);
        self.rows = (height as usize).div_ceil(stride);
        self.points.clear();
        self.valid.clear();
        let w = width as usize;
        let mut widest = 0.0f32;
        for r in 0..self.rows {
            let row = &points[r * stride * w..][..w];
            for c in 0..self.cols {
                let p = row[c * stride];
                if is_valid(&p) {
                    widest = widest.max((p[0] / p[2]).abs());
                    self.valid.push(self.points.len() as u32);
                    self.points.push(p);
                } else {
                    self.points.push([f32::NAN; 3]);
                }
            }
        }
        self.points_valid = estimate_full(self.valid.len(), stride, points.len());
        let half_hfov_rad = match hfov_deg {
            Some(deg) => (deg * 0.5).to_radians(),
            None => widest.atan(),
        };
        self.view = Some(ViewGeometry { half_hfov_rad, half_vfov_rad: (vfov_deg * 0.5).to_radians() });
        Ok(())
    }

    /// Ray `(a, b, 1)` of sampled pixel `index`, when the input had intrinsics.
    pub fn ray(&self, index: usize) -> Option<[f32; 3]> {
        if self.col_ray.is_empty() {
            return None;
        }
        Some([self.col_ray[index % self.cols], self.row_ray[index / self.cols], 1.0])
    }
}

fn estimate_full(valid_sampled: usize, stride: usize, pixels: usize) -> usize {
    (valid_sampled * stride * stride).min(pixels)
}

fn is_valid(p: &[f32; 3]) -> bool {
    p[0].is_finite() && p[1].is_finite() && p[2].is_finite() && p[2] > 0.0
}

fn check_size(len: usize, width: u32, height: u32) -> Result<(), PerceptionError> {
    let expected = (width as usize).checked_mul(height as usize);
    if width == 0 || height == 0 || expected != Some(len) {
        return Err(PerceptionError::SizeMismatch { width, height, len });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const K: Intrinsics = Intrinsics { fx: 525.0, fy: 525.0, cx: 319.5, cy: 239.5 };

    #[test]
    fn depth_pixel_back_projects_through_the_pinhole() {
        let (w, h) = (640u32, 480u32);
        let mut samples = vec![0u16; (w * h) as usize];
        // pixel (420, 100) at 2.0 m (mm units)
        samples[100 * 640 + 420] = 2000;
        let mut cloud = SampledCloud::default();
        cloud.from_depth(&samples, w, h, 0.001, K, 2).unwrap();
        assert_eq!(cloud.points_valid, 4, "one sampled pixel stands for stride^2");
        assert_eq!(cloud.valid.len(), 1);
        let p = cloud.points[cloud.valid[0] as usize];
        assert!((p[0] - (420.0 - 319.5) / 525.0 * 2.0).abs() < 1e-5);
        assert!((p[1] - (100.0 - 239.5) / 525.0 * 2.0).abs() < 1e-5);
        assert!((p[2] - 2.0).abs() < 1e-6);
        let view = cloud.view.unwrap();
        assert!((view.half_hfov_rad.to_degrees() * 2.0 - 62.7).abs() < 0.2);
    }

    #[test]
    fn mismatched_sizes_and_bad_intrinsics_are_errors() {
        let mut cloud = SampledCloud::default();
        let samples = vec![1000u16; 100];
        assert!(matches!(cloud.from_depth(&samples, 640, 480, 0.001, K, 2), Err(PerceptionError::SizeMismatch { .. })));
        let nan_k = Intrinsics { fx: f32::NAN, ..K };
        assert!(matches!(cloud.from_depth(&samples, 10, 10, 0.001, nan_k, 2), Err(PerceptionError::BadIntrinsics(_))));
        assert!(matches!(cloud.from_depth(&samples, 10, 10, 0.0, K, 2), Err(PerceptionError::BadDepthScale(_))));
        let pts = vec![[0.0f32; 3]; 5];
        assert!(matches!(cloud.from_xyz(&pts, 2, 2, 1, None, 45.0), Err(PerceptionError::SizeMismatch { .. })));
    }

    #[test]
    fn xyz_nan_and_behind_camera_points_are_invalid() {
        let pts = vec![[f32::NAN, 0.0, 1.0], [0.1, 0.2, -1.0], [0.5, 0.0, 1.0], [0.0, 0.0, 0.0]];
        let mut cloud = SampledCloud::default();
        cloud.from_xyz(&pts, 2, 2, 1, None, 45.0).unwrap();
        assert_eq!(cloud.points_valid, 1, "exact at stride 1");
        assert_eq!(cloud.valid, vec![2]);
        assert!((cloud.view.unwrap().half_hfov_rad - 0.5f32.atan()).abs() < 1e-6);
    }
}

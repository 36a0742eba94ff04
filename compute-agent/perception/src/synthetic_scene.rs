//! Analytic test scenes with known ground truth, rendered into organized depth images
//! through the pinhole model: a floor (optionally with a step down), walls across the
//! path and boxes. For tests and benchmarks; the full simulator lives in `sensor-agent`.
//!
//! World = user frame: x forward, y left, z up, floor at z = 0, camera at `(0, 0,
//! height_m)` looking forward, pitched down by `pitch_deg`, no roll.

use schemas::{DepthEncoding, DepthFrame, Intrinsics};

/// Axis-aligned box in the world, metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Block {
    /// Min corner `(x, y, z)`.
    pub min: [f32; 3],
    /// Max corner `(x, y, z)`.
    pub max: [f32; 3],
}

/// A scene and the camera looking at it.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// Camera height above the floor, metres.
    pub height_m: f32,
    /// Downward pitch of the optical axis, degrees.
    pub pitch_deg: f32,
    /// Intrinsics of the rendered image.
    pub intrinsics: Intrinsics,
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// Floor present (false: nothing below, e.g. the camera looks at the sky).
    pub floor: bool,
    /// Floor ends at this forward distance and continues `step_down_m` lower.
    pub step: Option<(f32, f32)>,
    /// Walls across the whole view at these forward distances.
    pub walls_x_m: Vec<f32>,
    /// Boxes.
    pub blocks: Vec<Block>,
    /// Largest depth the sensor returns, metres (beyond: 0 = invalid).
    pub max_depth_m: f32,
}

impl Scene {
    /// Kinect-class 640x480 camera (fx = fy = 525, ~62 x 49 deg), empty floor.
    pub fn kinect(height_m: f32, pitch_deg: f32) -> Self {
        Self {
            height_m,
            pitch_deg,
            intrinsics: Intrinsics { fx: 525.0, fy: 525.0, cx: 319.5, cy: 239.5 },
            width: 640,
            height: 480,
            floor: true,
            step: None,
            walls_x_m: Vec::new(),
            blocks: Vec::new(),
            max_depth_m: 8.0,
        }
    }

    /// The true floor plane `[a, b, c, d]` in the camera frame, normal up.
    pub fn floor_plane_camera(&self) -> [f32; 4] {
        let (s, c) = self.pitch_deg.to_radians().sin_cos();
        [0.0, -c, -s, self.height_m]
    }

    /// Camera axes (optical x right, y down, z forward) in world coordinates.
    fn axes(&self) -> [[f32; 3]; 3] {
        let (s, c) = self.pitch_deg.to_radians().sin_cos();
        [[0.0, -1.0, 0.0], [-s, 0.0, -c], [c, 0.0, -s]]
    }

    /// Depth (along the optical axis) of pixel `(u, v)`, metres, or `None`.
    pub fn depth_at(&self, u: f32, v: f32) -> Option<f32> {
        let k = self.intrinsics;
        let (a, b) = ((u - k.cx) / k.fx, (v - k.cy) / k.fy);
        let [ex, ey, ez] = self.axes();
        let d = [a * ex[0] + b * ey[0] + ez[0], a * ex[1] + b * ey[1] + ez[1], a * ex[2] + b * ey[2] + ez[2]];
        let o = [0.0, 0.0, self.height_m];
        // t is the depth: the ray's optical-z component is 1
        let mut best = f32::INFINITY;
        let mut hit = |t: f32| {
            if t > 1e-4 && t < best {
                best = t;
            }
        };
        if self.floor && d[2] < 0.0 {
            let t = -o[2] / d[2];
            let x = t * d[0];
            match self.step {
                Some((step_x, drop)) if x >= step_x => {
                    let t_low = (-drop - o[2]) / d[2];
                    if t_low * d[0] >= step_x {
                        hit(t_low);
                    }
                }
                _ => hit(t),
            }
        }
        for &wx in &self.walls_x_m {
            if d[0] > 0.0 {
                hit(wx / d[0]);
            }
        }
        for b in &self.blocks {
            if let Some(t) = slab(&o, &d, b) {
                hit(t);
            }
        }
        (best <= self.max_depth_m).then_some(best)
    }

    /// Renders the scene as u16 depth with `depth_scale_m` metres per unit.
    pub fn render_depth(&self, depth_scale_m: f32) -> Vec<u16> {
        let mut out = Vec::with_capacity((self.width * self.height) as usize);
        for v in 0..self.height {
            for u in 0..self.width {
                let z = self.depth_at(u as f32, v as f32);
                out.push(z.map_or(0, |z| (z / depth_scale_m).round().min(u16::MAX as f32) as u16));
            }
        }
        out
    }

    /// The scene as a sensor agent would publish it: millimetre depth packed with
    /// `encoding`, the exact gravity (the floor's normal, pointing down).
    pub fn depth_frame(&self, encoding: DepthEncoding) -> Result<DepthFrame, schemas::depth_codec::CodecError> {
        let mut data = Vec::new();
        schemas::depth_codec::encode(&self.render_depth(0.001), self.width, self.height, encoding, &mut data)?;
        let [a, b, c, _] = self.floor_plane_camera();
        Ok(DepthFrame {
            width: self.width,
            height: self.height,
            depth_scale_m: 0.001,
            intrinsics: self.intrinsics,
            gravity_camera: Some([-a, -b, -c]),
            mount: None,
            encoding,
            data,
        })
    }

    /// Renders the scene as organized xyz, camera frame, NaN where nothing is hit.
    pub fn render_xyz(&self) -> Vec<[f32; 3]> {
        let k = self.intrinsics;
        let mut out = Vec::with_capacity((self.width * self.height) as usize);
        for v in 0..self.height {
            for u in 0..self.width {
                out.push(match self.depth_at(u as f32, v as f32) {
                    Some(z) => [(u as f32 - k.cx) / k.fx * z, (v as f32 - k.cy) / k.fy * z, z],
                    None => [f32::NAN; 3],
                });
            }
        }
        out
    }
}

fn slab(o: &[f32; 3], d: &[f32; 3], b: &Block) -> Option<f32> {
    let mut t0 = f32::NEG_INFINITY;
    let mut t1 = f32::INFINITY;
    for i in 0..3 {
        if d[i].abs() < 1e-9 {
            if o[i] < b.min[i] || o[i] > b.max[i] {
                return None;
            }
        } else {
            let (a, c) = ((b.min[i] - o[i]) / d[i], (b.max[i] - o[i]) / d[i]);
            t0 = t0.max(a.min(c));
            t1 = t1.min(a.max(c));
        }
    }
    (t1 >= t0 && t0 > 0.0).then_some(t0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_pixel_of_level_camera_facing_a_wall_reads_the_wall_distance() {
        let mut s = Scene::kinect(1.0, 0.0);
        s.walls_x_m.push(2.5);
        assert!((s.depth_at(319.5, 239.5).unwrap() - 2.5).abs() < 1e-5);
    }

    #[test]
    fn pitched_camera_sees_the_floor_on_its_axis_at_height_over_sine() {
        let s = Scene::kinect(1.0, 30.0);
        // optical axis hits the floor at slant 2.0 m = depth 2.0
        assert!((s.depth_at(319.5, 239.5).unwrap() - 2.0).abs() < 1e-4);
        let [a, b, c, d] = s.floor_plane_camera();
        let p = [0.0, 0.0, 2.0];
        assert!((a * p[0] + b * p[1] + c * p[2] + d).abs() < 1e-5);
    }
}

//! The three solid shapes every scene item is built from, in the map frame of one floor
//! (x, y horizontal, z up, z = 0 on that floor), with the exact distance queries the
//! contact counter of the virtual user study needs.
//!
//! Walls, boxes, table tops, chairs, steps and hanging obstacles are boxes turned about
//! the vertical axis; cylinders, poles, table legs and people are vertical cylinders;
//! drop-offs are holes cut into the floor.

/// A box with vertical sides, turned by `yaw_rad` about the vertical axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OrientedBox {
    /// Centre of the footprint, map metres.
    pub center_m: [f64; 2],
    /// Half the footprint size along the box's own x and y axes, metres.
    pub half_size_m: [f64; 2],
    /// Turn of the box's x axis from the map x axis, radians, counter-clockwise.
    pub yaw_rad: f64,
    /// Height of the underside above the floor, metres.
    pub bottom_m: f64,
    /// Height of the top above the floor, metres.
    pub top_m: f64,
}

/// A cylinder with a vertical axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VerticalCylinder {
    /// Axis position, map metres.
    pub center_m: [f64; 2],
    /// Radius, metres.
    pub radius_m: f64,
    /// Height of the underside above the floor, metres.
    pub bottom_m: f64,
    /// Height of the top above the floor, metres.
    pub top_m: f64,
}

/// A rectangular hole in the floor (a drop-off, a step down, a stair opening).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DropOff {
    /// Centre of the opening, map metres.
    pub center_m: [f64; 2],
    /// Half the opening size along its own axes, metres.
    pub half_size_m: [f64; 2],
    /// Turn of the opening's x axis from the map x axis, radians.
    pub yaw_rad: f64,
    /// How far the floor drops, metres (positive).
    pub depth_m: f64,
}

/// One shape of an obstacle at a moment in time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Shape {
    /// A turned box.
    Box(OrientedBox),
    /// A vertical cylinder.
    Cylinder(VerticalCylinder),
    /// A hole in the floor.
    DropOff(DropOff),
}

/// Coordinates of a map point in a footprint's own frame (centre, turned by yaw).
fn to_local(center_m: [f64; 2], yaw_rad: f64, x_m: f64, y_m: f64) -> [f64; 2] {
    let (s, c) = yaw_rad.sin_cos();
    let dx = x_m - center_m[0];
    let dy = y_m - center_m[1];
    [c * dx + s * dy, -s * dx + c * dy]
}

/// Horizontal distance from a point to a turned rectangle (0 inside).
fn rect_distance_m(center_m: [f64; 2], half_m: [f64; 2], yaw_rad: f64, x_m: f64, y_m: f64) -> f64 {
    let p = to_local(center_m, yaw_rad, x_m, y_m);
    let ex = (p[0].abs() - half_m[0]).max(0.0);
    let ey = (p[1].abs() - half_m[1]).max(0.0);
    ex.hypot(ey)
}

/// Gap between the intervals [a0, a1] and [b0, b1] (0 when they overlap).
fn interval_gap(a0: f64, a1: f64, b0: f64, b1: f64) -> f64 {
    (b0 - a1).max(a0 - b1).max(0.0)
}

impl Shape {
    /// Distance from a point (map x, y, height z above the floor) to the shape's
    /// surface, 0 inside. A drop-off counts as the volume of its hole: a point over
    /// the opening at floor level or below is in it.
    pub fn point_distance_m(&self, p: [f64; 3]) -> f64 {
        let (center, yaw) = self.footprint_frame();
        let [x, y] = to_local(center, yaw, p[0], p[1]);
        self.local_point_distance_m([x, y, p[2]])
    }

    /// Centre and turn of the shape's own horizontal frame.
    fn footprint_frame(&self) -> ([f64; 2], f64) {
        match self {
            Shape::Box(b) => (b.center_m, b.yaw_rad),
            Shape::Cylinder(c) => (c.center_m, 0.0),
            Shape::DropOff(d) => (d.center_m, d.yaw_rad),
        }
    }

    /// [`Shape::point_distance_m`] of a point already in the shape's own frame (see
    /// [`Shape::footprint_frame`]): the hot loop of the cane's distance, so no turn and
    /// no `hypot` (libm's is overflow-safe and slow; these are metres).
    fn local_point_distance_m(&self, p: [f64; 3]) -> f64 {
        // how far outside a centred rectangle of half sizes `half`, along x and along y
        let outside = |half: [f64; 2]| ((p[0].abs() - half[0]).max(0.0), (p[1].abs() - half[1]).max(0.0));
        let ((ex, ey), ez) = match self {
            Shape::Box(b) => (outside(b.half_size_m), interval_gap(p[2], p[2], b.bottom_m, b.top_m)),
            Shape::Cylinder(c) => (
                (((p[0] * p[0] + p[1] * p[1]).sqrt() - c.radius_m).max(0.0), 0.0),
                interval_gap(p[2], p[2], c.bottom_m, c.top_m),
            ),
            Shape::DropOff(d) => (outside(d.half_size_m), interval_gap(p[2], p[2], -d.depth_m, 0.0)),
        };
        (ex * ex + ey * ey + ez * ez).sqrt()
    }

    /// Exact distance from a standing body — a vertical cylinder of `radius_m` from the
    /// floor to `height_m` at (x, y) — to this shape, 0 on contact. For a drop-off the
    /// body's axis (where the feet are) must be over the opening to touch it: walking
    /// past an edge with a shoulder over it is not a fall.
    pub fn body_distance_m(&self, x_m: f64, y_m: f64, radius_m: f64, height_m: f64) -> f64 {
        match self {
            Shape::Box(b) => {
                let h = rect_distance_m(b.center_m, b.half_size_m, b.yaw_rad, x_m, y_m) - radius_m;
                h.max(0.0).hypot(interval_gap(0.0, height_m, b.bottom_m, b.top_m))
            }
            Shape::Cylinder(c) => {
                let h = (x_m - c.center_m[0]).hypot(y_m - c.center_m[1]) - c.radius_m - radius_m;
                h.max(0.0).hypot(interval_gap(0.0, height_m, c.bottom_m, c.top_m))
            }
            Shape::DropOff(d) => rect_distance_m(d.center_m, d.half_size_m, d.yaw_rad, x_m, y_m),
        }
    }

    /// Distance from the segment `a`–`b` (e.g. a cane from hand to tip) to the shape,
    /// sampled every `SEGMENT_STEP_M` along the segment, so it is exact to within half
    /// that step (5 mm).
    pub fn segment_distance_m(&self, a: [f64; 3], b: [f64; 3]) -> f64 {
        let length_m = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2) + (b[2] - a[2]).powi(2)).sqrt();
        let steps = (length_m / SEGMENT_STEP_M).ceil().max(1.0) as usize;
        // the segment in the shape's own frame once, then every sample is a lerp
        let (center, yaw) = self.footprint_frame();
        let la = to_local(center, yaw, a[0], a[1]);
        let lb = to_local(center, yaw, b[0], b[1]);
        let mut best = f64::INFINITY;
        for i in 0..=steps {
            let f = i as f64 / steps as f64;
            let p = [la[0] + f * (lb[0] - la[0]), la[1] + f * (lb[1] - la[1]), a[2] + f * (b[2] - a[2])];
            best = best.min(self.local_point_distance_m(p));
        }
        best
    }

    /// A lower bound of [`Self::segment_distance_m`], from the axis-aligned bounds of
    /// the shape and of the segment: cheap enough to skip shapes that are far away.
    pub fn segment_distance_lower_bound_m(&self, a: [f64; 3], b: [f64; 3]) -> f64 {
        let (lo, hi) = self.bounds_m();
        let gap = |k: usize| interval_gap(a[k].min(b[k]), a[k].max(b[k]), lo[k], hi[k]);
        (gap(0).powi(2) + gap(1).powi(2) + gap(2).powi(2)).sqrt()
    }

    /// Axis-aligned bounds `[min, max]` of the shape in map coordinates (x, y, z).
    pub fn bounds_m(&self) -> ([f64; 3], [f64; 3]) {
        let footprint = |center: [f64; 2], half: [f64; 2], yaw: f64| {
            let (s, c) = yaw.sin_cos();
            let ex = (c * half[0]).abs() + (s * half[1]).abs();
            let ey = (s * half[0]).abs() + (c * half[1]).abs();
            ([center[0] - ex, center[1] - ey], [center[0] + ex, center[1] + ey])
        };
        match self {
            Shape::Box(b) => {
                let (lo, hi) = footprint(b.center_m, b.half_size_m, b.yaw_rad);
                ([lo[0], lo[1], b.bottom_m], [hi[0], hi[1], b.top_m])
            }
            Shape::Cylinder(c) => {
                let r = c.radius_m;
                ([c.center_m[0] - r, c.center_m[1] - r, c.bottom_m], [c.center_m[0] + r, c.center_m[1] + r, c.top_m])
            }
            Shape::DropOff(d) => {
                let (lo, hi) = footprint(d.center_m, d.half_size_m, d.yaw_rad);
                ([lo[0], lo[1], -d.depth_m], [hi[0], hi[1], 0.0])
            }
        }
    }
}

/// Sampling step of [`Shape::segment_distance_m`], metres.
pub const SEGMENT_STEP_M: f64 = 0.01;

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_box_turned_45() -> Shape {
        Shape::Box(OrientedBox {
            center_m: [0.0, 0.0],
            half_size_m: [0.5, 0.5],
            yaw_rad: std::f64::consts::FRAC_PI_4,
            bottom_m: 0.0,
            top_m: 1.0,
        })
    }

    #[test]
    fn body_beside_turned_box_measures_to_its_corner() {
        // The 45-degree box's corner points along +x at 0.5 * sqrt(2).
        let d = unit_box_turned_45().body_distance_m(2.0, 0.0, 0.25, 1.8);
        assert!((d - (2.0 - 0.5 * 2f64.sqrt() - 0.25)).abs() < 1e-9, "{d}");
    }

    #[test]
    fn body_under_head_high_sign_touches_only_when_tall_enough() {
        let sign = Shape::Box(OrientedBox {
            center_m: [0.0, 0.0],
            half_size_m: [0.3, 0.1],
            yaw_rad: 0.0,
            bottom_m: 1.6,
            top_m: 1.9,
        });
        assert_eq!(sign.body_distance_m(0.0, 0.0, 0.25, 1.8), 0.0);
        assert!((sign.body_distance_m(0.0, 0.0, 0.25, 1.5) - 0.1).abs() < 1e-9);
    }

    #[test]
    fn cane_segment_distance_to_turned_box_and_hanging_sign_is_exact() {
        // a wall turned 30 degrees, its near face 0.4 m from the cane's tip: the tip
        // (on the floor, 1.1 m ahead of a hand at 1 m) is the nearest point
        let yaw = 30f64.to_radians();
        let (s, c) = yaw.sin_cos();
        let face = [1.1 + 0.4 * c, 0.4 * s];
        let wall = Shape::Box(OrientedBox {
            center_m: [face[0] + 0.05 * c, face[1] + 0.05 * s],
            half_size_m: [0.05, 3.0],
            yaw_rad: yaw,
            bottom_m: 0.0,
            top_m: 1.8,
        });
        let d = wall.segment_distance_m([0.0, 0.0, 1.0], [1.1, 0.0, 0.0]);
        assert!((d - 0.4 * c * c - 0.4 * s * s).abs() < 1e-9, "{d}");
        assert!((wall.point_distance_m([1.1, 0.0, 0.0]) - 0.4).abs() < 1e-9);
        // a sign hanging from 1.55 m over the cane: the hand, 0.35 m short of its near
        // edge and 0.55 m below it, is nearer than the cane under it (0.87 m below)
        let sign = Shape::Box(OrientedBox {
            center_m: [0.5, 0.0],
            half_size_m: [0.15, 0.6],
            yaw_rad: 0.0,
            bottom_m: 1.55,
            top_m: 1.85,
        });
        let d = sign.segment_distance_m([0.0, 0.0, 1.0], [1.1, 0.0, 0.0]);
        let hand_gap = (0.35f64.powi(2) + 0.55f64.powi(2)).sqrt();
        assert!((d - hand_gap).abs() < 1e-9, "{d} vs {hand_gap}");
        assert!(1.55 - (1.0 - 0.35 / 1.1) > hand_gap);
    }

    #[test]
    fn cane_segment_distance_to_pole_is_within_sampling_step() {
        let pole =
            Shape::Cylinder(VerticalCylinder { center_m: [1.0, 0.3], radius_m: 0.02, bottom_m: 0.0, top_m: 2.0 });
        let d = pole.segment_distance_m([0.0, 0.0, 1.0], [2.0, 0.0, 0.0]);
        assert!((d - 0.28).abs() <= SEGMENT_STEP_M / 2.0 + 1e-9, "{d}");
    }

    #[test]
    fn drop_off_catches_the_feet_not_the_shoulder() {
        let hole =
            Shape::DropOff(DropOff { center_m: [0.0, 0.0], half_size_m: [1.0, 1.0], yaw_rad: 0.0, depth_m: 0.2 });
        assert!((hole.body_distance_m(1.2, 0.0, 0.25, 1.8) - 0.2).abs() < 1e-9);
        assert_eq!(hole.body_distance_m(0.9, 0.0, 0.25, 1.8), 0.0);
    }
}

//! A generated world before it is written: walls, the obstacles that may be left out,
//! landmarks, people and routes, in typed form; written out as scene TOML so a
//! generated world goes through the same parser and checks as a hand-written one.

use std::fmt::Write;

use crate::shape::{DropOff, OrientedBox, Shape, VerticalCylinder};

/// Walls of generated worlds, as the scene format's defaults.
pub(super) const WALL_THICKNESS_M: f64 = 0.1;
const WALL_HEIGHT_M: f64 = 2.5;
/// Seat side of a generated chair (the format's default) and its back's height.
const CHAIR_SIZE_M: f64 = 0.45;
const CHAIR_BACK_M: f64 = 0.9;

/// A wall segment, centred on its line.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Wall {
    pub from: [f64; 2],
    pub to: [f64; 2],
    pub label: String,
}

/// An obstacle's shape and place, in the scene format's terms.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Piece {
    /// `[[boxes]]`: furniture on the floor, or fixed to a wall above it.
    Box { center: [f64; 2], size: [f64; 2], yaw_deg: f64, bottom: f64, top: f64 },
    /// `[[cylinders]]`.
    Cylinder { center: [f64; 2], radius: f64, top: f64 },
    /// `[[poles]]`.
    Pole { center: [f64; 2], radius: f64, height: f64 },
    /// `[[tables]]` (top on four legs).
    Table { center: [f64; 2], size: [f64; 2], yaw_deg: f64, height: f64 },
    /// `[[chairs]]`, facing `yaw_deg`.
    Chair { center: [f64; 2], yaw_deg: f64 },
    /// `[[hanging]]`.
    Hanging { center: [f64; 2], size: [f64; 2], yaw_deg: f64, bottom: f64, top: f64 },
    /// `[[floor_regions]]` below the floor (`depth` > 0).
    DropOff { center: [f64; 2], size: [f64; 2], depth: f64 },
}

/// One obstacle of a generated world.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Item {
    pub label: String,
    pub piece: Piece,
}

/// A numbered door (landmark only).
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Door {
    pub at: [f64; 2],
    pub number: u32,
    pub facing_deg: f64,
}

/// A person walking out and back along a straight path.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Walker {
    pub from: [f64; 2],
    pub to: [f64; 2],
    pub speed_m_s: f64,
    pub phase_s: f64,
}

/// Everything a generated world holds.
#[derive(Debug, Clone, Default)]
pub(super) struct Layout {
    pub name: String,
    pub description: String,
    pub start: [f64; 2],
    pub start_yaw_deg: f64,
    pub goal: [f64; 2],
    pub goal_label: String,
    pub walls: Vec<Wall>,
    pub items: Vec<Item>,
    pub doors: Vec<Door>,
    pub corners: Vec<[f64; 2]>,
    pub people: Vec<Walker>,
    /// Floor-plan route: the points between the start and the goal.
    pub route: Vec<[f64; 2]>,
    /// The way round every obstacle, start left out, goal last (`[walker]`).
    pub way: Vec<[f64; 2]>,
    /// Where the way through is searched (min, max corners), when not round the walls;
    /// also what the floor plan covers (`[plan_extent]`): a pavement's plan ends at its
    /// ends and past the kerb.
    pub bounds: Option<([f64; 2], [f64; 2])>,
}

impl Layout {
    /// The floor-plan route from the start to the goal, both included.
    pub fn route_with_ends(&self) -> Vec<[f64; 2]> {
        let mut points = vec![self.start];
        points.extend_from_slice(&self.route);
        points.push(self.goal);
        points
    }

    /// The scene file of this layout.
    pub fn to_toml(&self) -> String {
        let mut s = String::new();
        let _ = writeln!(s, "name = {}", quoted(&self.name));
        let _ = writeln!(s, "description = {}", quoted(&self.description));
        let _ = writeln!(
            s,
            "start = {{ x_m = {}, y_m = {}, yaw_deg = {} }}",
            num(self.start[0]),
            num(self.start[1]),
            num(self.start_yaw_deg)
        );
        let _ = writeln!(
            s,
            "goal = {{ x_m = {}, y_m = {}, label = {} }}",
            num(self.goal[0]),
            num(self.goal[1]),
            quoted(&self.goal_label)
        );
        for w in &self.walls {
            let _ = write!(
                s,
                "\n[[walls]]\nlabel = {}\nfrom = {}\nto = {}\n",
                quoted(&w.label),
                point(w.from),
                point(w.to)
            );
        }
        for item in &self.items {
            let label = quoted(&item.label);
            let _ = match item.piece {
                Piece::Box { center, size, yaw_deg, bottom, top } => write!(
                    s,
                    "\n[[boxes]]\nlabel = {label}\ncenter = {}\nsize_m = {}\nyaw_deg = {}\nbottom_m = {}\ntop_m = {}\n",
                    point(center),
                    point(size),
                    num(yaw_deg),
                    num(bottom),
                    num(top)
                ),
                Piece::Cylinder { center, radius, top } => write!(
                    s,
                    "\n[[cylinders]]\nlabel = {label}\ncenter = {}\nradius_m = {}\ntop_m = {}\n",
                    point(center),
                    num(radius),
                    num(top)
                ),
                Piece::Pole { center, radius, height } => write!(
                    s,
                    "\n[[poles]]\nlabel = {label}\ncenter = {}\nradius_m = {}\nheight_m = {}\n",
                    point(center),
                    num(radius),
                    num(height)
                ),
                Piece::Table { center, size, yaw_deg, height } => write!(
                    s,
                    "\n[[tables]]\nlabel = {label}\ncenter = {}\nsize_m = {}\nyaw_deg = {}\nheight_m = {}\n",
                    point(center),
                    point(size),
                    num(yaw_deg),
                    num(height)
                ),
                Piece::Chair { center, yaw_deg } => write!(
                    s,
                    "\n[[chairs]]\nlabel = {label}\ncenter = {}\nyaw_deg = {}\n",
                    point(center),
                    num(yaw_deg)
                ),
                Piece::Hanging { center, size, yaw_deg, bottom, top } => write!(
                    s,
                    "\n[[hanging]]\nlabel = {label}\ncenter = {}\nsize_m = {}\nyaw_deg = {}\nbottom_m = {}\ntop_m = {}\n",
                    point(center),
                    point(size),
                    num(yaw_deg),
                    num(bottom),
                    num(top)
                ),
                Piece::DropOff { center, size, depth } => write!(
                    s,
                    "\n[[floor_regions]]\nlabel = {label}\ncenter = {}\nsize_m = {}\nheight_m = {}\n",
                    point(center),
                    point(size),
                    num(-depth)
                ),
            };
        }
        for d in &self.doors {
            let _ = write!(
                s,
                "\n[[doors]]\nat = {}\nnumber = \"{}\"\nfacing_deg = {}\n",
                point(d.at),
                d.number,
                num(d.facing_deg)
            );
        }
        for (i, c) in self.corners.iter().enumerate() {
            let _ = write!(s, "\n[[corners]]\nat = {}\nlabel = \"corner {}\"\n", point(*c), i + 1);
        }
        for (i, p) in self.people.iter().enumerate() {
            let _ = write!(
                s,
                "\n[[people]]\nlabel = \"person {}\"\nwaypoints = [{}, {}]\nspeed_m_s = {}\nphase_s = {}\n",
                i + 1,
                point(p.from),
                point(p.to),
                num(p.speed_m_s),
                num(p.phase_s)
            );
        }
        let _ = write!(s, "\n[floor_plan_route]\nwaypoints = {}\n", points(&self.route));
        if let Some((min, max)) = self.bounds {
            let _ = write!(s, "\n[plan_extent]\nmin = {}\nmax = {}\n", point(min), point(max));
        }
        if !self.way.is_empty() {
            let _ = write!(s, "\n[walker]\nwaypoints = {}\nat_end = \"stop\"\n", points(&self.way));
        }
        s
    }
}

impl Wall {
    /// The wall's solid slab.
    pub fn shape(&self) -> Shape {
        let (dx, dy) = (self.to[0] - self.from[0], self.to[1] - self.from[1]);
        Shape::Box(OrientedBox {
            center_m: [(self.from[0] + self.to[0]) / 2.0, (self.from[1] + self.to[1]) / 2.0],
            half_size_m: [dx.hypot(dy) / 2.0, WALL_THICKNESS_M / 2.0],
            yaw_rad: dy.atan2(dx),
            bottom_m: 0.0,
            top_m: WALL_HEIGHT_M,
        })
    }
}

impl Piece {
    /// The shape that stands in the way of a walking body: the whole footprint of a
    /// table or chair from the floor up (legs and seat alike are in the way), the exact
    /// shape of everything else.
    pub fn shape(&self) -> Shape {
        let boxed = |center: [f64; 2], size: [f64; 2], yaw_deg: f64, bottom_m: f64, top_m: f64| {
            Shape::Box(OrientedBox {
                center_m: center,
                half_size_m: [size[0] / 2.0, size[1] / 2.0],
                yaw_rad: f64::to_radians(yaw_deg),
                bottom_m,
                top_m,
            })
        };
        let cylinder = |center_m: [f64; 2], radius_m: f64, top_m: f64| {
            Shape::Cylinder(VerticalCylinder { center_m, radius_m, bottom_m: 0.0, top_m })
        };
        match *self {
            Piece::Box { center, size, yaw_deg, bottom, top } => boxed(center, size, yaw_deg, bottom, top),
            Piece::Hanging { center, size, yaw_deg, bottom, top } => boxed(center, size, yaw_deg, bottom, top),
            Piece::Table { center, size, yaw_deg, height } => boxed(center, size, yaw_deg, 0.0, height),
            Piece::Chair { center, yaw_deg } => boxed(center, [CHAIR_SIZE_M; 2], yaw_deg, 0.0, CHAIR_BACK_M),
            Piece::Cylinder { center, radius, top } => cylinder(center, radius, top),
            Piece::Pole { center, radius, height } => cylinder(center, radius, height),
            Piece::DropOff { center, size, depth } => Shape::DropOff(DropOff {
                center_m: center,
                half_size_m: [size[0] / 2.0, size[1] / 2.0],
                yaw_rad: 0.0,
                depth_m: depth,
            }),
        }
    }
}

/// Millimetres are plenty for a scene, and fixed decimals keep the text the same on
/// every platform.
fn num(x: f64) -> String {
    let s = format!("{x:.3}");
    if s == "-0.000" {
        "0.000".into()
    } else {
        s
    }
}

fn point(p: [f64; 2]) -> String {
    format!("[{}, {}]", num(p[0]), num(p[1]))
}

fn points(ps: &[[f64; 2]]) -> String {
    format!("[{}]", ps.iter().map(|p| point(*p)).collect::<Vec<_>>().join(", "))
}

fn quoted(text: &str) -> String {
    format!("\"{}\"", text.replace('\\', "\\\\").replace('"', "\\\""))
}

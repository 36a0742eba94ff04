//! A loaded simulated world: the scene's items turned into solid shapes per floor,
//! moving people, labelled landmarks, start and goal, and the geometry queries the
//! virtual user needs (how close is the cane or the body to the nearest obstacle).

use std::path::Path;

use super::generate;
use super::scene::{
    self, floor_indexes, parse_scene, path_length_m, CornerSpec, DoorSpec, ElevatorSpec, PlanExtentSpec, RoomSpec,
    SceneError, SceneFile, StairsSpec, WalkerSpec, LEG_INSET_M,
};
use super::shape::{DropOff, OrientedBox, Shape, VerticalCylinder};

/// The built-in worlds, by name, embedded in the binary.
pub const BUILTIN_WORLDS: [(&str, &str); 10] = [
    ("taylor-course", include_str!("../../worlds/taylor-course.toml")),
    ("open-course", include_str!("../../worlds/open-course.toml")),
    ("corridor", include_str!("../../worlds/corridor.toml")),
    ("building", include_str!("../../worlds/building.toml")),
    ("approach", include_str!("../../worlds/approach.toml")),
    ("step-down", include_str!("../../worlds/step-down.toml")),
    ("sign-ahead", include_str!("../../worlds/sign-ahead.toml")),
    // written from a description, after the cues were tuned (issue 29)
    ("corridor-narrow", include_str!("../../worlds/corridor-narrow.toml")),
    ("lobby-bench", include_str!("../../worlds/lobby-bench.toml")),
    ("hanging-lamp", include_str!("../../worlds/hanging-lamp.toml")),
];

/// What an obstacle is, for contact reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ObstacleKind {
    /// A wall segment.
    Wall,
    /// A box on the floor.
    Box,
    /// A vertical cylinder.
    Cylinder,
    /// A thin pole.
    Pole,
    /// A table (top and legs).
    Table,
    /// A chair (seat, back and legs).
    Chair,
    /// An obstacle hanging free of the floor.
    Hanging,
    /// A raised floor region (step up).
    Step,
    /// A hole in the floor (drop-off, step down, stair opening).
    DropOff,
    /// A flight of stairs seen from below.
    Stairs,
    /// A walking person.
    Person,
}

/// Index of an obstacle in [`World::obstacles`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ObstacleId(pub u32);

/// One obstacle of the scene (several shapes may belong to it, e.g. a table).
#[derive(Debug, Clone, PartialEq)]
pub struct Obstacle {
    /// What it is.
    pub kind: ObstacleKind,
    /// Its label, or `<table>[<index>]` when the scene gave none.
    pub label: String,
    /// Floor index.
    pub floor: i32,
}

/// The user's pose on the map.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UserPose {
    /// Map x, metres.
    pub x_m: f64,
    /// Map y, metres.
    pub y_m: f64,
    /// Heading, radians, counter-clockwise from +x.
    pub yaw_rad: f64,
    /// Floor index.
    pub floor: i32,
}

/// Where a walk should end.
#[derive(Debug, Clone, PartialEq)]
pub struct Goal {
    /// Map x, metres.
    pub x_m: f64,
    /// Map y, metres.
    pub y_m: f64,
    /// Floor index.
    pub floor: i32,
    /// Name.
    pub label: String,
}

/// One floor's static solid geometry, each shape tagged with its obstacle.
#[derive(Debug, Clone, Default)]
pub struct FloorGeometry {
    /// Floor index.
    pub index: i32,
    /// Floor name.
    pub name: String,
    /// Height above the building's zero, metres.
    pub elevation_m: f64,
    /// Boxes (walls, boxes, table tops, chair parts, hanging obstacles, steps, stairs).
    pub boxes: Vec<(OrientedBox, ObstacleId)>,
    /// Vertical cylinders (cylinders, poles, legs).
    pub cylinders: Vec<(VerticalCylinder, ObstacleId)>,
    /// Holes in the floor.
    pub drop_offs: Vec<(DropOff, ObstacleId)>,
}

/// A person walking back and forth along a path.
#[derive(Debug, Clone, PartialEq)]
pub struct Person {
    /// Obstacle id.
    pub id: ObstacleId,
    /// Floor index.
    pub floor: i32,
    waypoints: Vec<[f64; 2]>,
    length_m: f64,
    speed_m_s: f64,
    phase_s: f64,
    /// Body radius, metres.
    pub radius_m: f64,
    /// Height, metres.
    pub height_m: f64,
}

impl Person {
    /// Position on the map at time `t_s`: out along the path, then back, forever.
    pub fn position_at(&self, t_s: f64) -> [f64; 2] {
        let travelled = (t_s + self.phase_s) * self.speed_m_s;
        let lap = travelled.rem_euclid(2.0 * self.length_m);
        let mut along = if lap <= self.length_m { lap } else { 2.0 * self.length_m - lap };
        for w in self.waypoints.windows(2) {
            let seg = (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]);
            if along <= seg && seg > 0.0 {
                let f = along / seg;
                return [w[0][0] + f * (w[1][0] - w[0][0]), w[0][1] + f * (w[1][1] - w[0][1])];
            }
            along -= seg;
        }
        self.waypoints[self.waypoints.len() - 1]
    }

    /// The person's cylinder at time `t_s`.
    pub fn shape_at(&self, t_s: f64) -> VerticalCylinder {
        VerticalCylinder {
            center_m: self.position_at(t_s),
            radius_m: self.radius_m,
            bottom_m: 0.0,
            top_m: self.height_m,
        }
    }
}

/// The nearest obstacle to something, as found by a contact query.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Nearest {
    /// Distance to the obstacle's surface, metres (0 = touching or inside).
    pub distance_m: f64,
    /// Which obstacle.
    pub id: ObstacleId,
    /// What kind it is.
    pub kind: ObstacleKind,
}

/// A loaded world. Cheap to query; build it once per run.
#[derive(Debug, Clone)]
pub struct World {
    name: String,
    description: String,
    start: UserPose,
    goal: Goal,
    floors: Vec<FloorGeometry>,
    obstacles: Vec<Obstacle>,
    people: Vec<Person>,
    doors: Vec<DoorSpec>,
    corners: Vec<CornerSpec>,
    rooms: Vec<RoomSpec>,
    elevators: Vec<ElevatorSpec>,
    stairs: Vec<StairsSpec>,
    walker: Option<WalkerSpec>,
    floor_plan_route: Option<Vec<[f64; 2]>>,
    plan_extent: Option<PlanExtentSpec>,
    /// [`World::way_through`], worked out the first time it is asked
    way_through: std::sync::OnceLock<Option<bool>>,
}

static NO_GEOMETRY: FloorGeometry = FloorGeometry {
    index: i32::MIN,
    name: String::new(),
    elevation_m: 0.0,
    boxes: Vec::new(),
    cylinders: Vec::new(),
    drop_offs: Vec::new(),
};

impl World {
    /// A built-in world by name, a generated one (`gen:<kind>:<seed>`, see
    /// [`generate`]), or else a scene file at that path.
    pub fn load(name_or_path: &str) -> Result<World, SceneError> {
        if let Some(world) = Self::builtin(name_or_path) {
            return world;
        }
        if let Some(generated) = generate::parse_name(name_or_path) {
            let (kind, seed) = generated?;
            return Self::from_toml(&generate::scene_text(kind, seed)?, name_or_path);
        }
        let path = Path::new(name_or_path);
        if path.exists() {
            return Self::from_file(path);
        }
        Err(SceneError::UnknownWorld {
            name: name_or_path.to_string(),
            known: BUILTIN_WORLDS.iter().map(|(n, _)| *n).collect::<Vec<_>>().join(", "),
        })
    }

    /// A built-in world, `None` when no world has that name.
    pub fn builtin(name: &str) -> Option<Result<World, SceneError>> {
        BUILTIN_WORLDS.iter().find(|(n, _)| *n == name).map(|(n, text)| Self::from_toml(text, &format!("builtin:{n}")))
    }

    /// A world from a scene file.
    pub fn from_file(path: &Path) -> Result<World, SceneError> {
        let text = std::fs::read_to_string(path)
            .map_err(|source| SceneError::Io { path: path.display().to_string(), source })?;
        Self::from_toml(&text, &path.display().to_string())
    }

    /// A world from scene text; `origin` names it in errors.
    pub fn from_toml(text: &str, origin: &str) -> Result<World, SceneError> {
        Ok(Self::from_scene(&parse_scene(text, origin)?))
    }

    /// Builds the shapes of a checked scene.
    fn from_scene(scene: &SceneFile) -> World {
        let mut floors: Vec<FloorGeometry> = floor_indexes(scene)
            .into_iter()
            .map(|index| FloorGeometry {
                index,
                name: scene
                    .floors
                    .iter()
                    .find(|f| f.get_ref().index == index)
                    .map(|f| f.get_ref().name.clone())
                    .unwrap_or_default(),
                elevation_m: scene::elevation_of(scene, index),
                ..FloorGeometry::default()
            })
            .collect();
        floors.sort_by_key(|f| f.index);
        let mut build = Builder { floors, obstacles: Vec::new() };

        for (i, w) in scene.walls.iter().map(|w| w.get_ref()).enumerate() {
            let id = build.obstacle(ObstacleKind::Wall, &w.label, "walls", i, w.floor);
            let (dx, dy) = (w.to[0] - w.from[0], w.to[1] - w.from[1]);
            build.add_box(
                w.floor,
                id,
                OrientedBox {
                    center_m: [(w.from[0] + w.to[0]) / 2.0, (w.from[1] + w.to[1]) / 2.0],
                    half_size_m: [dx.hypot(dy) / 2.0, w.thickness_m / 2.0],
                    yaw_rad: dy.atan2(dx),
                    bottom_m: 0.0,
                    top_m: w.height_m,
                },
            );
        }
        for (i, b) in scene.boxes.iter().map(|b| b.get_ref()).enumerate() {
            let id = build.obstacle(ObstacleKind::Box, &b.label, "boxes", i, b.floor);
            build.add_box(b.floor, id, footprint_box(b.center, b.size_m, b.yaw_deg, b.bottom_m, b.top_m));
        }
        for (i, c) in scene.cylinders.iter().map(|c| c.get_ref()).enumerate() {
            let id = build.obstacle(ObstacleKind::Cylinder, &c.label, "cylinders", i, c.floor);
            build.add_cylinder(
                c.floor,
                id,
                VerticalCylinder { center_m: c.center, radius_m: c.radius_m, bottom_m: c.bottom_m, top_m: c.top_m },
            );
        }
        for (i, p) in scene.poles.iter().map(|p| p.get_ref()).enumerate() {
            let id = build.obstacle(ObstacleKind::Pole, &p.label, "poles", i, p.floor);
            build.add_cylinder(
                p.floor,
                id,
                VerticalCylinder { center_m: p.center, radius_m: p.radius_m, bottom_m: 0.0, top_m: p.height_m },
            );
        }
        for (i, t) in scene.tables.iter().map(|t| t.get_ref()).enumerate() {
            let id = build.obstacle(ObstacleKind::Table, &t.label, "tables", i, t.floor);
            build.add_box(
                t.floor,
                id,
                footprint_box(t.center, t.size_m, t.yaw_deg, t.height_m - t.top_thickness_m, t.height_m),
            );
            let inset = LEG_INSET_M + t.leg_radius_m;
            for corner in corners_of(t.center, [t.size_m[0] / 2.0 - inset, t.size_m[1] / 2.0 - inset], t.yaw_deg) {
                build.add_cylinder(
                    t.floor,
                    id,
                    VerticalCylinder {
                        center_m: corner,
                        radius_m: t.leg_radius_m,
                        bottom_m: 0.0,
                        top_m: t.height_m - t.top_thickness_m,
                    },
                );
            }
        }
        for (i, c) in scene.chairs.iter().map(|c| c.get_ref()).enumerate() {
            let id = build.obstacle(ObstacleKind::Chair, &c.label, "chairs", i, c.floor);
            let half = c.seat_size_m / 2.0;
            let seat_bottom = c.seat_height_m - CHAIR_SEAT_THICKNESS_M;
            build.add_box(
                c.floor,
                id,
                footprint_box(c.center, [c.seat_size_m; 2], c.yaw_deg, seat_bottom, c.seat_height_m),
            );
            let (s, co) = c.yaw_deg.to_radians().sin_cos();
            let back_center = [c.center[0] - co * (half - 0.01), c.center[1] - s * (half - 0.01)];
            build.add_box(
                c.floor,
                id,
                footprint_box(back_center, [0.02, c.seat_size_m], c.yaw_deg, c.seat_height_m, c.back_height_m),
            );
            for corner in corners_of(c.center, [half - 0.03, half - 0.03], c.yaw_deg) {
                build.add_cylinder(
                    c.floor,
                    id,
                    VerticalCylinder { center_m: corner, radius_m: 0.015, bottom_m: 0.0, top_m: seat_bottom },
                );
            }
        }
        for (i, h) in scene.hanging.iter().map(|h| h.get_ref()).enumerate() {
            let id = build.obstacle(ObstacleKind::Hanging, &h.label, "hanging", i, h.floor);
            build.add_box(h.floor, id, footprint_box(h.center, h.size_m, h.yaw_deg, h.bottom_m, h.top_m));
        }
        for (i, r) in scene.floor_regions.iter().map(|r| r.get_ref()).enumerate() {
            if r.height_m > 0.0 {
                let id = build.obstacle(ObstacleKind::Step, &r.label, "floor_regions", i, r.floor);
                build.add_box(r.floor, id, footprint_box(r.center, r.size_m, r.yaw_deg, 0.0, r.height_m));
            } else {
                let id = build.obstacle(ObstacleKind::DropOff, &r.label, "floor_regions", i, r.floor);
                build.add_drop_off(
                    r.floor,
                    id,
                    DropOff {
                        center_m: r.center,
                        half_size_m: [r.size_m[0] / 2.0, r.size_m[1] / 2.0],
                        yaw_rad: r.yaw_deg.to_radians(),
                        depth_m: -r.height_m,
                    },
                );
            }
        }
        for (i, s) in scene.stairs.iter().map(|s| s.get_ref()).enumerate() {
            let rise_m = scene::elevation_of(scene, s.to_floor) - scene::elevation_of(scene, s.from_floor);
            let step_rise = rise_m / s.steps as f64;
            let (sn, cs) = s.yaw_deg.to_radians().sin_cos();
            let run_m = s.steps as f64 * s.tread_m;
            let id = build.obstacle(ObstacleKind::Stairs, &s.label, "stairs", i, s.from_floor);
            for k in 0..s.steps {
                // Step k is solid from its front edge to the top of the flight.
                let from = k as f64 * s.tread_m;
                let mid = (from + run_m) / 2.0;
                build.add_box(
                    s.from_floor,
                    id,
                    OrientedBox {
                        center_m: [s.start[0] + cs * mid, s.start[1] + sn * mid],
                        half_size_m: [(run_m - from) / 2.0, s.width_m / 2.0],
                        yaw_rad: s.yaw_deg.to_radians(),
                        bottom_m: 0.0,
                        top_m: (k + 1) as f64 * step_rise,
                    },
                );
            }
            let id = build.obstacle(ObstacleKind::DropOff, &s.label, "stairs", i, s.to_floor);
            build.add_drop_off(
                s.to_floor,
                id,
                DropOff {
                    center_m: [s.start[0] + cs * run_m / 2.0, s.start[1] + sn * run_m / 2.0],
                    half_size_m: [run_m / 2.0, s.width_m / 2.0],
                    yaw_rad: s.yaw_deg.to_radians(),
                    depth_m: rise_m,
                },
            );
        }
        let mut people = Vec::new();
        for (i, p) in scene.people.iter().map(|p| p.get_ref()).enumerate() {
            let id = build.obstacle(ObstacleKind::Person, &p.label, "people", i, p.floor);
            people.push(Person {
                id,
                floor: p.floor,
                waypoints: p.waypoints.clone(),
                length_m: path_length_m(&p.waypoints),
                speed_m_s: p.speed_m_s,
                phase_s: p.phase_s,
                radius_m: p.radius_m,
                height_m: p.height_m,
            });
        }

        let start = scene.start.get_ref();
        let goal = scene.goal.get_ref();
        World {
            name: scene.name.clone(),
            description: scene.description.clone(),
            start: UserPose { x_m: start.x_m, y_m: start.y_m, yaw_rad: start.yaw_deg.to_radians(), floor: start.floor },
            goal: Goal { x_m: goal.x_m, y_m: goal.y_m, floor: goal.floor, label: goal.label.clone() },
            floors: build.floors,
            obstacles: build.obstacles,
            people,
            doors: scene.doors.iter().map(|d| d.get_ref().clone()).collect(),
            corners: scene.corners.iter().map(|d| d.get_ref().clone()).collect(),
            rooms: scene.rooms.iter().map(|d| d.get_ref().clone()).collect(),
            elevators: scene.elevators.iter().map(|d| d.get_ref().clone()).collect(),
            stairs: scene.stairs.iter().map(|d| d.get_ref().clone()).collect(),
            walker: scene.walker.as_ref().map(|w| w.get_ref().clone()),
            floor_plan_route: scene.floor_plan_route.as_ref().map(|r| r.get_ref().waypoints.clone()),
            plan_extent: scene.plan_extent.as_ref().map(|e| e.get_ref().clone()),
            way_through: std::sync::OnceLock::new(),
        }
    }

    /// Whether a body 0.5 m wide and 1.85 m tall can get from the start to the goal
    /// past every fixed obstacle (people move aside): the generator's own test
    /// ([`generate::way_through`]: a 5 cm grid, every
    /// obstacle grown by the body's half width and 5 cm, a search). `None` when the goal
    /// is on another floor (not searched). Worked out once per world (milliseconds).
    pub fn way_through(&self) -> Option<bool> {
        *self.way_through.get_or_init(|| {
            use super::generate::way_through::Grid;
            let (start, goal) = (self.start, &self.goal);
            if goal.floor != start.floor {
                return None;
            }
            let fixed: Vec<Shape> = self
                .obstacles_at(start.floor, 0.0)
                .filter(|(id, _)| self.obstacles[id.0 as usize].kind != ObstacleKind::Person)
                .map(|(_, shape)| shape)
                .collect();
            let (mut lo, mut hi) = (
                [start.x_m.min(goal.x_m), start.y_m.min(goal.y_m)],
                [start.x_m.max(goal.x_m), start.y_m.max(goal.y_m)],
            );
            for shape in &fixed {
                let (a, b) = shape.bounds_m();
                (lo[0], lo[1], hi[0], hi[1]) = (lo[0].min(a[0]), lo[1].min(a[1]), hi[0].max(b[0]), hi[1].max(b[1]));
            }
            let mut grid = Grid::covering([lo[0] - 1.0, lo[1] - 1.0], [hi[0] + 1.0, hi[1] + 1.0]);
            for shape in &fixed {
                let cells = grid.cells_of(shape);
                grid.add(&cells);
            }
            Some(grid.way([start.x_m, start.y_m], [goal.x_m, goal.y_m]).is_some())
        })
    }

    /// World name (`taylor-course`).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// What the world is for.
    pub fn description(&self) -> &str {
        &self.description
    }

    /// The user's start pose.
    pub fn start(&self) -> UserPose {
        self.start
    }

    /// The goal.
    pub fn goal(&self) -> &Goal {
        &self.goal
    }

    /// The scripted walk of the scene, if it has one.
    pub fn walker(&self) -> Option<&WalkerSpec> {
        self.walker.as_ref()
    }

    /// The route laid on the floor plan alone (walls, no furniture or hanging
    /// obstacles): its points between the start and the goal, when the scene has one.
    pub fn floor_plan_route(&self) -> Option<&[[f64; 2]]> {
        self.floor_plan_route.as_deref()
    }

    /// What the building's plan covers of floor `level` (min and max corners, map
    /// metres), when the scene says (`[plan_extent]`): beyond it the plan says nothing.
    pub fn plan_extent(&self, level: i32) -> Option<([f64; 2], [f64; 2])> {
        self.plan_extent.as_ref().filter(|e| e.floor == level).map(|e| (e.min, e.max))
    }

    /// Every floor, by ascending index.
    pub fn floors(&self) -> &[FloorGeometry] {
        &self.floors
    }

    /// Static geometry of one floor (empty for a floor the world does not have).
    pub fn geometry(&self, floor: i32) -> &FloorGeometry {
        self.floors.iter().find(|f| f.index == floor).unwrap_or(&NO_GEOMETRY)
    }

    /// Every obstacle; an [`ObstacleId`] indexes this.
    pub fn obstacles(&self) -> &[Obstacle] {
        &self.obstacles
    }

    /// The obstacle with this id.
    pub fn obstacle(&self, id: ObstacleId) -> Option<&Obstacle> {
        self.obstacles.get(id.0 as usize)
    }

    /// Walking people.
    pub fn people(&self) -> &[Person] {
        &self.people
    }

    /// Numbered doors.
    pub fn doors(&self) -> &[DoorSpec] {
        &self.doors
    }

    /// Corridor corners.
    pub fn corners(&self) -> &[CornerSpec] {
        &self.corners
    }

    /// Labelled rooms.
    pub fn rooms(&self) -> &[RoomSpec] {
        &self.rooms
    }

    /// Elevators.
    pub fn elevators(&self) -> &[ElevatorSpec] {
        &self.elevators
    }

    /// Flights of stairs.
    pub fn stairs(&self) -> &[StairsSpec] {
        &self.stairs
    }

    /// Every shape on `floor` at time `t_s` (people where they are then).
    pub fn obstacles_at(&self, floor: i32, t_s: f64) -> impl Iterator<Item = (ObstacleId, Shape)> + '_ {
        let g = self.geometry(floor);
        g.boxes
            .iter()
            .map(|(b, id)| (*id, Shape::Box(*b)))
            .chain(g.cylinders.iter().map(|(c, id)| (*id, Shape::Cylinder(*c))))
            .chain(g.drop_offs.iter().map(|(d, id)| (*id, Shape::DropOff(*d))))
            .chain(
                self.people
                    .iter()
                    .filter(move |p| p.floor == floor)
                    .map(move |p| (p.id, Shape::Cylinder(p.shape_at(t_s)))),
            )
    }

    /// Nearest obstacle to a standing body (vertical cylinder of `radius_m`, from the
    /// floor to `height_m`, at x, y) at time `t_s`; `None` on an empty floor.
    pub fn nearest_to_body(
        &self,
        floor: i32,
        x_m: f64,
        y_m: f64,
        radius_m: f64,
        height_m: f64,
        t_s: f64,
    ) -> Option<Nearest> {
        self.nearest_by(floor, t_s, |s| s.body_distance_m(x_m, y_m, radius_m, height_m))
    }

    /// Nearest obstacle to a segment (the cane, hand to tip; heights above the floor)
    /// at time `t_s`. Drop-offs are left out: the cane tip dipping into one is how a
    /// cane finds it, not a contact.
    pub fn nearest_to_segment(&self, floor: i32, a: [f64; 3], b: [f64; 3], t_s: f64) -> Option<Nearest> {
        self.nearest_by(floor, t_s, |s| match s {
            Shape::DropOff(_) => f64::INFINITY,
            _ => s.segment_distance_m(a, b),
        })
    }

    fn nearest_by(&self, floor: i32, t_s: f64, distance: impl Fn(&Shape) -> f64) -> Option<Nearest> {
        let mut best: Option<Nearest> = None;
        for (id, shape) in self.obstacles_at(floor, t_s) {
            let d = distance(&shape);
            if d.is_finite() && best.is_none_or(|b| d < b.distance_m) {
                let kind = self.obstacles[id.0 as usize].kind;
                best = Some(Nearest { distance_m: d, id, kind });
            }
        }
        best
    }
}

/// Thickness of a chair seat, metres.
const CHAIR_SEAT_THICKNESS_M: f64 = 0.04;

fn footprint_box(center: [f64; 2], size_m: [f64; 2], yaw_deg: f64, bottom_m: f64, top_m: f64) -> OrientedBox {
    OrientedBox {
        center_m: center,
        half_size_m: [size_m[0] / 2.0, size_m[1] / 2.0],
        yaw_rad: yaw_deg.to_radians(),
        bottom_m,
        top_m,
    }
}

/// The four corners at +-half around a centre, turned by yaw.
fn corners_of(center: [f64; 2], half: [f64; 2], yaw_deg: f64) -> [[f64; 2]; 4] {
    let (s, c) = yaw_deg.to_radians().sin_cos();
    [[1.0, 1.0], [1.0, -1.0], [-1.0, 1.0], [-1.0, -1.0]]
        .map(|[a, b]| [center[0] + c * a * half[0] - s * b * half[1], center[1] + s * a * half[0] + c * b * half[1]])
}

struct Builder {
    floors: Vec<FloorGeometry>,
    obstacles: Vec<Obstacle>,
}

impl Builder {
    fn obstacle(&mut self, kind: ObstacleKind, label: &str, table: &str, index: usize, floor: i32) -> ObstacleId {
        let label = if label.is_empty() { format!("{table}[{index}]") } else { label.to_string() };
        self.obstacles.push(Obstacle { kind, label, floor });
        ObstacleId(self.obstacles.len() as u32 - 1)
    }

    fn floor(&mut self, index: i32) -> &mut FloorGeometry {
        // The scene check guarantees every item's floor exists.
        let slot = self.floors.iter().position(|f| f.index == index).unwrap_or(0);
        &mut self.floors[slot]
    }

    fn add_box(&mut self, floor: i32, id: ObstacleId, b: OrientedBox) {
        self.floor(floor).boxes.push((b, id));
    }

    fn add_cylinder(&mut self, floor: i32, id: ObstacleId, c: VerticalCylinder) {
        self.floor(floor).cylinders.push((c, id));
    }

    fn add_drop_off(&mut self, floor: i32, id: ObstacleId, d: DropOff) {
        self.floor(floor).drop_offs.push((d, id));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::walker::ScriptedWalker;
    use std::collections::BinaryHeap;

    fn builtin(name: &str) -> World {
        match World::builtin(name) {
            Some(Ok(w)) => w,
            Some(Err(e)) => panic!("{e}"),
            None => panic!("no built-in {name}"),
        }
    }

    fn count(w: &World, kind: ObstacleKind) -> usize {
        w.obstacles().iter().filter(|o| o.kind == kind).count()
    }

    #[test]
    fn every_builtin_world_loads_with_its_features() {
        let t = builtin("taylor-course");
        assert_eq!(
            (count(&t, ObstacleKind::Wall), count(&t, ObstacleKind::Chair), count(&t, ObstacleKind::Hanging)),
            (6, 3, 2)
        );
        let heights: Vec<f64> = t
            .geometry(0)
            .boxes
            .iter()
            .filter(|(_, id)| t.obstacles()[id.0 as usize].kind == ObstacleKind::Hanging)
            .map(|(b, _)| b.bottom_m)
            .collect();
        assert!(
            heights.iter().any(|&h| h < 1.0) && heights.iter().any(|&h| h > 1.5),
            "waist- and head-high: {heights:?}"
        );

        let c = builtin("corridor");
        assert!(c.doors().len() >= 10 && c.corners().len() >= 2 && c.people().len() == 2);

        let b = builtin("building");
        assert_eq!(b.floors().iter().map(|f| f.index).collect::<Vec<_>>(), vec![0, 1]);
        assert_eq!(b.elevators()[0].floors, vec![0, 1]);
        assert_eq!(b.stairs().len(), 1);
        assert_eq!(b.geometry(0).drop_offs.len(), 0);
        assert_eq!(b.geometry(1).drop_offs.len(), 1, "stair opening upstairs");
        let top_step = b.geometry(0).boxes.iter().map(|(s, _)| s.top_m).fold(0.0, f64::max);
        assert!((top_step - 3.5).abs() < 1e-9, "stairs rise to the next floor: {top_step}");
        assert!(b.rooms().iter().any(|r| r.label == "room 204" && r.floor == 1));

        let a = builtin("approach");
        assert_eq!(count(&a, ObstacleKind::Wall), 1);

        let s = builtin("sign-ahead");
        assert_eq!((s.obstacles().len(), count(&s, ObstacleKind::Hanging)), (1, 1));
        let (sign, _) = s.geometry(0).boxes[0];
        assert!(sign.bottom_m > 1.5 && sign.top_m < 1.9, "head height: {sign:?}");
    }

    /// What a 0.45 m wide body walking the floor-plan route (start to goal) touches,
    /// and how near the route comes to a wall or a drop-off.
    fn along_floor_plan_route(w: &World) -> (std::collections::BTreeSet<String>, f64) {
        let (start, goal) = (w.start(), w.goal());
        let mut route = vec![[start.x_m, start.y_m]];
        route.extend_from_slice(w.floor_plan_route().unwrap_or_else(|| panic!("{}: no floor-plan route", w.name())));
        route.push([goal.x_m, goal.y_m]);
        let (mut touched, mut nearest_m) = (std::collections::BTreeSet::new(), f64::INFINITY);
        for leg in route.windows(2) {
            let steps = ((leg[1][0] - leg[0][0]).hypot(leg[1][1] - leg[0][1]) / 0.05).ceil() as usize;
            for i in 0..=steps {
                let f = i as f64 / steps as f64;
                let (x, y) = (leg[0][0] + f * (leg[1][0] - leg[0][0]), leg[0][1] + f * (leg[1][1] - leg[0][1]));
                for (id, shape) in w.obstacles_at(0, 0.0) {
                    let Some(o) = w.obstacle(id) else { continue };
                    if matches!(o.kind, ObstacleKind::Wall | ObstacleKind::DropOff) {
                        nearest_m = nearest_m.min(shape.body_distance_m(x, y, 0.0, 1.8));
                    } else if shape.body_distance_m(x, y, 0.225, 1.8) == 0.0 {
                        touched.insert(o.label.clone());
                    }
                }
            }
        }
        (touched, nearest_m)
    }

    #[test]
    fn a_world_says_whether_there_is_a_way_through() {
        // built-in and generated worlds have one; a goal on another floor is not searched
        assert_eq!(World::load("corridor").unwrap().way_through(), Some(true));
        assert_eq!(World::load("gen:lobby:7").unwrap().way_through(), Some(true));
        assert_eq!(World::load("building").unwrap().way_through(), None);
        // a corridor closed by a wall across it; then with a 0.45 m gap (too narrow for
        // a 0.5 m wide body), then a 0.8 m one
        // (the corridor closed at both ends: the simulated floor goes on outside the walls)
        let head = "name = \"w\"\nstart = { x_m = 0.0, y_m = 0.0 }\ngoal = { x_m = 6.0, y_m = 0.0 }\n\
                    [[walls]]\nfrom = [-1.0, -1.0]\nto = [7.0, -1.0]\n[[walls]]\nfrom = [-1.0, 1.0]\nto = [7.0, 1.0]\n\
                    [[walls]]\nfrom = [-1.0, -1.0]\nto = [-1.0, 1.0]\n[[walls]]\nfrom = [7.0, -1.0]\nto = [7.0, 1.0]\n";
        let across = |gap: f64| {
            format!(
                "[[walls]]\nfrom = [3.0, -1.0]\nto = [3.0, {}]\n[[walls]]\nfrom = [3.0, {}]\nto = [3.0, 1.0]\n",
                -gap / 2.0,
                gap / 2.0
            )
        };
        let world = |extra: &str| World::from_toml(&format!("{head}{extra}"), "t").unwrap();
        assert_eq!(world("[[walls]]\nfrom = [3.0, -1.0]\nto = [3.0, 1.0]\n").way_through(), Some(false));
        assert_eq!(world(&across(0.45)).way_through(), Some(false));
        assert_eq!(world(&across(0.8)).way_through(), Some(true));
        // people are not in the way: they give way
        let person = "[[people]]\nwaypoints = [[3.0, 0.0], [3.0, 0.1]]\n";
        assert_eq!(world(person).way_through(), Some(true));
    }

    #[test]
    fn hidden_style_worlds_load_with_what_their_description_says_and_a_floor_plan_route() {
        let box_of = |w: &World, label: &str| {
            let id = w.obstacles().iter().position(|o| o.label == label).unwrap_or_else(|| panic!("no {label}"));
            w.geometry(0)
                .boxes
                .iter()
                .find(|(_, i)| i.0 as usize == id)
                .map(|(b, _)| *b)
                .unwrap_or_else(|| panic!("{label} is no box"))
        };
        let c = builtin("corridor-narrow");
        let cabinet = box_of(&c, "wall cabinet");
        assert_eq!((cabinet.bottom_m, cabinet.top_m, 2.0 * cabinet.half_size_m[1]), (1.2, 1.9, 0.3));
        let sign = box_of(&c, "flag sign");
        assert_eq!((sign.bottom_m, sign.top_m, 2.0 * sign.half_size_m[0]), (1.6, 1.9, 0.3));
        assert_eq!((count(&c, ObstacleKind::Cylinder), c.corners().len()), (1, 1), "a bin, one corner");
        let (touched, nearest_wall_m) = along_floor_plan_route(&c);
        // down the middle of 1.6 m (0.8 m from the side walls; the nearest wall is the end
        // wall, 0.75 m behind the start), clear of the bin, the cabinet and the sign
        assert!(touched.is_empty() && (nearest_wall_m - 0.75).abs() < 1e-9, "{touched:?} {nearest_wall_m}");

        let l = builtin("lobby-bench");
        let bench = box_of(&l, "bench");
        assert_eq!((2.0 * bench.half_size_m[0], 2.0 * bench.half_size_m[1], bench.top_m), (1.6, 0.45, 0.45));
        assert_eq!(l.geometry(0).drop_offs.iter().map(|(d, _)| d.depth_m).collect::<Vec<_>>(), [0.15]);
        assert_eq!(count(&l, ObstacleKind::Pole), 3, "bollards");
        let (touched, nearest_m) = along_floor_plan_route(&l);
        // the plan shows the step (0.5 m off the route), not the bench and bollard on it
        assert_eq!(touched.into_iter().collect::<Vec<_>>(), ["bench", "bollard 2"]);
        assert!((nearest_m - 0.5).abs() < 1e-9, "{nearest_m}");

        let h = builtin("hanging-lamp");
        let lamp = box_of(&h, "hanging lamp");
        assert!(lamp.bottom_m >= 1.5 && lamp.top_m <= 1.85, "{lamp:?}");
        let (touched, _) = along_floor_plan_route(&h);
        assert_eq!(touched.into_iter().collect::<Vec<_>>(), ["hanging lamp"], "the sign hangs beside the way");
    }

    #[test]
    fn scene_file_loads_by_path_and_a_missing_file_is_an_unknown_world() {
        let path = std::env::temp_dir().join(format!("wearnav-sim-scene-{}.toml", std::process::id()));
        let text = "name = \"mine\"\nstart = { x_m = 0.0, y_m = 0.0 }\ngoal = { x_m = 2.0, y_m = 0.0 }\n[[poles]]\ncenter = [1.0, 0.0]\nheight_m = 1.0\n";
        if let Err(e) = std::fs::write(&path, text) {
            panic!("cannot write {}: {e}", path.display());
        }
        let loaded = World::load(&path.display().to_string());
        let _ = std::fs::remove_file(&path);
        let w = loaded.unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(w.name(), "mine");
        assert_eq!(w.geometry(0).cylinders.len(), 1);
        let missing = World::load(&path.display().to_string()).err().map(|e| e.to_string()).unwrap_or_default();
        assert!(missing.starts_with("unknown world `"), "{missing}");
    }

    #[test]
    fn unknown_world_lists_the_builtin_ones() {
        let err = World::load("no-such-world").err().map(|e| e.to_string()).unwrap_or_default();
        assert!(
            err.contains("unknown world `no-such-world`")
                && err.contains("taylor-course, open-course, corridor, building, approach, step-down"),
            "{err}"
        );
    }

    /// Shortest walking distance for a body of shoulder width on a 10 cm grid
    /// (8-connected Dijkstra), or `None` when the goal cannot be reached.
    fn walking_distance_m(w: &World, size_m: [f64; 2]) -> Option<f64> {
        let cell = 0.1;
        let (nx, ny) = ((size_m[0] / cell) as i64, (size_m[1] / cell) as i64);
        let centre = |i: i64, j: i64| ((i as f64 + 0.5) * cell, (j as f64 + 0.5) * cell);
        let free: Vec<bool> = (0..nx * ny)
            .map(|k| {
                let (x, y) = centre(k % nx, k / nx);
                w.nearest_to_body(0, x, y, 0.25, 1.8, 0.0).is_none_or(|n| n.distance_m > 0.0)
            })
            .collect();
        let index = |x: f64, y: f64| ((y / cell) as i64) * nx + (x / cell) as i64;
        let (s, g) = (index(w.start().x_m, w.start().y_m), index(w.goal().x_m, w.goal().y_m));
        let mut dist = vec![f64::INFINITY; (nx * ny) as usize];
        let mut heap = BinaryHeap::new();
        dist[s as usize] = 0.0;
        heap.push((std::cmp::Reverse(0u64), s));
        while let Some((std::cmp::Reverse(dmm), k)) = heap.pop() {
            let d = dmm as f64 / 1e6;
            if k == g {
                return Some(d);
            }
            if d > dist[k as usize] {
                continue;
            }
            let (i, j) = (k % nx, k / nx);
            for (di, dj) in [(1, 0), (-1, 0), (0, 1), (0, -1), (1, 1), (1, -1), (-1, 1), (-1, -1)] {
                let (a, b) = (i + di, j + dj);
                if a < 0 || b < 0 || a >= nx || b >= ny || !free[(b * nx + a) as usize] {
                    continue;
                }
                if di != 0 && dj != 0 && !(free[(j * nx + a) as usize] && free[(b * nx + i) as usize]) {
                    continue;
                }
                let nd = d + cell * ((di * di + dj * dj) as f64).sqrt();
                if nd < dist[(b * nx + a) as usize] {
                    dist[(b * nx + a) as usize] = nd;
                    heap.push((std::cmp::Reverse((nd * 1e6) as u64), b * nx + a));
                }
            }
        }
        None
    }

    #[test]
    fn taylor_course_goal_is_15_to_25_m_of_walking_from_the_start() {
        let w = builtin("taylor-course");
        let walk = walking_distance_m(&w, [10.0, 10.0]);
        let straight = (w.goal().x_m - w.start().x_m).hypot(w.goal().y_m - w.start().y_m);
        let walk = walk.unwrap_or(f64::INFINITY);
        println!("taylor-course: {walk:.1} m of walking, {straight:.1} m straight");
        assert!((15.0..=25.0).contains(&walk), "walking distance {walk:.1} m");
        assert!(walk > 1.5 * straight, "the course must turn: {walk:.1} m vs {straight:.1} m straight");
        let start = w.start();
        assert!((start.x_m < 1.0) && (start.y_m - 5.0).abs() < 0.5 && start.yaw_rad == 0.0, "middle-left facing right");
    }

    #[test]
    fn taylor_course_floor_plan_route_clears_the_walls_but_not_the_furniture() {
        let w = builtin("taylor-course");
        let (start, goal) = (w.start(), w.goal());
        let mut route = vec![[start.x_m, start.y_m]];
        route.extend_from_slice(w.floor_plan_route().unwrap_or_else(|| panic!("no floor-plan route")));
        route.push([goal.x_m, goal.y_m]);
        let mut in_the_way = std::collections::BTreeSet::new();
        let mut nearest_wall_m = f64::INFINITY;
        for leg in route.windows(2) {
            let steps = ((leg[1][0] - leg[0][0]).hypot(leg[1][1] - leg[0][1]) / 0.05).ceil() as usize;
            for i in 0..=steps {
                let f = i as f64 / steps as f64;
                let (x, y) = (leg[0][0] + f * (leg[1][0] - leg[0][0]), leg[0][1] + f * (leg[1][1] - leg[0][1]));
                // a body 0.45 m wide and 1.8 m tall walking the route
                for (id, shape) in w.obstacles_at(0, 0.0) {
                    let d = shape.body_distance_m(x, y, 0.225, 1.8);
                    let Some(o) = w.obstacle(id) else { continue };
                    if o.kind == ObstacleKind::Wall {
                        nearest_wall_m = nearest_wall_m.min(d);
                    } else if d == 0.0 {
                        in_the_way.insert(o.label.clone());
                    }
                }
            }
        }
        // laid on the walls alone: clear of every wall and divider (the nearest, 0.42 m,
        // is the west wall at the start), and through what the floor plan does not show
        assert!(nearest_wall_m >= 0.4, "{nearest_wall_m}");
        assert_eq!(in_the_way.into_iter().collect::<Vec<_>>(), ["chair 1", "head-high sign"]);
    }

    #[test]
    fn open_course_goal_is_straight_ahead_past_a_divider_across_the_way() {
        let w = builtin("open-course");
        let walk = walking_distance_m(&w, [10.0, 10.0]).unwrap_or(f64::INFINITY);
        let straight = (w.goal().x_m - w.start().x_m).hypot(w.goal().y_m - w.start().y_m);
        println!("open-course: {walk:.1} m of walking, {straight:.1} m straight");
        // the straight way is blocked, but going round costs little: the sound leads
        assert!(walk > straight + 0.3 && walk < 1.3 * straight, "{walk:.1} m vs {straight:.1} m straight");
        let start = w.start();
        let ahead = w.nearest_to_segment(0, [start.x_m, start.y_m, 1.0], [w.goal().x_m, w.goal().y_m, 1.0], 0.0);
        assert!(ahead.is_some_and(|n| n.distance_m == 0.0), "something stands on the straight line: {ahead:?}");
        assert_eq!(
            (count(&w, ObstacleKind::Wall), count(&w, ObstacleKind::Chair), count(&w, ObstacleKind::Hanging)),
            (6, 3, 2)
        );
    }

    #[test]
    fn scripted_walks_of_the_builtin_worlds_never_touch_an_obstacle() {
        for (name, _) in BUILTIN_WORLDS {
            let w = builtin(name);
            let Some(spec) = w.walker() else { continue };
            let walker = ScriptedWalker::new(w.start(), spec);
            let end_s = walker.script_duration_s() * 2.0;
            let mut t = 0.0;
            while t <= end_s {
                let p = walker.pose_at(t);
                if let Some(n) = w.nearest_to_body(p.floor, p.x_m, p.y_m, 0.25, 1.8, t) {
                    assert!(n.distance_m > 0.0, "{name}: body touches {:?} at t = {t:.1} s, {p:?}", w.obstacle(n.id));
                }
                t += 0.05;
            }
        }
    }

    #[test]
    fn cane_reaching_a_wall_is_a_contact_with_that_wall() {
        let w = match World::from_toml(
            "name = \"t\"\nstart = { x_m = 0.0, y_m = 0.0 }\ngoal = { x_m = 1.0, y_m = 0.0 }\n[[walls]]\nlabel = \"w\"\nfrom = [1.0, -1.0]\nto = [1.0, 1.0]\nthickness_m = 0.1\n[[floor_regions]]\ncenter = [0.5, 0.0]\nsize_m = [0.4, 0.4]\nheight_m = -0.2\n",
            "t",
        ) {
            Ok(w) => w,
            Err(e) => panic!("{e}"),
        };
        let hit = w.nearest_to_segment(0, [0.0, 0.0, 1.0], [1.2, 0.0, 0.0], 0.0);
        assert!(hit.is_some_and(|n| n.distance_m == 0.0 && n.kind == ObstacleKind::Wall), "{hit:?}");
        let short = w.nearest_to_segment(0, [0.0, 0.0, 1.0], [0.8, 0.0, 0.0], 0.0);
        assert!(short.is_some_and(|n| (n.distance_m - 0.15).abs() < 0.01 && n.kind == ObstacleKind::Wall), "{short:?}");
        // Standing in the hole is a contact with the drop-off.
        let fall = w.nearest_to_body(0, 0.5, 0.0, 0.25, 1.8, 0.0);
        assert!(fall.is_some_and(|n| n.distance_m == 0.0 && n.kind == ObstacleKind::DropOff), "{fall:?}");
    }
}

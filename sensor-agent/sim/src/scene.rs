//! Scene files: the TOML format the simulated worlds are written in, its schema check,
//! and errors that name the line and the reason.
//!
//! A scene is a TOML document (full reference with examples: `sensor-agent/worlds/README.md`):
//!
//! ```toml
//! name = "my-room"
//! description = "what this world is for"
//! start = { x_m = 0.7, y_m = 5.0, yaw_deg = 0.0 }        # user start pose, floor 0
//! goal = { x_m = 8.8, y_m = 9.0, label = "music" }       # where the walk ends
//!
//! [[floors]]                    # optional; without it there is one floor, index 0
//! index = 0
//! name = "ground"
//! elevation_m = 0.0
//!
//! [[walls]]                     # vertical slab along a segment
//! from = [0.0, 0.0]
//! to = [10.0, 0.0]
//! height_m = 2.5                # default 2.5
//! thickness_m = 0.1             # default 0.1
//!
//! [[cylinders]]
//! center = [2.0, 2.0]
//! radius_m = 0.2
//! top_m = 0.9
//!
//! [walker]                      # optional scripted walk from `start`
//! waypoints = [[2.0, 5.0], [2.0, 8.5]]
//! at_end = "stop"               # or "back_up": retrace the path walking backwards, forever
//!
//! [floor_plan_route]            # optional: the route laid on the walls alone
//! waypoints = [[1.75, 8.5], [5.0, 8.5]]   # from `start`, the goal not repeated
//!
//! [plan_extent]                 # optional: what the building's plan covers
//! min = [-0.5, -0.2]            # beyond it the exported floor plan is unknown,
//! max = [30.5, 4.0]             # so no route is laid there
//! ```
//!
//! Item tables: `walls`, `boxes`, `cylinders`, `poles`, `tables`, `chairs`, `hanging`,
//! `floor_regions` (steps up, drop-offs down), `people` (walking on waypoints),
//! `doors` (numbered), `corners`, `rooms` (labelled areas), `elevators`, `stairs`.
//! Every geometric item takes `floor` (default 0) and an optional `label`. Unknown
//! fields are refused; impossible shapes (a negative radius, a top below its bottom,
//! a hanging obstacle that touches the floor, a floor that does not exist) are refused
//! with the line of the item and the reason.

use serde::Deserialize;
use toml::Spanned;

/// Why a scene could not be loaded. Every variant says where (`origin`, line) and why.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The text is not valid TOML or does not fit the schema (unknown field, wrong type).
    #[error("{origin}:{line}: {message}")]
    Syntax {
        /// File path or `builtin:<name>`.
        origin: String,
        /// 1-based line of the problem (0 when the parser gave no position).
        line: usize,
        /// The parser's reason.
        message: String,
    },
    /// The TOML is well formed but describes something impossible.
    #[error("{origin}:{line}: {item}: {reason}")]
    Invalid {
        /// File path or `builtin:<name>`.
        origin: String,
        /// 1-based line where the offending item starts.
        line: usize,
        /// Which item (`cylinders[2] "bin"`).
        item: String,
        /// What is wrong with it.
        reason: String,
    },
    /// The scene file could not be read.
    #[error("cannot read scene file {path}: {source}")]
    Io {
        /// Path given.
        path: String,
        /// The OS error.
        source: std::io::Error,
    },
    /// A `gen:` name that names no generated world.
    #[error(transparent)]
    Generate(#[from] crate::generate::GenerateError),
    /// A world name that is neither built in nor a readable file.
    #[error("unknown world `{name}`: give a scene file path, one of the built-in worlds ({known}) or a generated one (gen:corridor:7; kinds corridor, office, lobby, street)")]
    UnknownWorld {
        /// The name asked for.
        name: String,
        /// Comma-separated built-in names.
        known: String,
    },
}

fn default_wall_height() -> f64 {
    2.5
}
fn default_wall_thickness() -> f64 {
    0.1
}
fn default_pole_radius() -> f64 {
    0.025
}
fn default_table_height() -> f64 {
    0.75
}
fn default_table_top() -> f64 {
    0.04
}
fn default_leg_radius() -> f64 {
    0.025
}
fn default_seat_size() -> f64 {
    0.45
}
fn default_seat_height() -> f64 {
    0.45
}
fn default_back_height() -> f64 {
    0.9
}
fn default_door_width() -> f64 {
    0.9
}
fn default_person_radius() -> f64 {
    0.25
}
fn default_person_height() -> f64 {
    1.75
}
fn default_walk_speed() -> f64 {
    1.0
}
fn default_turn_rate() -> f64 {
    90.0
}
fn default_tread() -> f64 {
    0.3
}
fn default_stair_width() -> f64 {
    1.2
}

/// A whole scene file.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    /// World name (`taylor-course`); `describe()` prints `sim:<name>`.
    pub name: String,
    /// What the world is for.
    #[serde(default)]
    pub description: String,
    /// Where the user starts.
    pub start: Spanned<StartSpec>,
    /// Where the walk should end.
    pub goal: Spanned<GoalSpec>,
    /// Floors (default: one floor, index 0, elevation 0).
    #[serde(default)]
    pub floors: Vec<Spanned<FloorSpec>>,
    /// Wall segments.
    #[serde(default)]
    pub walls: Vec<Spanned<WallSpec>>,
    /// Boxes standing on (or raised above) the floor.
    #[serde(default)]
    pub boxes: Vec<Spanned<BoxSpec>>,
    /// Vertical cylinders (bins, columns).
    #[serde(default)]
    pub cylinders: Vec<Spanned<CylinderSpec>>,
    /// Thin poles from the floor up.
    #[serde(default)]
    pub poles: Vec<Spanned<PoleSpec>>,
    /// Tables: a top on four legs.
    #[serde(default)]
    pub tables: Vec<Spanned<TableSpec>>,
    /// Chairs: seat, back, four legs.
    #[serde(default)]
    pub chairs: Vec<Spanned<ChairSpec>>,
    /// Obstacles hanging free of the floor (waist-high, head-high).
    #[serde(default)]
    pub hanging: Vec<Spanned<HangingSpec>>,
    /// Floor regions at another height: steps up (positive) and drop-offs (negative).
    #[serde(default)]
    pub floor_regions: Vec<Spanned<FloorRegionSpec>>,
    /// People walking on waypoint paths.
    #[serde(default)]
    pub people: Vec<Spanned<PersonSpec>>,
    /// Numbered doors (unique landmarks).
    #[serde(default)]
    pub doors: Vec<Spanned<DoorSpec>>,
    /// Corridor corners (non-unique landmarks).
    #[serde(default)]
    pub corners: Vec<Spanned<CornerSpec>>,
    /// Labelled rooms (areas).
    #[serde(default)]
    pub rooms: Vec<Spanned<RoomSpec>>,
    /// Elevators joining floors.
    #[serde(default)]
    pub elevators: Vec<Spanned<ElevatorSpec>>,
    /// Flights of stairs joining two floors.
    #[serde(default)]
    pub stairs: Vec<Spanned<StairsSpec>>,
    /// Scripted walk from `start` (optional).
    pub walker: Option<Spanned<WalkerSpec>>,
    /// The route a planner would lay on the floor plan alone (optional).
    pub floor_plan_route: Option<Spanned<FloorPlanRouteSpec>>,
    /// What the building's plan covers of one floor (optional; without it, everything
    /// on the floor with a margin round it).
    pub plan_extent: Option<Spanned<PlanExtentSpec>>,
}

/// The rectangle of a floor that the building's plan covers. A plan of a pavement
/// ends at the pavement's ends and at the kerb: it says nothing of what lies across
/// the road or behind the building, so the floor plan exported from the world leaves
/// that unknown, and no route is laid there.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlanExtentSpec {
    /// The floor (default 0).
    #[serde(default)]
    pub floor: i32,
    /// Smallest x and y, map metres.
    pub min: [f64; 2],
    /// Largest x and y, map metres.
    pub max: [f64; 2],
}

/// A route laid on the floor plan alone: walls and dividers, no furniture, no hanging
/// obstacles (what a planner given only the building's plan would give), from `start`
/// to the goal.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FloorPlanRouteSpec {
    /// Points between `start` and the goal, in order, map metres (on the start floor).
    pub waypoints: Vec<[f64; 2]>,
}

/// The user's start pose.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StartSpec {
    /// Map x, metres.
    pub x_m: f64,
    /// Map y, metres.
    pub y_m: f64,
    /// Heading, degrees, counter-clockwise from +x.
    #[serde(default)]
    pub yaw_deg: f64,
    /// Floor index.
    #[serde(default)]
    pub floor: i32,
}

/// The goal.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GoalSpec {
    /// Map x, metres.
    pub x_m: f64,
    /// Map y, metres.
    pub y_m: f64,
    /// Floor index.
    #[serde(default)]
    pub floor: i32,
    /// Name ("music", "room 112").
    #[serde(default)]
    pub label: String,
}

/// One floor of the building.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FloorSpec {
    /// Index used by items' `floor` fields.
    pub index: i32,
    /// Name ("ground floor").
    #[serde(default)]
    pub name: String,
    /// Height of this floor above the building's zero, metres.
    #[serde(default)]
    pub elevation_m: f64,
}

/// A wall segment.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WallSpec {
    /// Floor index.
    #[serde(default)]
    pub floor: i32,
    /// Segment start, map metres.
    pub from: [f64; 2],
    /// Segment end, map metres.
    pub to: [f64; 2],
    /// Height, metres.
    #[serde(default = "default_wall_height")]
    pub height_m: f64,
    /// Thickness, metres (centred on the segment).
    #[serde(default = "default_wall_thickness")]
    pub thickness_m: f64,
    /// Name.
    #[serde(default)]
    pub label: String,
}

/// A box.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoxSpec {
    /// Floor index.
    #[serde(default)]
    pub floor: i32,
    /// Footprint centre, map metres.
    pub center: [f64; 2],
    /// Footprint size along the box's own axes, metres.
    pub size_m: [f64; 2],
    /// Turn, degrees.
    #[serde(default)]
    pub yaw_deg: f64,
    /// Underside height, metres.
    #[serde(default)]
    pub bottom_m: f64,
    /// Top height, metres.
    pub top_m: f64,
    /// Name.
    #[serde(default)]
    pub label: String,
}

/// A vertical cylinder.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CylinderSpec {
    /// Floor index.
    #[serde(default)]
    pub floor: i32,
    /// Axis position, map metres.
    pub center: [f64; 2],
    /// Radius, metres.
    pub radius_m: f64,
    /// Underside height, metres.
    #[serde(default)]
    pub bottom_m: f64,
    /// Top height, metres.
    pub top_m: f64,
    /// Name.
    #[serde(default)]
    pub label: String,
}

/// A thin pole from the floor up.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PoleSpec {
    /// Floor index.
    #[serde(default)]
    pub floor: i32,
    /// Position, map metres.
    pub center: [f64; 2],
    /// Radius, metres (default 2.5 cm).
    #[serde(default = "default_pole_radius")]
    pub radius_m: f64,
    /// Height, metres.
    pub height_m: f64,
    /// Name.
    #[serde(default)]
    pub label: String,
}

/// A table: a top on four legs set in 5 cm from the corners.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TableSpec {
    /// Floor index.
    #[serde(default)]
    pub floor: i32,
    /// Centre, map metres.
    pub center: [f64; 2],
    /// Top size along the table's own axes, metres.
    pub size_m: [f64; 2],
    /// Turn, degrees.
    #[serde(default)]
    pub yaw_deg: f64,
    /// Height of the top surface, metres.
    #[serde(default = "default_table_height")]
    pub height_m: f64,
    /// Thickness of the top, metres.
    #[serde(default = "default_table_top")]
    pub top_thickness_m: f64,
    /// Leg radius, metres.
    #[serde(default = "default_leg_radius")]
    pub leg_radius_m: f64,
    /// Name.
    #[serde(default)]
    pub label: String,
}

/// A chair: square seat on four legs with a back on the side opposite its facing.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChairSpec {
    /// Floor index.
    #[serde(default)]
    pub floor: i32,
    /// Seat centre, map metres.
    pub center: [f64; 2],
    /// Direction a seated person faces, degrees.
    #[serde(default)]
    pub yaw_deg: f64,
    /// Seat side length, metres.
    #[serde(default = "default_seat_size")]
    pub seat_size_m: f64,
    /// Seat height, metres.
    #[serde(default = "default_seat_height")]
    pub seat_height_m: f64,
    /// Height of the top of the back, metres.
    #[serde(default = "default_back_height")]
    pub back_height_m: f64,
    /// Name.
    #[serde(default)]
    pub label: String,
}

/// An obstacle hanging free of the floor (its support is too thin to see).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HangingSpec {
    /// Floor index.
    #[serde(default)]
    pub floor: i32,
    /// Footprint centre, map metres.
    pub center: [f64; 2],
    /// Footprint size, metres.
    pub size_m: [f64; 2],
    /// Turn, degrees.
    #[serde(default)]
    pub yaw_deg: f64,
    /// Underside height above the floor, metres (> 0).
    pub bottom_m: f64,
    /// Top height, metres.
    pub top_m: f64,
    /// Name.
    #[serde(default)]
    pub label: String,
}

/// A floor region at another height: a step up (`height_m > 0`, a raised platform)
/// or a drop-off (`height_m < 0`, a hole with vertical sides).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FloorRegionSpec {
    /// Floor index.
    #[serde(default)]
    pub floor: i32,
    /// Centre, map metres.
    pub center: [f64; 2],
    /// Size along its own axes, metres.
    pub size_m: [f64; 2],
    /// Turn, degrees.
    #[serde(default)]
    pub yaw_deg: f64,
    /// Height relative to the floor, metres, non-zero.
    pub height_m: f64,
    /// Name.
    #[serde(default)]
    pub label: String,
}

/// A person walking back and forth along waypoints.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PersonSpec {
    /// Floor index.
    #[serde(default)]
    pub floor: i32,
    /// Path, map metres; the person walks it to the end, then back, forever.
    pub waypoints: Vec<[f64; 2]>,
    /// Walking speed, m/s.
    #[serde(default = "default_walk_speed")]
    pub speed_m_s: f64,
    /// Body radius, metres.
    #[serde(default = "default_person_radius")]
    pub radius_m: f64,
    /// Height, metres.
    #[serde(default = "default_person_height")]
    pub height_m: f64,
    /// Seconds of walking already done at t = 0 (to spread several people out).
    #[serde(default)]
    pub phase_s: f64,
    /// Name.
    #[serde(default)]
    pub label: String,
}

/// A numbered door in a wall (a unique landmark).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DoorSpec {
    /// Floor index.
    #[serde(default)]
    pub floor: i32,
    /// Centre of the doorway on the wall line, map metres.
    pub at: [f64; 2],
    /// Door number as written on its sign ("112").
    pub number: String,
    /// Direction the door's face looks (into the corridor), degrees.
    #[serde(default)]
    pub facing_deg: f64,
    /// Width, metres.
    #[serde(default = "default_door_width")]
    pub width_m: f64,
}

/// A corridor corner (a non-unique landmark).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CornerSpec {
    /// Floor index.
    #[serde(default)]
    pub floor: i32,
    /// Position, map metres.
    pub at: [f64; 2],
    /// Name.
    #[serde(default)]
    pub label: String,
}

/// A labelled rectangular area.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RoomSpec {
    /// Floor index.
    #[serde(default)]
    pub floor: i32,
    /// Name ("room 112", "kitchen").
    pub label: String,
    /// Lower corner, map metres.
    pub min: [f64; 2],
    /// Upper corner, map metres.
    pub max: [f64; 2],
}

/// An elevator stopping at several floors (same x, y on each).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ElevatorSpec {
    /// Name.
    pub label: String,
    /// Where one stands to enter, map metres.
    pub at: [f64; 2],
    /// Floor indexes served (at least two).
    pub floors: Vec<i32>,
}

/// A straight flight of stairs rising from `from_floor` to `to_floor`. On the lower
/// floor it is a rising staircase; on the upper floor its footprint is an opening
/// (a drop-off) beside the landing.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct StairsSpec {
    /// Name.
    pub label: String,
    /// Lower floor index.
    pub from_floor: i32,
    /// Upper floor index.
    pub to_floor: i32,
    /// Middle of the first step's front edge, map metres.
    pub start: [f64; 2],
    /// Direction of climbing, degrees.
    pub yaw_deg: f64,
    /// Number of steps.
    pub steps: u32,
    /// Depth of one step, metres.
    #[serde(default = "default_tread")]
    pub tread_m: f64,
    /// Width of the flight, metres.
    #[serde(default = "default_stair_width")]
    pub width_m: f64,
}

/// What the scripted walker does after its last waypoint.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum AtEnd {
    /// Stand still there.
    Stop,
    /// Walk the path back to the start facing the same way (backing up), then repeat.
    BackUp,
}

/// A scripted walk from the start pose.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WalkerSpec {
    /// Points to walk to in order, map metres (on the start floor).
    pub waypoints: Vec<[f64; 2]>,
    /// Walking speed, m/s.
    #[serde(default = "default_walk_speed")]
    pub speed_m_s: f64,
    /// Turning rate in place, degrees/s.
    #[serde(default = "default_turn_rate")]
    pub turn_rate_deg_s: f64,
    /// What happens after the last waypoint.
    pub at_end: AtEnd,
}

/// Largest coordinate or size accepted, metres: anything bigger is a typo.
const MAX_EXTENT_M: f64 = 10_000.0;

/// Checks one item, remembering where it is for the error message.
struct Check<'a> {
    origin: &'a str,
    text: &'a str,
    span: std::ops::Range<usize>,
    item: String,
}

impl Check<'_> {
    fn fail(&self, reason: String) -> SceneError {
        SceneError::Invalid {
            origin: self.origin.to_string(),
            line: line_of(self.text, self.span.start),
            item: self.item.clone(),
            reason,
        }
    }

    fn finite(&self, field: &str, values: &[f64]) -> Result<(), SceneError> {
        for v in values {
            if !v.is_finite() || v.abs() > MAX_EXTENT_M {
                return Err(self.fail(format!("{field} must be finite and within {MAX_EXTENT_M} m, got {v}")));
            }
        }
        Ok(())
    }

    fn positive(&self, field: &str, value: f64) -> Result<(), SceneError> {
        self.finite(field, &[value])?;
        if value <= 0.0 {
            return Err(self.fail(format!("{field} must be > 0, got {value}")));
        }
        Ok(())
    }

    fn above(&self, bottom_m: f64, top_m: f64) -> Result<(), SceneError> {
        self.finite("bottom_m/top_m", &[bottom_m, top_m])?;
        if bottom_m < 0.0 {
            return Err(self.fail(format!("bottom_m must be >= 0 (items cannot go below their floor), got {bottom_m}")));
        }
        if top_m <= bottom_m {
            return Err(self.fail(format!("top_m ({top_m}) must be above bottom_m ({bottom_m})")));
        }
        Ok(())
    }

    fn floor(&self, floors: &[i32], floor: i32) -> Result<(), SceneError> {
        if floors.contains(&floor) {
            Ok(())
        } else {
            Err(self.fail(format!("floor {floor} does not exist (floors: {floors:?})")))
        }
    }
}

/// 1-based line number of a byte offset.
fn line_of(text: &str, offset: usize) -> usize {
    text.as_bytes()[..offset.min(text.len())].iter().filter(|&&b| b == b'\n').count() + 1
}

fn item_name(table: &str, index: usize, label: &str) -> String {
    if label.is_empty() {
        format!("{table}[{index}]")
    } else {
        format!("{table}[{index}] \"{label}\"")
    }
}

/// Parses and checks a scene. `origin` names the text in errors (a path, `builtin:x`).
pub fn parse_scene(text: &str, origin: &str) -> Result<SceneFile, SceneError> {
    let scene: SceneFile = toml::from_str(text).map_err(|e| SceneError::Syntax {
        origin: origin.to_string(),
        line: e.span().map(|s| line_of(text, s.start)).unwrap_or(0),
        message: e.message().trim().to_string(),
    })?;
    validate(&scene, text, origin)?;
    Ok(scene)
}

/// Floor indexes the scene declares (floor 0 alone when it declares none).
pub fn floor_indexes(scene: &SceneFile) -> Vec<i32> {
    if scene.floors.is_empty() {
        vec![0]
    } else {
        scene.floors.iter().map(|f| f.get_ref().index).collect()
    }
}

fn validate(scene: &SceneFile, text: &str, origin: &str) -> Result<(), SceneError> {
    let check = |span: std::ops::Range<usize>, item: String| Check { origin, text, span, item };
    let floors = floor_indexes(scene);

    for (i, f) in scene.floors.iter().enumerate() {
        let c = check(f.span(), item_name("floors", i, &f.get_ref().name));
        c.finite("elevation_m", &[f.get_ref().elevation_m])?;
        if floors.iter().filter(|&&x| x == f.get_ref().index).count() > 1 {
            return Err(c.fail(format!("floor index {} is declared twice", f.get_ref().index)));
        }
    }
    let s = &scene.start;
    let c = check(s.span(), "start".into());
    c.finite("x_m/y_m/yaw_deg", &[s.get_ref().x_m, s.get_ref().y_m, s.get_ref().yaw_deg])?;
    c.floor(&floors, s.get_ref().floor)?;
    let g = &scene.goal;
    let c = check(g.span(), "goal".into());
    c.finite("x_m/y_m", &[g.get_ref().x_m, g.get_ref().y_m])?;
    c.floor(&floors, g.get_ref().floor)?;

    for (i, w) in scene.walls.iter().enumerate() {
        let v = w.get_ref();
        let c = check(w.span(), item_name("walls", i, &v.label));
        c.floor(&floors, v.floor)?;
        c.finite("from/to", &[v.from[0], v.from[1], v.to[0], v.to[1]])?;
        c.positive("height_m", v.height_m)?;
        c.positive("thickness_m", v.thickness_m)?;
        if (v.to[0] - v.from[0]).hypot(v.to[1] - v.from[1]) < 1e-3 {
            return Err(c.fail("from and to are the same point: a wall needs a length".into()));
        }
    }
    for (i, b) in scene.boxes.iter().enumerate() {
        let v = b.get_ref();
        let c = check(b.span(), item_name("boxes", i, &v.label));
        c.floor(&floors, v.floor)?;
        c.finite("center/yaw_deg", &[v.center[0], v.center[1], v.yaw_deg])?;
        c.positive("size_m[0]", v.size_m[0])?;
        c.positive("size_m[1]", v.size_m[1])?;
        c.above(v.bottom_m, v.top_m)?;
    }
    for (i, cy) in scene.cylinders.iter().enumerate() {
        let v = cy.get_ref();
        let c = check(cy.span(), item_name("cylinders", i, &v.label));
        c.floor(&floors, v.floor)?;
        c.finite("center", &v.center)?;
        c.positive("radius_m", v.radius_m)?;
        c.above(v.bottom_m, v.top_m)?;
    }
    for (i, p) in scene.poles.iter().enumerate() {
        let v = p.get_ref();
        let c = check(p.span(), item_name("poles", i, &v.label));
        c.floor(&floors, v.floor)?;
        c.finite("center", &v.center)?;
        c.positive("radius_m", v.radius_m)?;
        c.positive("height_m", v.height_m)?;
    }
    for (i, t) in scene.tables.iter().enumerate() {
        let v = t.get_ref();
        let c = check(t.span(), item_name("tables", i, &v.label));
        c.floor(&floors, v.floor)?;
        c.finite("center/yaw_deg", &[v.center[0], v.center[1], v.yaw_deg])?;
        c.positive("size_m[0]", v.size_m[0])?;
        c.positive("size_m[1]", v.size_m[1])?;
        c.positive("top_thickness_m", v.top_thickness_m)?;
        c.positive("leg_radius_m", v.leg_radius_m)?;
        if v.height_m <= v.top_thickness_m {
            return Err(
                c.fail(format!("height_m ({}) must exceed top_thickness_m ({})", v.height_m, v.top_thickness_m))
            );
        }
        if v.size_m[0].min(v.size_m[1]) < 2.0 * (LEG_INSET_M + v.leg_radius_m) {
            return Err(c.fail("top is too small for its legs".into()));
        }
    }
    for (i, ch) in scene.chairs.iter().enumerate() {
        let v = ch.get_ref();
        let c = check(ch.span(), item_name("chairs", i, &v.label));
        c.floor(&floors, v.floor)?;
        c.finite("center/yaw_deg", &[v.center[0], v.center[1], v.yaw_deg])?;
        c.positive("seat_size_m", v.seat_size_m)?;
        c.positive("seat_height_m", v.seat_height_m)?;
        if v.back_height_m <= v.seat_height_m {
            return Err(c.fail(format!(
                "back_height_m ({}) must be above seat_height_m ({})",
                v.back_height_m, v.seat_height_m
            )));
        }
    }
    for (i, h) in scene.hanging.iter().enumerate() {
        let v = h.get_ref();
        let c = check(h.span(), item_name("hanging", i, &v.label));
        c.floor(&floors, v.floor)?;
        c.finite("center/yaw_deg", &[v.center[0], v.center[1], v.yaw_deg])?;
        c.positive("size_m[0]", v.size_m[0])?;
        c.positive("size_m[1]", v.size_m[1])?;
        c.above(v.bottom_m, v.top_m)?;
        if v.bottom_m <= 0.0 {
            return Err(c.fail("a hanging obstacle must have bottom_m > 0 (use [[boxes]] for one on the floor)".into()));
        }
    }
    for (i, r) in scene.floor_regions.iter().enumerate() {
        let v = r.get_ref();
        let c = check(r.span(), item_name("floor_regions", i, &v.label));
        c.floor(&floors, v.floor)?;
        c.finite("center/yaw_deg/height_m", &[v.center[0], v.center[1], v.yaw_deg, v.height_m])?;
        c.positive("size_m[0]", v.size_m[0])?;
        c.positive("size_m[1]", v.size_m[1])?;
        if v.height_m == 0.0 {
            return Err(c.fail("height_m must be non-zero (> 0 step up, < 0 drop-off)".into()));
        }
    }
    for (i, p) in scene.people.iter().enumerate() {
        let v = p.get_ref();
        let c = check(p.span(), item_name("people", i, &v.label));
        c.floor(&floors, v.floor)?;
        if v.waypoints.len() < 2 {
            return Err(c.fail(format!("a walking person needs at least 2 waypoints, got {}", v.waypoints.len())));
        }
        for w in &v.waypoints {
            c.finite("waypoints", w)?;
        }
        if path_length_m(&v.waypoints) < 1e-3 {
            return Err(c.fail("waypoints do not span any distance".into()));
        }
        c.positive("speed_m_s", v.speed_m_s)?;
        c.positive("radius_m", v.radius_m)?;
        c.positive("height_m", v.height_m)?;
        c.finite("phase_s", &[v.phase_s])?;
    }
    for (i, d) in scene.doors.iter().enumerate() {
        let v = d.get_ref();
        let c = check(d.span(), item_name("doors", i, &v.number));
        c.floor(&floors, v.floor)?;
        c.finite("at/facing_deg", &[v.at[0], v.at[1], v.facing_deg])?;
        c.positive("width_m", v.width_m)?;
        if v.number.trim().is_empty() {
            return Err(c.fail("number must not be empty".into()));
        }
    }
    for (i, k) in scene.corners.iter().enumerate() {
        let v = k.get_ref();
        let c = check(k.span(), item_name("corners", i, &v.label));
        c.floor(&floors, v.floor)?;
        c.finite("at", &v.at)?;
    }
    for (i, r) in scene.rooms.iter().enumerate() {
        let v = r.get_ref();
        let c = check(r.span(), item_name("rooms", i, &v.label));
        c.floor(&floors, v.floor)?;
        c.finite("min/max", &[v.min[0], v.min[1], v.max[0], v.max[1]])?;
        if v.max[0] <= v.min[0] || v.max[1] <= v.min[1] {
            return Err(c.fail(format!("max {:?} must be above min {:?} on both axes", v.max, v.min)));
        }
    }
    for (i, e) in scene.elevators.iter().enumerate() {
        let v = e.get_ref();
        let c = check(e.span(), item_name("elevators", i, &v.label));
        c.finite("at", &v.at)?;
        if v.floors.len() < 2 {
            return Err(c.fail("an elevator must serve at least two floors".into()));
        }
        for f in &v.floors {
            c.floor(&floors, *f)?;
        }
    }
    for (i, s) in scene.stairs.iter().enumerate() {
        let v = s.get_ref();
        let c = check(s.span(), item_name("stairs", i, &v.label));
        c.floor(&floors, v.from_floor)?;
        c.floor(&floors, v.to_floor)?;
        c.finite("start/yaw_deg", &[v.start[0], v.start[1], v.yaw_deg])?;
        c.positive("tread_m", v.tread_m)?;
        c.positive("width_m", v.width_m)?;
        if v.steps == 0 {
            return Err(c.fail("steps must be at least 1".into()));
        }
        let rise = elevation_of(scene, v.to_floor) - elevation_of(scene, v.from_floor);
        if rise <= 0.0 {
            return Err(c.fail(format!(
                "to_floor {} must be above from_floor {} (elevation difference {rise} m)",
                v.to_floor, v.from_floor
            )));
        }
    }
    if let Some(w) = &scene.walker {
        let v = w.get_ref();
        let c = check(w.span(), "walker".into());
        for p in &v.waypoints {
            c.finite("waypoints", p)?;
        }
        c.positive("speed_m_s", v.speed_m_s)?;
        c.positive("turn_rate_deg_s", v.turn_rate_deg_s)?;
    }
    if let Some(e) = &scene.plan_extent {
        let (v, c) = (e.get_ref(), check(e.span(), "plan_extent".into()));
        c.floor(&floors, v.floor)?;
        c.finite("min", &v.min)?;
        c.finite("max", &v.max)?;
        if v.min[0] >= v.max[0] || v.min[1] >= v.max[1] {
            return Err(c.fail(format!("min {:?} must be below max {:?} in x and in y", v.min, v.max)));
        }
        let (start, goal) = (scene.start.get_ref(), scene.goal.get_ref());
        let ends = [("start", start.floor, [start.x_m, start.y_m]), ("goal", goal.floor, [goal.x_m, goal.y_m])];
        for (name, floor, [x, y]) in ends {
            if floor == v.floor && !(v.min[0] <= x && x <= v.max[0] && v.min[1] <= y && y <= v.max[1]) {
                return Err(c.fail(format!("the {name} ({x}, {y}) lies outside it: no route could reach it")));
            }
        }
    }
    if let Some(r) = &scene.floor_plan_route {
        let c = check(r.span(), "floor_plan_route".into());
        for p in &r.get_ref().waypoints {
            c.finite("waypoints", p)?;
        }
        // the route is laid on the walls: none of its legs may go through one (a
        // doorway is a gap between two walls, not a wall)
        let (start, goal) = (scene.start.get_ref(), scene.goal.get_ref());
        let mut points = vec![[start.x_m, start.y_m]];
        points.extend(r.get_ref().waypoints.iter().copied());
        if goal.floor == start.floor {
            points.push([goal.x_m, goal.y_m]);
        }
        for leg in points.windows(2) {
            for (i, w) in scene.walls.iter().map(|w| w.get_ref()).enumerate() {
                if w.floor == start.floor && segment_distance_m(leg[0], leg[1], w.from, w.to) < w.thickness_m / 2.0 {
                    let name = if w.label.is_empty() { String::new() } else { format!(" \"{}\"", w.label) };
                    return Err(c.fail(format!(
                        "the leg from ({}, {}) to ({}, {}) crosses walls[{i}]{name} (line {})",
                        leg[0][0],
                        leg[0][1],
                        leg[1][0],
                        leg[1][1],
                        line_of(text, scene.walls[i].span().start)
                    )));
                }
            }
        }
    }
    Ok(())
}

/// Shortest distance between the segments a0-a1 and b0-b1 in the plane (0 when they
/// cross).
fn segment_distance_m(a0: [f64; 2], a1: [f64; 2], b0: [f64; 2], b1: [f64; 2]) -> f64 {
    let cross = |o: [f64; 2], p: [f64; 2], q: [f64; 2]| (p[0] - o[0]) * (q[1] - o[1]) - (p[1] - o[1]) * (q[0] - o[0]);
    let (d1, d2) = (cross(b0, b1, a0), cross(b0, b1, a1));
    let (d3, d4) = (cross(a0, a1, b0), cross(a0, a1, b1));
    if d1 * d2 < 0.0 && d3 * d4 < 0.0 {
        return 0.0;
    }
    let point_to = |p: [f64; 2], s0: [f64; 2], s1: [f64; 2]| {
        let (dx, dy) = (s1[0] - s0[0], s1[1] - s0[1]);
        let len2 = dx * dx + dy * dy;
        let t = if len2 > 0.0 { (((p[0] - s0[0]) * dx + (p[1] - s0[1]) * dy) / len2).clamp(0.0, 1.0) } else { 0.0 };
        (p[0] - s0[0] - t * dx).hypot(p[1] - s0[1] - t * dy)
    };
    point_to(a0, b0, b1).min(point_to(a1, b0, b1)).min(point_to(b0, a0, a1)).min(point_to(b1, a0, a1))
}

/// Elevation of a floor index (0 for an undeclared floor 0).
pub fn elevation_of(scene: &SceneFile, floor: i32) -> f64 {
    scene.floors.iter().find(|f| f.get_ref().index == floor).map(|f| f.get_ref().elevation_m).unwrap_or(0.0)
}

/// Length of a polyline, metres.
pub fn path_length_m(points: &[[f64; 2]]) -> f64 {
    points.windows(2).map(|w| (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1])).sum()
}

/// Distance of a table's legs from the edges of its top, metres.
pub const LEG_INSET_M: f64 = 0.05;

#[cfg(test)]
mod tests {
    use super::*;

    const HEAD: &str = "name = \"t\"\nstart = { x_m = 0.0, y_m = 0.0 }\ngoal = { x_m = 1.0, y_m = 0.0 }\n";

    #[test]
    fn unknown_field_is_refused_with_its_line() {
        let text =
            format!("{HEAD}\n[[cylinders]]\ncenter = [1.0, 1.0]\nradius_m = 0.2\ntop_m = 1.0\ncolour = \"red\"\n");
        let err = parse_scene(&text, "room.toml").unwrap_err();
        match &err {
            SceneError::Syntax { line, message, .. } => {
                assert_eq!(*line, 9, "{err}");
                assert!(message.contains("unknown field `colour`"), "{err}");
            }
            other => panic!("expected a syntax error, got {other}"),
        }
        assert!(err.to_string().starts_with("room.toml:9: "), "{err}");
    }

    #[test]
    fn negative_radius_names_the_item_line_and_reason() {
        let text = format!(
            "{HEAD}\n[[cylinders]]\ncenter = [1.0, 1.0]\nradius_m = 0.2\ntop_m = 1.0\n\n[[cylinders]]\nlabel = \"bin\"\ncenter = [2.0, 1.0]\nradius_m = -0.2\ntop_m = 1.0\n"
        );
        let err = parse_scene(&text, "room.toml").unwrap_err();
        match &err {
            SceneError::Invalid { line, item, reason, .. } => {
                assert_eq!(*line, 10, "{err}");
                assert_eq!(item, "cylinders[1] \"bin\"");
                assert!(reason.contains("radius_m must be > 0, got -0.2"), "{err}");
            }
            other => panic!("expected an invalid-shape error, got {other}"),
        }
    }

    #[test]
    fn hanging_obstacle_on_the_floor_is_refused() {
        let text =
            format!("{HEAD}[[hanging]]\ncenter = [1.0, 1.0]\nsize_m = [0.5, 0.5]\nbottom_m = 0.0\ntop_m = 1.0\n");
        let err = parse_scene(&text, "x").unwrap_err();
        assert!(err.to_string().contains("hanging[0]: a hanging obstacle must have bottom_m > 0"), "{err}");
        assert!(err.to_string().starts_with("x:4: "), "{err}");
    }

    #[test]
    fn item_on_missing_floor_and_inverted_heights_are_refused() {
        let text = format!("{HEAD}[[boxes]]\nfloor = 3\ncenter = [1.0, 1.0]\nsize_m = [0.5, 0.5]\ntop_m = 1.0\n");
        assert!(parse_scene(&text, "x").unwrap_err().to_string().contains("floor 3 does not exist"));
        let text = format!("{HEAD}[[boxes]]\ncenter = [1.0, 1.0]\nsize_m = [0.5, 0.5]\nbottom_m = 1.0\ntop_m = 0.5\n");
        assert!(parse_scene(&text, "x").unwrap_err().to_string().contains("top_m (0.5) must be above bottom_m (1)"));
    }

    #[test]
    fn example_scene_of_the_worlds_readme_loads() {
        let readme = include_str!("../../worlds/README.md");
        let example = readme
            .split("## Example")
            .nth(1)
            .and_then(|rest| rest.split("```toml").nth(1))
            .and_then(|block| block.split("```").next())
            .unwrap_or_else(|| panic!("README has no toml example"));
        let scene = parse_scene(example, "README.md").unwrap_or_else(|e| panic!("{e}"));
        assert_eq!((scene.walls.len(), scene.hanging.len(), scene.floor_regions.len()), (1, 1, 1));
    }

    #[test]
    fn a_floor_plan_route_through_a_wall_is_refused_with_both_lines_and_one_through_a_doorway_is_not() {
        // a wall across the way at x = 0.5 from y = -2 to 2, and one with a doorway gap
        // at y -0.5..0.5 (two walls)
        let solid = "[[walls]]\nlabel = \"partition\"\nfrom = [0.5, -2.0]\nto = [0.5, 2.0]\n";
        let gap = "[[walls]]\nfrom = [0.5, -2.0]\nto = [0.5, -0.5]\n[[walls]]\nfrom = [0.5, 0.5]\nto = [0.5, 2.0]\n";
        let route = "[floor_plan_route]\nwaypoints = [[0.2, 0.0], [0.8, 0.1]]\n";
        let err = parse_scene(&format!("{HEAD}{solid}{route}"), "x").unwrap_err().to_string();
        assert!(
            err.starts_with(
                "x:8: floor_plan_route: the leg from (0.2, 0) to (0.8, 0.1) crosses walls[0] \"partition\" (line 4)"
            ),
            "{err}"
        );
        assert!(parse_scene(&format!("{HEAD}{gap}{route}"), "x").is_ok());
        // the leg from the last waypoint to the goal is a leg too
        let last = "[floor_plan_route]\nwaypoints = [[0.0, 1.0]]\n";
        let err = parse_scene(&format!("{HEAD}{solid}{last}"), "x").unwrap_err().to_string();
        assert!(err.contains("the leg from (0, 1) to (1, 0) crosses"), "{err}");
        // round the wall's end: no leg crosses it
        let around = "[floor_plan_route]\nwaypoints = [[0.0, 3.0], [1.0, 3.0]]\n";
        assert!(parse_scene(&format!("{HEAD}{solid}{around}"), "x").is_ok());
        assert_eq!(segment_distance_m([0.0, 0.0], [1.0, 0.0], [0.5, 0.3], [0.5, 1.0]), 0.3);
        assert_eq!(segment_distance_m([0.0, 0.0], [1.0, 1.0], [0.0, 1.0], [1.0, 0.0]), 0.0);
    }

    #[test]
    fn floor_plan_route_loads_and_a_point_that_is_not_a_number_is_refused() {
        let scene = parse_scene(&format!("{HEAD}[floor_plan_route]\nwaypoints = [[0.5, 1.0], [1.0, 1.0]]\n"), "x")
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(scene.floor_plan_route.map(|r| r.into_inner().waypoints), Some(vec![[0.5, 1.0], [1.0, 1.0]]));
        let err = parse_scene(&format!("{HEAD}[floor_plan_route]\nwaypoints = [[0.5, nan]]\n"), "x").unwrap_err();
        assert!(err.to_string().starts_with("x:4: floor_plan_route"), "{err}");
    }

    #[test]
    fn a_plan_extent_loads_and_one_that_is_empty_leaves_out_the_goal_or_names_no_floor_is_refused() {
        let extent = |body: &str| parse_scene(&format!("{HEAD}[plan_extent]\n{body}\n"), "x");
        let scene = extent("min = [-0.5, -0.5]\nmax = [1.5, 0.5]").unwrap_or_else(|e| panic!("{e}"));
        let e = scene.plan_extent.map(|e| e.into_inner()).unwrap_or_else(|| panic!("no extent"));
        assert_eq!((e.floor, e.min, e.max), (0, [-0.5, -0.5], [1.5, 0.5]));
        for (body, reason) in [
            ("min = [1.0, -0.5]\nmax = [1.0, 0.5]", "min [1.0, -0.5] must be below max [1.0, 0.5] in x and in y"),
            ("min = [-0.5, -0.5]\nmax = [0.5, 0.5]", "the goal (1, 0) lies outside it: no route could reach it"),
            ("min = [-0.5, nan]\nmax = [1.5, 0.5]", "min must be finite"),
            ("floor = 2\nmin = [-0.5, -0.5]\nmax = [1.5, 0.5]", "floor 2 does not exist"),
        ] {
            let err = extent(body).unwrap_err().to_string();
            assert!(err.starts_with("x:4: plan_extent: ") && err.contains(reason), "{body}: {err}");
        }
    }

    #[test]
    fn wrong_type_is_a_syntax_error_with_line() {
        let text = format!("{HEAD}[[poles]]\ncenter = [1.0, 1.0]\nheight_m = \"tall\"\n");
        let err = parse_scene(&text, "x").unwrap_err();
        assert!(matches!(err, SceneError::Syntax { line: 6, .. }), "{err}");
    }
}

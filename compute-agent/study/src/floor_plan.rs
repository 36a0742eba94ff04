//! A simulated world as the plan of its building (issue 31, `wearnav map`): per floor a
//! ROS occupancy grid of the walls and a semantic layer (rooms, numbered doors, corners,
//! the goal, elevators and stairs as gateways), the map a route planner gets instead of
//! hand-written routes. Floor plan only, as an architect's plan shows it: no furniture
//! (boxes, cylinders, poles, tables, chairs, hanging obstacles) and no people; those are
//! for the camera and the cane to find.
//!
//! The manifest gives each floor's height (`elevation_m`, the world's), by which a
//! barometer tells the floors apart. What each element of the world becomes:
//!
//! | world | grid | semantic layer |
//! | --- | --- | --- |
//! | wall | occupied, footprint rasterised exactly (see below) | |
//! | drop-off (`floor_regions` below the floor) | occupied | |
//! | step up (`floor_regions` above the floor) | occupied | |
//! | stairs, lower floor | the flight occupied | gateway stop [`STAIR_APPROACH_M`] before the first step |
//! | stairs, upper floor | the opening occupied | gateway stop [`STAIR_APPROACH_M`] past the top step |
//! | elevator | | gateway, a stop at `at` (where one stands to enter) on each floor |
//! | room | | area (rectangle; nested rooms get the smallest enclosing one as parent) and a label |
//! | door | nothing: the worlds' doors are signs on continuous walls | numbered door, normal = its facing |
//! | corner | | corner (the format has no name for it) |
//! | goal | | label (its name, or `goal`), listed first |
//! | furniture, hanging, people | free | |
//! | free floor beyond the scene's `[plan_extent]` | unknown | |
//!
//! Changes of floor level are occupied: a route for a blind walker goes round a step or
//! a hole when the plan has a way round (the `step-down` world's own walk does), and a
//! stair is taken only as a gateway, never crossed on the level. Doors are not cut into
//! walls because the simulated walls have none: a route through a doorway the simulated
//! user cannot walk through would be a route the study cannot follow.
//!
//! Rasterisation: a cell is occupied when its centre lies in the footprint, when the
//! footprint's centre line (along its longer side) passes through it, or when the
//! footprint is thinner than a cell's diagonal and overlaps it; so a wall of any
//! thickness and angle is a 4-connected band along its whole length, never with a gap.
//! Everything else in the grid is free, but for what lies beyond the scene's
//! `[plan_extent]` (a generated street's: the pavement's ends, past the kerb): the
//! building's plan does not cover it, so it is unknown, and no route is laid there.
//! The grid covers everything on the floor (walls, openings, rooms, doors, corners,
//! gateway stops, start and goal) with [`MARGIN_M`] around it, its cells aligned on
//! multiples of the resolution.

use std::path::Path;

use map::{
    Area, Building, Cell, Corner, Door, Floor, Gateway, GatewayKind, GatewayStop, Label, MapError, OccupancyGrid,
    Origin, SemanticLayer, MAX_RESOLUTION_M,
};
use sim::scene::{RoomSpec, StairsSpec};
use sim::{ObstacleId, ObstacleKind, World};

/// Grid resolution of `wearnav map` unless told otherwise, metres per cell (5 cm: what
/// ROS `map_saver` writes for a typical laser map; a 0.05 m wall is one to two cells).
pub const DEFAULT_RESOLUTION_M: f64 = 0.05;

/// Free floor kept around everything on a floor, metres: room for the planner's
/// clearance (0.3 m) and its snap radius (1 m) round the outermost walls and points.
pub const MARGIN_M: f64 = 1.0;

/// Where one stands to take a flight of stairs, metres from its first step (lower floor)
/// or its top step (upper floor) along the climb: one stride, where a cane user stops
/// to find the first riser and the handrail.
pub const STAIR_APPROACH_M: f64 = 0.5;

/// The map the particle filter localizes on.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum LocalizationMap {
    /// The floor plan `wearnav map` exports: walls, no furniture (an architect's plan).
    #[default]
    FloorPlan,
    /// What a mapping run would record: the floor plan and the furniture and hanging
    /// obstacles in the cane camera's obstacle band; no people, no chairs
    /// ([`export_as_mapped`]).
    Mapped,
}

impl LocalizationMap {
    /// This map of `world`; `perception` gives the obstacle band for [`Self::Mapped`].
    pub fn export(
        self,
        world: &World,
        resolution_m: f64,
        perception: &perception::PerceptionConfig,
    ) -> Result<Building, FloorPlanError> {
        match self {
            Self::FloorPlan => export(world, resolution_m),
            Self::Mapped => {
                let s = &perception.scan;
                export_as_mapped(world, resolution_m, [s.min_obstacle_height_m as f64, s.max_obstacle_height_m as f64])
            }
        }
    }
}

/// Why a world could not be exported.
#[derive(Debug, thiserror::Error)]
pub enum FloorPlanError {
    /// The resolution is not a number in (0, 10] metres.
    #[error("resolution {resolution_m} m/cell is absurd: give a number in (0, {MAX_RESOLUTION_M}] (default {DEFAULT_RESOLUTION_M})")]
    Resolution {
        /// the value given
        resolution_m: f64,
    },
    /// A floor's grid could not be made (too many cells at this resolution).
    #[error("world `{world}`, floor {floor}: {source}; try a coarser resolution")]
    Grid {
        /// world name
        world: String,
        /// floor index
        floor: i32,
        /// the map crate's reason
        source: MapError,
    },
    /// The semantic layer is not one the map crate would load (two doors with one
    /// number on a floor, two rooms with one name, ...).
    #[error("world `{world}`, floor {floor}: {source}; fix the scene file")]
    Semantic {
        /// world name
        world: String,
        /// floor index
        floor: i32,
        /// the map crate's reason
        source: MapError,
    },
    /// The floors do not make a building (a gateway described two ways).
    #[error("world `{world}`: {source}; fix the scene file")]
    Building {
        /// world name
        world: String,
        /// the map crate's reason
        source: MapError,
    },
}

/// The floor plan of `world` at `resolution_m` metres per cell: one floor per
/// [`World::floors`] entry (level = floor index), grid and semantic layer as the module
/// doc says. The semantic layers are checked as [`SemanticLayer::load`] would check them,
/// so what [`Building::write`] writes, [`Building::load`] reads back.
pub fn export(world: &World, resolution_m: f64) -> Result<Building, FloorPlanError> {
    export_with(world, resolution_m, None)
}

/// The map a mapping run would record of `world` (what a robot or a surveyor's depth
/// camera leaves in a ROS `map_saver` grid): the floor plan of [`export`] and, occupied
/// too, every part of the furniture and hanging obstacles that reaches into the height
/// band `band_m` above the floor (the cane camera's obstacle band); people are left out,
/// as a mapping run's filters leave out what moves, and chairs, which are moved between
/// a mapping run and a walk. The particle filter's map with `--map mapped`
/// (docs/localization.md): with walls alone, most of what the cane camera sees in a
/// furnished room is not on the map.
pub fn export_as_mapped(world: &World, resolution_m: f64, band_m: [f64; 2]) -> Result<Building, FloorPlanError> {
    export_with(world, resolution_m, Some(band_m))
}

fn export_with(
    world: &World,
    resolution_m: f64,
    furniture_band_m: Option<[f64; 2]>,
) -> Result<Building, FloorPlanError> {
    if !(resolution_m > 0.0 && resolution_m <= MAX_RESOLUTION_M) {
        return Err(FloorPlanError::Resolution { resolution_m });
    }
    let gateways = gateways(world);
    let mut floors = Vec::with_capacity(world.floors().len());
    for geometry in world.floors() {
        let level = geometry.index;
        let grid_err = |source| FloorPlanError::Grid { world: world.name().to_string(), floor: level, source };
        let mut grid = empty_grid(world, &gateways, level, resolution_m).map_err(grid_err)?;
        for (b, id) in &geometry.boxes {
            let kind = world.obstacle(*id).map(|o| o.kind);
            if matches!(kind, Some(ObstacleKind::Wall | ObstacleKind::Stairs | ObstacleKind::Step)) {
                occupy(&mut grid, Footprint { center_m: b.center_m, half_size_m: b.half_size_m, yaw_rad: b.yaw_rad });
            }
        }
        for (d, _) in &geometry.drop_offs {
            occupy(&mut grid, Footprint { center_m: d.center_m, half_size_m: d.half_size_m, yaw_rad: d.yaw_rad });
        }
        if let Some([low, high]) = furniture_band_m {
            // chairs are moved between a mapping run and a walk: not on the map
            let kept = |id: &ObstacleId, bottom: f64, top: f64| {
                bottom < high && top > low && world.obstacle(*id).is_some_and(|o| o.kind != ObstacleKind::Chair)
            };
            for (b, _) in geometry.boxes.iter().filter(|(b, id)| kept(id, b.bottom_m, b.top_m)) {
                occupy(&mut grid, Footprint { center_m: b.center_m, half_size_m: b.half_size_m, yaw_rad: b.yaw_rad });
            }
            for (c, _) in geometry.cylinders.iter().filter(|(c, id)| kept(id, c.bottom_m, c.top_m)) {
                let r = c.radius_m;
                occupy(&mut grid, Footprint { center_m: c.center_m, half_size_m: [r, r], yaw_rad: 0.0 });
            }
        }
        if let Some(extent) = world.plan_extent(level) {
            unknown_beyond(&mut grid, extent);
        }
        let layer = semantic_layer(world, &gateways, level, &grid);
        // checked as a loaded file is (door numbers unique, areas well formed, ...)
        let name = format!("{}:floor{level}", world.name());
        let semantic = SemanticLayer::parse(&layer.to_toml(), Path::new(&name))
            .map_err(|source| FloorPlanError::Semantic { world: world.name().to_string(), floor: level, source })?;
        floors.push(Floor { level, grid, semantic });
    }
    // each floor's height, as the building's plans give it (a barometer tells floors by it)
    let elevations: Vec<(i32, f64)> = world.floors().iter().map(|f| (f.index, f.elevation_m)).collect();
    Building::new(floors, Path::new(world.name()))
        .and_then(|b| b.with_elevations(&elevations, Path::new(world.name())))
        .map_err(|source| FloorPlanError::Building { world: world.name().to_string(), source })
}

/// Overlaps thinner than this are touches, metres (a nanometre: far below any cell,
/// far above the rounding of map coordinates).
const TOUCH_M: f64 = 1e-9;

/// A rectangle on the floor: centre, half sizes along its own axes, turn.
#[derive(Debug, Clone, Copy)]
struct Footprint {
    center_m: [f64; 2],
    half_size_m: [f64; 2],
    yaw_rad: f64,
}

impl Footprint {
    /// Half extents of its axis-aligned bounds.
    fn extent_m(&self) -> [f64; 2] {
        let (s, c) = self.yaw_rad.sin_cos();
        let [hx, hy] = self.half_size_m;
        [(c * hx).abs() + (s * hy).abs(), (s * hx).abs() + (c * hy).abs()]
    }

    /// A map point in the footprint's own frame.
    fn local(&self, x_m: f64, y_m: f64) -> [f64; 2] {
        let (s, c) = self.yaw_rad.sin_cos();
        let (dx, dy) = (x_m - self.center_m[0], y_m - self.center_m[1]);
        [c * dx + s * dy, -s * dx + c * dy]
    }

    /// Its centre line along the longer side, as a footprint of no width.
    fn centre_line(&self) -> Footprint {
        let [hx, hy] = self.half_size_m;
        Footprint { half_size_m: if hx >= hy { [hx, 0.0] } else { [0.0, hy] }, ..*self }
    }

    /// Whether it overlaps the open axis-aligned square of half side `h` at (x, y) with
    /// positive area (or, for a centre line, positive length): no separating axis among
    /// the map's and the footprint's own (a touch along an edge is no overlap).
    fn overlaps_square(&self, x_m: f64, y_m: f64, h: f64) -> bool {
        let [ex, ey] = self.extent_m();
        let [lx, ly] = self.local(x_m, y_m);
        let (s, c) = self.yaw_rad.sin_cos();
        // a touch within rounding (a wall ending on a cell edge) is no overlap either
        let square_radius = h * (c.abs() + s.abs()) - TOUCH_M;
        (x_m - self.center_m[0]).abs() < h + ex - TOUCH_M
            && (y_m - self.center_m[1]).abs() < h + ey - TOUCH_M
            && lx.abs() < self.half_size_m[0] + square_radius
            && ly.abs() < self.half_size_m[1] + square_radius
    }
}

/// Marks the free cells whose centre lies outside `extent` (min and max corners)
/// unknown: what the building's plan does not cover.
fn unknown_beyond(grid: &mut OccupancyGrid, (min, max): ([f64; 2], [f64; 2])) {
    for row in 0..grid.height() {
        for col in 0..grid.width() {
            let (x, y) = grid.cell_center(col, row);
            let inside = min[0] <= x && x <= max[0] && min[1] <= y && y <= max[1];
            if !inside && grid.get(col, row) == Some(Cell::Free) {
                grid.set(col, row, Cell::Unknown);
            }
        }
    }
}

/// Marks the cells of `f` occupied (the module doc's rule).
fn occupy(grid: &mut OccupancyGrid, f: Footprint) {
    let res = grid.resolution_m();
    let thin = 2.0 * f.half_size_m[0].min(f.half_size_m[1]) < res * std::f64::consts::SQRT_2;
    let line = f.centre_line();
    let [ex, ey] = f.extent_m();
    let (lo_c, lo_r) = grid.world_to_grid(f.center_m[0] - ex, f.center_m[1] - ey);
    let (hi_c, hi_r) = grid.world_to_grid(f.center_m[0] + ex, f.center_m[1] + ey);
    // one cell beyond the bounds each way; the grid covers every footprint, clamp anyway
    let clamp = |v: f64, n: usize| (v.floor() as i64).clamp(0, n as i64 - 1) as usize;
    let (c0, c1) = (clamp(lo_c - 1.0, grid.width()), clamp(hi_c + 1.0, grid.width()));
    let (r0, r1) = (clamp(lo_r - 1.0, grid.height()), clamp(hi_r + 1.0, grid.height()));
    for row in r0..=r1 {
        for col in c0..=c1 {
            let (x, y) = grid.cell_center(col, row);
            let [lx, ly] = f.local(x, y);
            let centre_in = lx.abs() <= f.half_size_m[0] && ly.abs() <= f.half_size_m[1];
            if centre_in || line.overlaps_square(x, y, res / 2.0) || (thin && f.overlaps_square(x, y, res / 2.0)) {
                grid.set(col, row, Cell::Occupied);
            }
        }
    }
}

/// An all-free grid over everything on floor `level`, with the margin.
fn empty_grid(world: &World, gateways: &[Gateway], level: i32, res: f64) -> Result<OccupancyGrid, MapError> {
    let mut points: Vec<[f64; 2]> = Vec::new();
    let geometry = world.geometry(level);
    let footprints = geometry
        .boxes
        .iter()
        .map(|(b, _)| Footprint { center_m: b.center_m, half_size_m: b.half_size_m, yaw_rad: b.yaw_rad })
        .chain(geometry.drop_offs.iter().map(|(d, _)| Footprint {
            center_m: d.center_m,
            half_size_m: d.half_size_m,
            yaw_rad: d.yaw_rad,
        }));
    // every box is taken, furniture too: the plan then covers the same floor the world does
    for f in footprints {
        let [ex, ey] = f.extent_m();
        points.push([f.center_m[0] - ex, f.center_m[1] - ey]);
        points.push([f.center_m[0] + ex, f.center_m[1] + ey]);
    }
    for r in world.rooms().iter().filter(|r| r.floor == level) {
        points.extend([r.min, r.max]);
    }
    points.extend(world.doors().iter().filter(|d| d.floor == level).map(|d| d.at));
    points.extend(world.corners().iter().filter(|c| c.floor == level).map(|c| c.at));
    points.extend(gateways.iter().filter_map(|g| g.stop(level)).map(|s| [s.x, s.y]));
    let (start, goal) = (world.start(), world.goal());
    if start.floor == level {
        points.push([start.x_m, start.y_m]);
    }
    if goal.floor == level {
        points.push([goal.x_m, goal.y_m]);
    }
    if points.is_empty() {
        // a floor with nothing on it: a margin round its origin
        points.push([0.0, 0.0]);
    }
    let lo = points.iter().fold([f64::INFINITY; 2], |m, p| [m[0].min(p[0]), m[1].min(p[1])]);
    let hi = points.iter().fold([f64::NEG_INFINITY; 2], |m, p| [m[0].max(p[0]), m[1].max(p[1])]);
    let origin_x = ((lo[0] - MARGIN_M) / res).floor() * res;
    let origin_y = ((lo[1] - MARGIN_M) / res).floor() * res;
    let width = ((hi[0] + MARGIN_M - origin_x) / res).ceil().max(1.0);
    let height = ((hi[1] + MARGIN_M - origin_y) / res).ceil().max(1.0);
    // refused by the map crate's size limit before anything is allocated
    let cells = |n: f64| if n < u32::MAX as f64 { n as usize } else { u32::MAX as usize };
    let origin = Origin { x_m: origin_x, y_m: origin_y, yaw_rad: 0.0 };
    OccupancyGrid::filled(cells(width), cells(height), res, origin, Cell::Free)
}

/// Every elevator and flight of stairs as a gateway, stops where one stands to take it.
fn gateways(world: &World) -> Vec<Gateway> {
    let elevators = world.elevators().iter().map(|e| Gateway {
        name: e.label.clone(),
        kind: GatewayKind::Elevator,
        stops: e.floors.iter().map(|&floor| GatewayStop { floor, x: e.at[0], y: e.at[1] }).collect(),
    });
    let stairs = world.stairs().iter().map(|s| {
        let (foot, top) = stair_stops(s);
        Gateway {
            name: s.label.clone(),
            kind: GatewayKind::Stairs,
            stops: vec![
                GatewayStop { floor: s.from_floor, x: foot[0], y: foot[1] },
                GatewayStop { floor: s.to_floor, x: top[0], y: top[1] },
            ],
        }
    });
    elevators.chain(stairs).collect()
}

/// Where one stands at the foot of a flight (lower floor) and at its top (upper floor).
pub fn stair_stops(s: &StairsSpec) -> ([f64; 2], [f64; 2]) {
    let (sn, cs) = s.yaw_deg.to_radians().sin_cos();
    let run_m = s.steps as f64 * s.tread_m;
    let at = |along_m: f64| [s.start[0] + cs * along_m, s.start[1] + sn * along_m];
    (at(-STAIR_APPROACH_M), at(run_m + STAIR_APPROACH_M))
}

/// The name of the place where `world`'s walks end on its floor plan: the goal's
/// label, or `goal`.
pub fn goal_label(world: &World) -> String {
    let goal = world.goal();
    if goal.label.trim().is_empty() {
        "goal".to_string()
    } else {
        goal.label.clone()
    }
}

/// The semantic layer of floor `level` (the goal's label first, so a lookup by its name
/// finds where the walk ends).
fn semantic_layer(world: &World, gateways: &[Gateway], level: i32, grid: &OccupancyGrid) -> SemanticLayer {
    // a simulated world's north is its +y axis (as a simulated compass reads it)
    let mut layer = SemanticLayer { north_deg: Some(sim::compass::SIM_NORTH_DEG), ..SemanticLayer::default() };
    let goal = world.goal();
    let goal_name = goal_label(world);
    if goal.floor == level {
        layer.labels.push(Label { name: goal_name.clone(), x: goal.x_m, y: goal.y_m, floor: level });
    }
    let rooms: Vec<&RoomSpec> = world.rooms().iter().filter(|r| r.floor == level).collect();
    for r in &rooms {
        let parent = rooms
            .iter()
            .filter(|p| p.label != r.label && contains(p, r) && area(p) > area(r))
            .min_by(|a, b| area(a).total_cmp(&area(b)))
            .map(|p| p.label.clone());
        layer.areas.push(Area {
            name: r.label.clone(),
            floor: level,
            polygon: vec![[r.min[0], r.min[1]], [r.max[0], r.min[1]], [r.max[0], r.max[1]], [r.min[0], r.max[1]]],
            parent,
        });
        // the goal's label already names this room where the walk ends
        if goal.floor == level && r.label.eq_ignore_ascii_case(&goal_name) {
            continue;
        }
        let [x, y] = free_point_in(grid, r);
        layer.labels.push(Label { name: r.label.clone(), x, y, floor: level });
    }
    for d in world.doors().iter().filter(|d| d.floor == level) {
        let (s, c) = d.facing_deg.to_radians().sin_cos();
        layer.doors.push(Door { number: d.number.clone(), x: d.at[0], y: d.at[1], floor: level, normal: [c, s] });
    }
    for c in world.corners().iter().filter(|c| c.floor == level) {
        layer.corners.push(Corner { x: c.at[0], y: c.at[1], floor: level });
    }
    layer.gateways = gateways.iter().filter(|g| g.stop(level).is_some()).cloned().collect();
    layer
}

fn area(r: &RoomSpec) -> f64 {
    (r.max[0] - r.min[0]).abs() * (r.max[1] - r.min[1]).abs()
}

fn contains(outer: &RoomSpec, inner: &RoomSpec) -> bool {
    outer.min[0] <= inner.min[0]
        && outer.min[1] <= inner.min[1]
        && outer.max[0] >= inner.max[0]
        && outer.max[1] >= inner.max[1]
}

/// The room's centre, or when a wall or an opening covers it, the free cell of the room
/// nearest to it (the centre when the room has none free): a label one can walk to.
fn free_point_in(grid: &OccupancyGrid, r: &RoomSpec) -> [f64; 2] {
    let centre = [(r.min[0] + r.max[0]) / 2.0, (r.min[1] + r.max[1]) / 2.0];
    let cell_at = |x: f64, y: f64| grid.world_to_cell(x, y).and_then(|(c, row)| grid.get(c, row));
    if cell_at(centre[0], centre[1]) != Some(Cell::Occupied) {
        return centre;
    }
    let (Some((c0, r0)), Some((c1, r1))) = (
        grid.world_to_cell(r.min[0].min(r.max[0]), r.min[1].min(r.max[1])),
        grid.world_to_cell(r.min[0].max(r.max[0]), r.min[1].max(r.max[1])),
    ) else {
        return centre;
    };
    let mut best: Option<(f64, [f64; 2])> = None;
    for row in r0..=r1 {
        for col in c0..=c1 {
            if grid.get(col, row) == Some(Cell::Free) {
                let (x, y) = grid.cell_center(col, row);
                let d = (x - centre[0]).hypot(y - centre[1]);
                if best.is_none_or(|(bd, _)| d < bd) {
                    best = Some((d, [x, y]));
                }
            }
        }
    }
    best.map_or(centre, |(_, p)| p)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(res: f64) -> OccupancyGrid {
        let origin = Origin { x_m: -1.0, y_m: -1.0, yaw_rad: 0.0 };
        OccupancyGrid::filled((4.0 / res) as usize, (4.0 / res) as usize, res, origin, Cell::Free).unwrap()
    }

    fn occupied_cells(g: &OccupancyGrid) -> Vec<(usize, usize)> {
        (0..g.height())
            .flat_map(|r| (0..g.width()).map(move |c| (c, r)))
            .filter(|&(c, r)| g.get(c, r) == Some(Cell::Occupied))
            .collect()
    }

    #[test]
    fn railing_thinner_than_a_cell_between_two_rows_occupies_both() {
        // 4 cm thick on the boundary between two 5 cm rows: no cell centre is inside
        let mut g = grid(0.05);
        occupy(&mut g, Footprint { center_m: [0.5, 0.5], half_size_m: [0.5, 0.02], yaw_rad: 0.0 });
        let rows: std::collections::BTreeSet<usize> = occupied_cells(&g).into_iter().map(|(_, r)| r).collect();
        assert_eq!(rows.into_iter().collect::<Vec<_>>(), [29, 30]);
        assert_eq!(g.count(Cell::Occupied), 2 * 20);
    }

    #[test]
    fn thick_wall_occupies_exactly_the_cells_whose_centres_it_covers() {
        // 10 cm thick on a cell boundary, 1 m long from a cell boundary: 2 rows x 20 columns
        let mut g = grid(0.05);
        occupy(&mut g, Footprint { center_m: [0.5, 0.0], half_size_m: [0.5, 0.05], yaw_rad: 0.0 });
        assert_eq!(g.count(Cell::Occupied), 40);
        assert!(occupied_cells(&g).iter().all(|&(c, r)| (20..40).contains(&c) && (19..21).contains(&r)));
    }

    #[test]
    fn thin_wall_at_any_angle_is_four_connected_along_its_length() {
        for deg in [0.0, 7.0, 30.0, 45.0, 62.5, 90.0, 133.0] {
            let mut g = grid(0.05);
            let yaw = f64::to_radians(deg);
            occupy(&mut g, Footprint { center_m: [1.0, 1.0], half_size_m: [1.2, 0.01], yaw_rad: yaw });
            let (s, c) = yaw.sin_cos();
            let mut last: Option<(usize, usize)> = None;
            for i in 0..960 {
                let t = -1.2 + 2.4 * (i as f64 + 0.5) / 960.0;
                let cell = g.world_to_cell(1.0 + c * t, 1.0 + s * t).unwrap();
                assert_eq!(g.get(cell.0, cell.1), Some(Cell::Occupied), "{deg}° at {t}");
                if let Some(prev) = last {
                    let step = prev.0.abs_diff(cell.0) + prev.1.abs_diff(cell.1);
                    // from one cell along the line to the next: a side neighbour, or a
                    // diagonal one with a side neighbour occupied too
                    if step == 2 {
                        let side = [(prev.0, cell.1), (cell.0, prev.1)];
                        assert!(side.iter().any(|&(a, b)| g.get(a, b) == Some(Cell::Occupied)), "{deg}° at {t}");
                    }
                }
                last = Some(cell);
            }
        }
    }

    #[test]
    fn resolution_that_is_not_a_cell_size_is_refused() {
        let w = World::load("approach").unwrap();
        for bad in [0.0, -0.05, f64::NAN, f64::INFINITY, 11.0] {
            assert!(matches!(export(&w, bad), Err(FloorPlanError::Resolution { .. })), "{bad}");
        }
        let e = export(&w, 1e-5).unwrap_err();
        assert!(matches!(e, FloorPlanError::Grid { .. }) && e.to_string().contains("coarser"), "{e}");
    }

    #[test]
    fn two_doors_with_one_number_on_a_floor_are_refused_with_the_reason() {
        let text = "name = \"t\"\nstart = { x_m = 0.0, y_m = 0.0 }\ngoal = { x_m = 1.0, y_m = 0.0 }\n\
                    [[doors]]\nnumber = \"7\"\nat = [0.0, 1.0]\n[[doors]]\nnumber = \"7\"\nat = [1.0, 1.0]\n";
        let w = World::from_toml(text, "t").unwrap();
        let e = export(&w, DEFAULT_RESOLUTION_M).unwrap_err();
        assert!(matches!(e, FloorPlanError::Semantic { floor: 0, .. }) && e.to_string().contains("twice"), "{e}");
    }
}

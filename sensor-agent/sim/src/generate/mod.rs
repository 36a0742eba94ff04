//! Generated worlds (`gen:<kind>:<seed>`): scenes nobody tuned the cues on, for the
//! virtual user study (issue 29). Each kind holds the obstacles orientation-and-mobility
//! instructors teach cane users to expect (protruding objects above the cane's reach,
//! overhangs, low wide furniture, drop-offs), laid out afresh from a seed:
//!
//! | kind | what |
//! | --- | --- |
//! | [`Kind::Corridor`] | an L or Z corridor 1.2–2.4 m wide: numbered doors, bins, wall-mounted fountains, cabinets and signs (0.7–2.0 m high, 0.15–0.35 m out), people keeping to their side |
//! | [`Kind::Office`] | a room 8–14 m across: desks, chairs, columns, sometimes a partition with a doorway |
//! | [`Kind::Lobby`] | a hall round a sunken area: benches, bollards, planters, hanging lamps and signs |
//! | [`Kind::Street`] | a pavement 2–4 m wide along a building: poles, bins, low branches, the kerb along the far side |
//!
//! A generated world is written as scene TOML and loaded through [`parse_scene`], the
//! one path every scene takes. Every one has a way through for a 0.5 m wide body (the
//! [`way_through`] grid: an obstacle that closes the way is left out), that way as its
//! `[walker]` (the route of a map that knows every obstacle), and a `[floor_plan_route]`
//! down the middle of its lane, laid on the walls and level changes alone, as a
//! planner given the building's plan would lay it: obstacles stand on it or beside it.
//!
//! The same name gives the same scene, byte for byte, on every platform: the numbers
//! come from [`SimRng`] (seeded by the seed and the kind) and are written to the
//! millimetre.
//!
//! [`parse_scene`]: crate::scene::parse_scene

mod corridor;
mod layout;
mod lobby;
mod office;
mod street;
pub mod way_through;

use crate::random::SimRng;
use layout::{Layout, Wall, WALL_THICKNESS_M};
use way_through::Grid;

/// What a generated world is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Kind {
    /// An L- or Z-shaped corridor.
    Corridor,
    /// An office room with desks.
    Office,
    /// A lobby round a sunken area.
    Lobby,
    /// A pavement along a building.
    Street,
}

/// Every kind, in the order the study prints them.
pub const KINDS: [Kind; 4] = [Kind::Corridor, Kind::Office, Kind::Lobby, Kind::Street];

/// The prefix of a generated world's name.
pub const PREFIX: &str = "gen:";

impl Kind {
    /// The kind's name in `gen:<kind>:<seed>`.
    pub fn name(self) -> &'static str {
        match self {
            Kind::Corridor => "corridor",
            Kind::Office => "office",
            Kind::Lobby => "lobby",
            Kind::Street => "street",
        }
    }

    /// Mixed into the seed so that `gen:office:7` and `gen:lobby:7` draw different numbers.
    fn salt(self) -> u64 {
        match self {
            Kind::Corridor => 0x636f_7272_6964_6f72,
            Kind::Office => 0x6f66_6669_6365_0000,
            Kind::Lobby => 0x6c6f_6262_7900_0000,
            Kind::Street => 0x7374_7265_6574_0000,
        }
    }
}

/// Why a `gen:` name gives no world.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum GenerateError {
    /// The kind is not one of [`KINDS`].
    #[error("{name}: unknown kind `{kind}`: use gen:corridor, gen:office, gen:lobby or gen:street")]
    UnknownKind {
        /// The name given.
        name: String,
        /// The kind in it.
        kind: String,
    },
    /// No seed after the kind.
    #[error("{name}: a generated world needs a seed, as in {name}:7 (`wearnav course --worlds {name} --count N` takes them from --seed)")]
    NoSeed {
        /// The name given.
        name: String,
    },
    /// The seed is not a whole number.
    #[error("{name}: seed must be a whole number (0 to 18446744073709551615), as in gen:{kind}:7")]
    BadSeed {
        /// The name given.
        name: String,
        /// The kind in it.
        kind: String,
    },
    /// The walls alone left no way from the start to the goal: a bug of the generator.
    #[error("{name}: the generator left no way from the start to the goal even without obstacles (a bug: please report the name)")]
    NoWay {
        /// The world's name.
        name: String,
    },
}

/// A kind by its name (`corridor`); `name` is the whole world name, for the error.
pub fn kind_named(kind: &str, name: &str) -> Result<Kind, GenerateError> {
    KINDS
        .into_iter()
        .find(|k| k.name() == kind)
        .ok_or_else(|| GenerateError::UnknownKind { name: name.into(), kind: kind.into() })
}

/// The kind and seed of a generated world's name: `None` when `name` does not start
/// with `gen:`, an error when it does but is not `gen:<kind>:<whole number>`.
pub fn parse_name(name: &str) -> Option<Result<(Kind, u64), GenerateError>> {
    let rest = name.strip_prefix(PREFIX)?;
    Some(match rest.split_once(':') {
        None => kind_named(rest, name).and(Err(GenerateError::NoSeed { name: name.into() })),
        Some((kind, seed)) => kind_named(kind, name).and_then(|k| {
            seed.trim()
                .parse::<u64>()
                .map(|s| (k, s))
                .map_err(|_| GenerateError::BadSeed { name: name.into(), kind: kind.into() })
        }),
    })
}

/// The name of generated world `seed` of `kind`.
pub fn world_name(kind: Kind, seed: u64) -> String {
    format!("{PREFIX}{}:{seed}", kind.name())
}

/// The scene file of world `seed` of `kind`.
pub fn scene_text(kind: Kind, seed: u64) -> Result<String, GenerateError> {
    let mut rng = SimRng::seed_from(seed ^ kind.salt());
    let mut layout = match kind {
        Kind::Corridor => corridor::layout(&mut rng),
        Kind::Office => office::layout(&mut rng),
        Kind::Lobby => lobby::layout(&mut rng),
        Kind::Street => street::layout(&mut rng),
    };
    layout.name = world_name(kind, seed);
    let left_out = settle(&mut layout)?;
    if left_out > 0 {
        layout.description.push_str(&format!("; {left_out} obstacle(s) left out, they closed the way"));
    }
    Ok(layout.to_toml())
}

/// Finds the way through: every obstacle grown by the clearance, a search from the
/// start to the goal; when it is blocked, the obstacles are put back one by one and
/// each one that closes the way is left out. Sets the layout's `way`; returns how many
/// obstacles were left out.
fn settle(layout: &mut Layout) -> Result<usize, GenerateError> {
    let (start, goal) = (layout.start, layout.goal);
    let mut grid = Grid::covering(layout_bounds(layout).0, layout_bounds(layout).1);
    for w in &layout.walls {
        let cells = grid.cells_of(&w.shape());
        grid.add(&cells);
    }
    let cells: Vec<Vec<usize>> = layout.items.iter().map(|i| grid.cells_of(&i.piece.shape())).collect();
    for c in &cells {
        grid.add(c);
    }
    let mut left_out = 0;
    let way = match grid.way(start, goal) {
        Some(way) => way,
        None => {
            for c in &cells {
                grid.remove(c);
            }
            let mut keep = Vec::with_capacity(cells.len());
            for c in &cells {
                grid.add(c);
                let open = grid.way(start, goal).is_some();
                if !open {
                    grid.remove(c);
                    left_out += 1;
                }
                keep.push(open);
            }
            let mut k = keep.into_iter();
            layout.items.retain(|_| k.next().unwrap_or(false));
            grid.way(start, goal).ok_or_else(|| GenerateError::NoWay { name: layout.name.clone() })?
        }
    };
    layout.way = grid.straightened(start, &way, goal);
    Ok(left_out)
}

/// The area the way is searched in: what the kind says, or else everything the layout
/// places with a metre round it.
fn layout_bounds(layout: &Layout) -> ([f64; 2], [f64; 2]) {
    if let Some(b) = layout.bounds {
        return b;
    }
    let mut min = layout.start;
    let mut max = layout.start;
    let points = layout.walls.iter().flat_map(|w| [w.from, w.to]).chain([layout.goal]);
    for p in points {
        min = [min[0].min(p[0]), min[1].min(p[1])];
        max = [max[0].max(p[0]), max[1].max(p[1])];
    }
    ([min[0] - 1.0, min[1] - 1.0], [max[0] + 1.0, max[1] + 1.0])
}

/// Four walls round a room from (0, 0) to `size`, their inner faces on its edges.
fn room_walls(layout: &mut Layout, size: [f64; 2]) {
    let t = WALL_THICKNESS_M / 2.0;
    let [x, y] = size;
    let corner = [[-t, -t], [x + t, -t], [x + t, y + t], [-t, y + t]];
    for (k, name) in ["south wall", "east wall", "north wall", "west wall"].into_iter().enumerate() {
        layout.walls.push(Wall { from: corner[k], to: corner[(k + 1) % 4], label: name.into() });
    }
}

/// True when a circle of `r` round `c` lies in the room of `size` with 10 cm to spare.
fn in_room(size: [f64; 2], c: [f64; 2], r: f64) -> bool {
    (0..2).all(|a| c[a] - r > 0.1 && c[a] + r < size[a] - 0.1)
}

/// Uniform in `lo..hi`.
fn between(rng: &mut SimRng, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.uniform()
}

/// True with probability `p`.
fn chance(rng: &mut SimRng, p: f64) -> bool {
    rng.uniform() < p
}

/// A whole number in `lo..=hi`.
fn count(rng: &mut SimRng, lo: usize, hi: usize) -> usize {
    lo + ((rng.uniform() * (hi - lo + 1) as f64) as usize).min(hi - lo)
}

/// A polyline with distances along it: where obstacles go relative to a route.
#[derive(Debug, Clone)]
struct Polyline {
    points: Vec<[f64; 2]>,
    along_m: Vec<f64>,
}

impl Polyline {
    fn new(points: Vec<[f64; 2]>) -> Self {
        let mut along_m = vec![0.0];
        for w in points.windows(2) {
            let last = along_m[along_m.len() - 1];
            along_m.push(last + (w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]));
        }
        Polyline { points, along_m }
    }

    fn length_m(&self) -> f64 {
        self.along_m.last().copied().unwrap_or(0.0)
    }

    /// The point `s_m` along, and the unit direction of the leg it is on.
    fn at(&self, s_m: f64) -> ([f64; 2], [f64; 2]) {
        let s = s_m.clamp(0.0, self.length_m());
        let k = self.along_m.partition_point(|&a| a <= s).clamp(1, self.points.len().max(2) - 1);
        let (a, b) = (self.points[k - 1], self.points[k]);
        let len = (self.along_m[k] - self.along_m[k - 1]).max(1e-9);
        let f = (s - self.along_m[k - 1]) / len;
        let dir = [(b[0] - a[0]) / len, (b[1] - a[1]) / len];
        ([a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1])], dir)
    }

    /// The point `s_m` along and `left_m` to its left (negative: right).
    fn beside(&self, s_m: f64, left_m: f64) -> [f64; 2] {
        let (p, d) = self.at(s_m);
        [p[0] - d[1] * left_m, p[1] + d[0] * left_m]
    }

    /// Heading of the leg at `s_m`, degrees.
    fn heading_deg(&self, s_m: f64) -> f64 {
        let (_, d) = self.at(s_m);
        d[1].atan2(d[0]).to_degrees()
    }
}

/// Footprints already placed (centre, radius of a circle round them), so a new
/// obstacle does not stand inside another, nor on the start or the goal.
#[derive(Debug, Clone, Default)]
struct Spots {
    taken: Vec<([f64; 2], f64)>,
}

impl Spots {
    /// Keeps the start and the goal clear: nothing within `radius_m` of them.
    fn around_ends(start: [f64; 2], goal: [f64; 2], radius_m: f64) -> Spots {
        Spots { taken: vec![(start, radius_m), (goal, radius_m)] }
    }

    fn fits(&self, c: [f64; 2], r: f64) -> bool {
        self.taken.iter().all(|(p, q)| (p[0] - c[0]).hypot(p[1] - c[1]) > r + q + 0.1)
    }

    /// Takes the spot when it fits; says whether it did.
    fn take(&mut self, c: [f64; 2], r: f64) -> bool {
        let fits = self.fits(c, r);
        if fits {
            self.taken.push((c, r));
        }
        fits
    }
}

#[cfg(test)]
mod tests;

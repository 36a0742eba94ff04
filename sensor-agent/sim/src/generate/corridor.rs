//! `gen:corridor`: an L- or Z-shaped corridor 1.2–2.4 m wide, closed at both ends,
//! the start at one end and the goal at the other. Along it: numbered doors
//! (landmarks), bins (against a wall or out in the way), objects fixed to the walls
//! above the cane's reach (drinking fountains 0.7–1.05 m, cabinets 1.0–2.0 m, flag signs
//! 1.5–2.0 m, sticking 0.15–0.35 m out: what a cane passes under and the body meets),
//! and, where the corridor is wide enough to pass, people walking towards the user on
//! the user's left (their own right). The floor-plan route is the corridor's centre line.

use super::layout::{Door, Item, Layout, Piece, Walker, Wall, WALL_THICKNESS_M};
use super::{between, chance, count};
use crate::random::SimRng;

/// How far the start and the goal stand from the end walls' faces, metres.
const END_GAP_M: f64 = 0.7;

/// Unit vector of a heading that is a multiple of 90°.
fn unit(heading_deg: f64) -> [f64; 2] {
    let r = heading_deg.to_radians();
    [r.cos().round(), r.sin().round()]
}

/// One straight leg of the centre line.
struct Leg {
    from: [f64; 2],
    dir: [f64; 2],
    length_m: f64,
}

impl Leg {
    /// The point `s` along the leg and `left` to its left.
    fn at(&self, s: f64, left: f64) -> [f64; 2] {
        [self.from[0] + s * self.dir[0] - left * self.dir[1], self.from[1] + s * self.dir[1] + left * self.dir[0]]
    }

    fn heading_deg(&self) -> f64 {
        self.dir[1].atan2(self.dir[0]).to_degrees()
    }
}

pub(super) fn layout(rng: &mut SimRng) -> Layout {
    let width = between(rng, 1.2, 2.4);
    let z_shape = chance(rng, 0.5);
    let mut lengths = vec![between(rng, 8.0, 14.0), between(rng, 6.0, 12.0)];
    if z_shape {
        lengths.push(between(rng, 6.0, 12.0));
    }
    let first = count(rng, 0, 3) as f64 * 90.0;
    let turn = if chance(rng, 0.5) { 90.0 } else { -90.0 };
    // an L turns once; a Z turns back the other way, so its last leg runs as its first
    let headings: Vec<f64> = (0..lengths.len()).map(|k| if k == 1 { first + turn } else { first }).collect();

    let mut centre = vec![[0.0, 0.0]];
    let mut legs = Vec::new();
    for (&length_m, &h) in lengths.iter().zip(&headings) {
        let from = centre[centre.len() - 1];
        let dir = unit(h);
        centre.push([from[0] + length_m * dir[0], from[1] + length_m * dir[1]]);
        legs.push(Leg { from, dir, length_m });
    }
    let last = legs.len() - 1;

    let mut layout = Layout {
        description: format!(
            "generated corridor: {}-shaped, {:.2} m wide, legs of {} m",
            if z_shape { "Z" } else { "L" },
            width,
            lengths.iter().map(|l| format!("{l:.1}")).collect::<Vec<_>>().join(", ")
        ),
        start: legs[0].at(END_GAP_M + WALL_THICKNESS_M / 2.0, 0.0),
        start_yaw_deg: legs[0].heading_deg(),
        goal: legs[last].at(legs[last].length_m - END_GAP_M - WALL_THICKNESS_M / 2.0, 0.0),
        goal_label: "stairwell door".into(),
        route: centre[1..centre.len() - 1].to_vec(),
        corners: centre[1..centre.len() - 1].to_vec(),
        ..Layout::default()
    };
    walls(&mut layout, &legs, &centre, width);
    doors(&mut layout, rng, &legs, width);

    // people keep to the user's left, so what is fixed to the walls or stands by them
    // goes on the right of the leg they walk
    let person_leg = (width >= 1.6 && chance(rng, 0.7)).then(|| {
        let k = (0..legs.len()).max_by(|&a, &b| legs[a].length_m.total_cmp(&legs[b].length_m)).unwrap_or(0);
        let leg = &legs[k];
        let lateral = width / 2.0 - 0.3;
        let near = if k == 0 { 3.0 } else { 1.0 };
        let far = leg.length_m - 1.0;
        let speed_m_s = between(rng, 0.8, 1.3);
        layout.people.push(Walker {
            from: leg.at(far, lateral),
            to: leg.at(near, lateral),
            speed_m_s,
            phase_s: between(rng, 0.0, (far - near) / speed_m_s),
        });
        k
    });

    let (mut bins, mut fixed) = (0, 0);
    for (k, leg) in legs.iter().enumerate() {
        let lo = if k == 0 { 2.5 } else { width / 2.0 + 0.5 };
        let hi = if k == last { leg.length_m - 2.5 } else { leg.length_m - width / 2.0 - 0.5 };
        let wanted = count(rng, 1, 1 + (leg.length_m / 5.0) as usize);
        let mut placed: Vec<f64> = Vec::new();
        for _ in 0..wanted {
            let Some(s) = (0..10).map(|_| between(rng, lo, hi)).find(|s| placed.iter().all(|p| (p - s).abs() > 1.2))
            else {
                continue;
            };
            placed.push(s);
            let side = if person_leg == Some(k) || chance(rng, 0.5) { -1.0 } else { 1.0 };
            let what = rng.uniform();
            if what < 0.35 {
                bins += 1;
                let radius = between(rng, 0.15, 0.22);
                let against_wall = width / 2.0 - radius - 0.02;
                // out in the way (most often: a bin left where it was emptied), but
                // leaving 0.7 m on the other side
                let lateral = if chance(rng, 0.35) {
                    against_wall
                } else {
                    let nearest = (0.7 + radius - width / 2.0).max(0.0);
                    between(rng, nearest, nearest.max(against_wall - 0.3))
                };
                layout.items.push(Item {
                    label: format!("bin {bins}"),
                    piece: Piece::Cylinder { center: leg.at(s, side * lateral), radius, top: between(rng, 0.55, 0.9) },
                });
            } else {
                fixed += 1;
                // (name, bottom, top, along the wall, out from it)
                let (name, bottom, top, along, out) = if what < 0.55 {
                    let bottom = between(rng, 0.7, 0.8);
                    (
                        "drinking fountain",
                        bottom,
                        between(rng, 0.95, 1.05),
                        between(rng, 0.4, 0.55),
                        between(rng, 0.28, 0.35),
                    )
                } else if what < 0.8 {
                    let bottom = between(rng, 1.0, 1.3);
                    ("wall cabinet", bottom, between(rng, 1.7, 2.0), between(rng, 0.5, 0.9), between(rng, 0.15, 0.35))
                } else {
                    let bottom = between(rng, 1.5, 1.75);
                    (
                        "flag sign",
                        bottom,
                        bottom + between(rng, 0.2, 0.25),
                        between(rng, 0.05, 0.1),
                        between(rng, 0.25, 0.35),
                    )
                };
                layout.items.push(Item {
                    label: format!("{name} {fixed}"),
                    piece: Piece::Box {
                        center: leg.at(s, side * (width / 2.0 - out / 2.0)),
                        size: [along, out],
                        yaw_deg: leg.heading_deg(),
                        bottom,
                        top,
                    },
                });
            }
        }
    }
    layout.description.push_str(&format!(
        "; {} doors, {bins} bin(s), {fixed} object(s) fixed to the walls, {} person/people walking",
        layout.doors.len(),
        layout.people.len()
    ));
    layout
}

/// Both walls of the corridor (their faces `width` apart, mitred at the corners) and
/// the two end walls.
fn walls(layout: &mut Layout, legs: &[Leg], centre: &[[f64; 2]], width: f64) {
    let half = width / 2.0 + WALL_THICKNESS_M / 2.0;
    let normal = |k: usize| [-legs[k].dir[1], legs[k].dir[0]];
    let offset = |side: f64| -> Vec<[f64; 2]> {
        centre
            .iter()
            .enumerate()
            .map(|(i, c)| {
                // at a right-angled corner the mitre point is off both legs by `half`
                let n = match i {
                    0 => normal(0),
                    i if i == centre.len() - 1 => normal(legs.len() - 1),
                    i => {
                        let (a, b) = (normal(i - 1), normal(i));
                        [a[0] + b[0], a[1] + b[1]]
                    }
                };
                [c[0] + side * half * n[0], c[1] + side * half * n[1]]
            })
            .collect()
    };
    let (left, right) = (offset(1.0), offset(-1.0));
    for (side, points) in [("left", &left), ("right", &right)] {
        for (k, w) in points.windows(2).enumerate() {
            layout.walls.push(Wall { from: w[0], to: w[1], label: format!("{side} wall {}", k + 1) });
        }
    }
    let end = centre.len() - 1;
    layout.walls.push(Wall { from: left[0], to: right[0], label: "end wall behind the start".into() });
    layout.walls.push(Wall { from: left[end], to: right[end], label: "end wall past the goal".into() });
}

/// Numbered doors on both walls, 3–6 m apart, numbered in walking order.
fn doors(layout: &mut Layout, rng: &mut SimRng, legs: &[Leg], width: f64) {
    let half = width / 2.0 + WALL_THICKNESS_M / 2.0;
    let mut found: Vec<(f64, Door)> = Vec::new();
    let mut walked = 0.0;
    for leg in legs {
        for side in [1.0, -1.0] {
            let mut s = width / 2.0 + between(rng, 1.0, 3.0);
            while s < leg.length_m - width / 2.0 - 1.0 {
                let facing = leg.heading_deg() - side * 90.0;
                found.push((walked + s, Door { at: leg.at(s, side * half), number: 0, facing_deg: facing }));
                s += between(rng, 3.0, 6.0);
            }
        }
        walked += leg.length_m;
    }
    found.sort_by(|a, b| a.0.total_cmp(&b.0));
    let base = 100 * count(rng, 1, 4) as u32;
    layout.doors = found.into_iter().enumerate().map(|(i, (_, d))| Door { number: base + 1 + i as u32, ..d }).collect();
}

//! `gen:street`: a pavement 2–4 m wide and 25–40 m long between a building's wall
//! (south, y = 0) and the kerb (north, y = width), where the road lies 0.12–0.18 m
//! lower. The floor-plan route runs down the middle of the pavement. Along it: lamp and
//! sign posts (mostly in the furniture zone by the kerb), bins, low branches of kerbside
//! trees hanging at 1.4–1.9 m (out over the pavement, some over the route), A-boards,
//! and things fixed to the building's wall (0.7–2.0 m high, 0.15–0.35 m out).

use super::layout::{Item, Layout, Piece, Wall, WALL_THICKNESS_M};
use super::{between, chance, count, Spots};
use crate::random::SimRng;

pub(super) fn layout(rng: &mut SimRng) -> Layout {
    let length = between(rng, 25.0, 40.0);
    let width = between(rng, 2.0, 4.0);
    let kerb = between(rng, 0.12, 0.18);
    let mut layout = Layout {
        start: [1.0, width / 2.0],
        goal: [length - 1.0, width / 2.0],
        goal_label: "bus stop".into(),
        // no end walls: the way is searched along the pavement, not round the building
        bounds: Some(([-0.5, -0.2], [length + 0.5, width + 1.0])),
        ..Layout::default()
    };
    let t = WALL_THICKNESS_M / 2.0;
    layout.walls.push(Wall { from: [-1.0, -t], to: [length + 1.0, -t], label: "building wall".into() });
    layout.items.push(Item {
        label: "kerb".into(),
        piece: Piece::DropOff { center: [length / 2.0, width + 1.5], size: [length + 4.0, 3.0], depth: kerb },
    });

    let mut spots = Spots::around_ends(layout.start, layout.goal, 1.2);
    let mut overhead = Spots::default();
    let (mut posts, mut bins, mut branches, mut boards, mut fixed) = (0, 0, 0, 0, 0);
    let wanted = count(rng, (length / 5.0) as usize, (length / 3.5) as usize);
    for _ in 0..wanted {
        let what = rng.uniform();
        let x = between(rng, 3.0, length - 2.5);
        if what < 0.3 {
            let radius = between(rng, 0.04, 0.08);
            let y = if chance(rng, 0.6) { width - between(rng, 0.3, 0.5) } else { between(rng, 0.5, width - 0.3) };
            if spots.take([x, y], radius + 0.2) {
                posts += 1;
                layout.items.push(Item {
                    label: format!("post {posts}"),
                    piece: Piece::Pole { center: [x, y], radius, height: between(rng, 2.5, 4.0) },
                });
            }
        } else if what < 0.5 {
            let radius = between(rng, 0.2, 0.3);
            let y = match count(rng, 0, 2) {
                0 => radius + 0.05,
                1 => width - radius - 0.15,
                // out in the pavement, leaving 0.75 m to pass by the wall
                _ => between(rng, radius + 0.75, (width - radius - 0.15).max(radius + 0.75)),
            };
            if spots.take([x, y], radius) {
                bins += 1;
                layout.items.push(Item {
                    label: format!("bin {bins}"),
                    piece: Piece::Cylinder { center: [x, y], radius, top: between(rng, 0.8, 1.0) },
                });
            }
        } else if what < 0.75 {
            // a kerbside tree's branch, reaching in over the kerb's edge or out over the
            // middle of the pavement (never past 1 m from the wall: people walk under
            // the trees only when they must)
            let inner = if chance(rng, 0.5) {
                between(rng, width - 0.6, width - 0.2)
            } else {
                between(rng, (width / 2.0 - 0.2).max(1.0), width - 0.6)
            };
            let outer = width + between(rng, 0.0, 0.5);
            let extent = [between(rng, 0.8, 1.6), outer - inner];
            let y = (inner + outer) / 2.0;
            if overhead.take([x, y], extent[0] / 2.0) {
                branches += 1;
                let bottom = between(rng, 1.4, 1.9);
                layout.items.push(Item {
                    label: format!("low branch {branches}"),
                    piece: Piece::Hanging {
                        center: [x, y],
                        size: extent,
                        yaw_deg: 0.0,
                        bottom,
                        top: bottom + between(rng, 0.3, 0.6),
                    },
                });
            }
        } else if what < 0.85 {
            let y = if chance(rng, 0.6) { between(rng, 0.4, 0.8) } else { between(rng, 0.4, width - 0.5) };
            if spots.take([x, y], 0.4) {
                boards += 1;
                layout.items.push(Item {
                    label: format!("A-board {boards}"),
                    piece: Piece::Box {
                        center: [x, y],
                        size: [0.6, 0.45],
                        yaw_deg: 0.0,
                        bottom: 0.0,
                        top: between(rng, 0.9, 1.1),
                    },
                });
            }
        } else {
            let out = between(rng, 0.15, 0.35);
            let along = between(rng, 0.4, 1.0);
            let bottom = between(rng, 0.7, 1.6);
            if spots.take([x, out / 2.0], along / 2.0) {
                fixed += 1;
                layout.items.push(Item {
                    label: format!("wall-mounted box {fixed}"),
                    piece: Piece::Box {
                        center: [x, out / 2.0],
                        size: [along, out],
                        yaw_deg: 0.0,
                        bottom,
                        top: (bottom + between(rng, 0.3, 0.6)).min(2.0),
                    },
                });
            }
        }
    }
    layout.description = format!(
        "generated street: a pavement {width:.2} m wide and {length:.1} m long, the kerb {kerb:.2} m down; \
         {posts} post(s), {bins} bin(s), {branches} low branch(es), {boards} A-board(s), {fixed} box(es) on the wall"
    );
    layout
}

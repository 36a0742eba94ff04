//! `gen:lobby`: a hall 10–16 x 8–14 m with a sunken area in its middle (one step of
//! 0.15–0.18 m or a lounge 0.3–0.45 m down), entered by the west wall and left by the
//! east. The floor plan holds the level change, so its route goes round the sunken
//! area down the middle of the lane between it and the north wall (2–3.5 m wide). On and
//! beside that route: benches (low wide boxes 1.2–1.8 x 0.4–0.5 m, 0.4–0.5 m high, below
//! where a cane sweeps high), a row of bollards (0.85–1.0 m), planters, and lamps and
//! signs hanging at 1.5–1.9 m, under which a cane passes.

use super::layout::{Item, Layout, Piece};
use super::{between, chance, count, in_room, room_walls, Polyline, Spots};
use crate::random::SimRng;

pub(super) fn layout(rng: &mut SimRng) -> Layout {
    let size = [between(rng, 10.0, 16.0), between(rng, 8.0, 14.0)];
    let lane = between(rng, 2.0, 3.5);
    let sunken_size = [between(rng, 2.5, 4.5f64.min(size[0] - 6.5)), 0.0];
    let north = size[1] - lane;
    let sunken_size = [sunken_size[0], between(rng, 2.5, 4.5f64.min(north - 1.5))];
    let sunken_x = between(rng, 3.0 + sunken_size[0] / 2.0, size[0] - 3.0 - sunken_size[0] / 2.0);
    let sunken_center = [sunken_x, north - sunken_size[1] / 2.0];
    let depth = if chance(rng, 0.5) { between(rng, 0.15, 0.18) } else { between(rng, 0.3, 0.45) };
    let (west, east) = (sunken_x - sunken_size[0] / 2.0, sunken_x + sunken_size[0] / 2.0);
    let middle = north + lane / 2.0;
    let mut layout = Layout {
        start: [0.7, between(rng, 1.5, size[1] - 1.5)],
        goal: [size[0] - 0.7, between(rng, 1.5, size[1] - 1.5)],
        goal_label: "lift lobby".into(),
        route: vec![[west - 1.2, middle], [east + 1.2, middle]],
        ..Layout::default()
    };
    room_walls(&mut layout, size);
    layout.items.push(Item {
        label: if depth < 0.2 { "step down".into() } else { "sunken lounge".into() },
        piece: Piece::DropOff { center: sunken_center, size: sunken_size, depth },
    });

    let route = Polyline::new(layout.route_with_ends());
    let mut spots = Spots::around_ends(layout.start, layout.goal, 1.0);
    // nothing stands in the sunken area or on its edge
    let off_edge = |c: [f64; 2], r: f64| {
        let dx = ((c[0] - sunken_center[0]).abs() - sunken_size[0] / 2.0).max(0.0);
        let dy = ((c[1] - sunken_center[1]).abs() - sunken_size[1] / 2.0).max(0.0);
        dx.hypot(dy) > r + 0.2
    };
    let fits = |spots: &Spots, c: [f64; 2], r: f64| in_room(size, c, r) && off_edge(c, r) && spots.fits(c, r);
    // `lateral` either side of the route, or anywhere in the room
    let spot = |rng: &mut SimRng, on_route: bool, lateral: f64, r: f64| -> ([f64; 2], f64) {
        if on_route {
            let s = between(rng, 1.5, route.length_m() - 1.5);
            (route.beside(s, between(rng, -lateral, lateral)), route.heading_deg(s))
        } else {
            let c = [between(rng, r + 0.2, size[0] - r - 0.2), between(rng, r + 0.2, size[1] - r - 0.2)];
            (c, if chance(rng, 0.5) { 0.0 } else { 90.0 })
        }
    };

    let mut benches = 0;
    for i in 0..count(rng, 1, 3) {
        let bench = [between(rng, 1.2, 1.8), between(rng, 0.4, 0.5)];
        let r = bench[0].hypot(bench[1]) / 2.0;
        let on_route = i == 0 && chance(rng, 0.7);
        let across = chance(rng, 0.3);
        let Some((center, heading)) = (0..10).map(|_| spot(rng, on_route, 0.3, r)).find(|&(c, _)| fits(&spots, c, r))
        else {
            continue;
        };
        spots.take(center, r);
        benches += 1;
        let top = between(rng, 0.4, 0.5);
        layout.items.push(Item {
            label: format!("bench {benches}"),
            piece: Piece::Box {
                center,
                size: bench,
                yaw_deg: heading + if across { 90.0 } else { 0.0 },
                bottom: 0.0,
                top,
            },
        });
    }

    let mut bollards = 0;
    if chance(rng, 0.7) {
        // a row across the way in, 1.3–1.7 m apart
        let s = between(rng, 2.2, 4.0);
        let n = count(rng, 2, 4);
        let spacing = between(rng, 1.3, 1.7);
        let offset = between(rng, -0.5, 0.5);
        let (radius, height) = (between(rng, 0.05, 0.1), between(rng, 0.85, 1.0));
        for i in 0..n {
            let c = route.beside(s, offset + (i as f64 - (n as f64 - 1.0) / 2.0) * spacing);
            if fits(&spots, c, radius) {
                spots.take(c, radius);
                bollards += 1;
                layout.items.push(Item {
                    label: format!("bollard {bollards}"),
                    piece: Piece::Pole { center: c, radius, height },
                });
            }
        }
    }

    let mut planters = 0;
    for _ in 0..count(rng, 1, 3) {
        let radius = between(rng, 0.3, 0.5);
        let on_route = chance(rng, 0.4);
        let Some((center, _)) =
            (0..10).map(|_| spot(rng, on_route, 0.5, radius)).find(|&(c, _)| fits(&spots, c, radius))
        else {
            continue;
        };
        spots.take(center, radius);
        planters += 1;
        layout.items.push(Item {
            label: format!("planter {planters}"),
            piece: Piece::Cylinder { center, radius, top: between(rng, 0.6, 1.0) },
        });
    }

    // hanging things are above the floor: they only keep off each other
    let mut overhead = Spots::default();
    let mut hanging = 0;
    for _ in 0..count(rng, 1, 3) {
        let lamp = chance(rng, 0.5);
        let on_route = chance(rng, 0.7);
        let Some((center, heading)) = (0..10)
            .map(|_| {
                let (c, h) = spot(rng, on_route, 0.3, 0.6);
                if on_route || chance(rng, 0.5) {
                    (c, h)
                } else {
                    // beside the route, 0.6–1.5 m off it
                    let s = between(rng, 1.5, route.length_m() - 1.5);
                    let side = if chance(rng, 0.5) { 1.0 } else { -1.0 };
                    (route.beside(s, side * between(rng, 0.6, 1.5)), route.heading_deg(s))
                }
            })
            .find(|&(c, _)| in_room(size, c, 0.6) && overhead.fits(c, 0.6))
        else {
            continue;
        };
        overhead.take(center, 0.6);
        hanging += 1;
        let bottom = between(rng, 1.5, 1.9);
        let (name, extent, top) = if lamp {
            let side = between(rng, 0.3, 0.5);
            ("hanging lamp", [side, side], bottom + between(rng, 0.2, 0.4))
        } else {
            ("hanging sign", [between(rng, 0.8, 1.2), between(rng, 0.05, 0.1)], bottom + between(rng, 0.25, 0.4))
        };
        layout.items.push(Item {
            label: format!("{name} {hanging}"),
            piece: Piece::Hanging { center, size: extent, yaw_deg: heading + 90.0, bottom, top },
        });
    }
    layout.description = format!(
        "generated lobby: {:.1} x {:.1} m round a {:.1} x {:.1} m area {:.2} m down, the way past it {lane:.1} m wide; \
         {benches} bench(es), {bollards} bollard(s), {planters} planter(s), {hanging} hanging lamp(s)/sign(s)",
        size[0], size[1], sunken_size[0], sunken_size[1], depth
    );
    layout
}

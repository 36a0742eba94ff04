//! `gen:office`: an open-plan office 8–14 m each way, entered by the west wall and
//! left by the east. Half the offices are split by a partition with one doorway
//! (1.0–1.6 m); the floor-plan route then runs through the doorway's middle, else
//! straight across. Desks (tables 1.2–1.6 x 0.7–0.8 m: a cane finds the legs, the body
//! the top), chairs pulled out from them, and columns, close to half of each on the
//! route, the rest anywhere in the room.

use super::layout::{Item, Layout, Piece, Wall};
use super::{between, chance, count, in_room, room_walls, Polyline, Spots};
use crate::random::SimRng;

pub(super) fn layout(rng: &mut SimRng) -> Layout {
    let size = [between(rng, 8.0, 14.0), between(rng, 8.0, 14.0)];
    let mut layout = Layout {
        start: [0.7, between(rng, 1.5, size[1] - 1.5)],
        goal: [size[0] - 0.7, between(rng, 1.5, size[1] - 1.5)],
        goal_label: "meeting room door".into(),
        ..Layout::default()
    };
    room_walls(&mut layout, size);
    // the partition's x and its doorway's middle and width
    let partition = chance(rng, 0.5).then(|| {
        let x = between(rng, 0.4, 0.6) * size[0];
        let gap = between(rng, 1.0, 1.6);
        let y = between(rng, 1.2 + gap / 2.0, size[1] - 1.2 - gap / 2.0);
        layout.walls.push(Wall { from: [x, -0.05], to: [x, y - gap / 2.0], label: "partition south".into() });
        layout.walls.push(Wall { from: [x, y + gap / 2.0], to: [x, size[1] + 0.05], label: "partition north".into() });
        layout.route = vec![[x - 1.2, y], [x + 1.2, y]];
        (x, y, gap)
    });
    let route = Polyline::new(layout.route_with_ends());
    let mut spots = Spots::around_ends(layout.start, layout.goal, 1.0);
    let clear_of_partition = |c: [f64; 2], r: f64| partition.is_none_or(|(x, _, _)| (c[0] - x).abs() > r + 0.3);
    // somewhere on the route (within `lateral` of it) or anywhere in the room
    let spot = |rng: &mut SimRng, on_route: bool, lateral: f64, r: f64| -> [f64; 2] {
        if on_route {
            route.beside(between(rng, 1.8, route.length_m() - 1.8), between(rng, -lateral, lateral))
        } else {
            [between(rng, r + 0.2, size[0] - r - 0.2), between(rng, r + 0.2, size[1] - r - 0.2)]
        }
    };

    let (mut desks, mut chairs, mut columns) = (0, 0, 0);
    for _ in 0..count(rng, 4, 8) {
        let desk = [between(rng, 1.2, 1.6), between(rng, 0.7, 0.8)];
        let yaw_deg = if chance(rng, 0.5) { 0.0 } else { 90.0 };
        let r = desk[0].hypot(desk[1]) / 2.0;
        let on_route = chance(rng, 0.45);
        let Some(center) = (0..10)
            .map(|_| spot(rng, on_route, 0.5, r))
            .find(|&c| in_room(size, c, r) && clear_of_partition(c, r) && spots.fits(c, r))
        else {
            continue;
        };
        // a chair pulled out from a long side, facing the desk
        let chair = chance(rng, 0.7).then(|| {
            let side = if chance(rng, 0.5) { 1.0 } else { -1.0 };
            let (s, c) = f64::to_radians(yaw_deg + 90.0).sin_cos();
            let off = side * (desk[1] / 2.0 + between(rng, 0.2, 0.4));
            [center[0] + c * off, center[1] + s * off]
        });
        // it sits against its own desk, so it is checked before the desk takes its spot
        let chair = chair.filter(|&c| in_room(size, c, 0.33) && clear_of_partition(c, 0.33) && spots.fits(c, 0.33));
        spots.take(center, r);
        desks += 1;
        layout.items.push(Item {
            label: format!("desk {desks}"),
            piece: Piece::Table { center, size: desk, yaw_deg, height: between(rng, 0.72, 0.76) },
        });
        if let Some(at) = chair {
            spots.taken.push((at, 0.33));
            chairs += 1;
            let facing = (center[1] - at[1]).atan2(center[0] - at[0]).to_degrees();
            layout
                .items
                .push(Item { label: format!("chair {chairs}"), piece: Piece::Chair { center: at, yaw_deg: facing } });
        }
    }
    for _ in 0..count(rng, 1, 3) {
        let radius = between(rng, 0.2, 0.3);
        let on_route = chance(rng, 0.4);
        let Some(center) = (0..10)
            .map(|_| spot(rng, on_route, 0.4, radius))
            .find(|&c| in_room(size, c, radius) && clear_of_partition(c, radius) && spots.fits(c, radius))
        else {
            continue;
        };
        spots.take(center, radius);
        columns += 1;
        layout
            .items
            .push(Item { label: format!("column {columns}"), piece: Piece::Cylinder { center, radius, top: 3.0 } });
    }
    layout.description = format!(
        "generated office: {:.1} x {:.1} m{}, {desks} desks, {chairs} chairs, {columns} columns",
        size[0],
        size[1],
        partition.map_or(String::new(), |(_, _, gap)| format!(", a partition with a {gap:.2} m doorway"))
    );
    layout
}

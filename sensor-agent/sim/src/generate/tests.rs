//! Generated worlds checked the way the study sees them: loaded by name through
//! `World::load`, their geometry taken from the parsed scene (table legs, chair backs),
//! not from the generator's own shapes.

use super::*;
use crate::shape::Shape;
use crate::world::{ObstacleKind, World};

fn load(name: &str) -> World {
    World::load(name).unwrap_or_else(|e| panic!("{e}"))
}

/// Every static shape of floor 0 with its kind.
fn shapes(w: &World) -> Vec<(Shape, ObstacleKind)> {
    let g = w.geometry(0);
    let kind = |id: &crate::ObstacleId| w.obstacle(*id).map_or(ObstacleKind::Box, |o| o.kind);
    g.boxes
        .iter()
        .map(|(b, id)| (Shape::Box(*b), kind(id)))
        .chain(g.cylinders.iter().map(|(c, id)| (Shape::Cylinder(*c), kind(id))))
        .chain(g.drop_offs.iter().map(|(d, id)| (Shape::DropOff(*d), kind(id))))
        .collect()
}

/// Points every `step_m` along a polyline.
fn along(points: &[[f64; 2]], step_m: f64) -> Vec<[f64; 2]> {
    let mut out = Vec::new();
    for w in points.windows(2) {
        let n = (((w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1])) / step_m).ceil().max(1.0) as usize;
        for i in 0..=n {
            let f = i as f64 / n as f64;
            out.push([w[0][0] + f * (w[1][0] - w[0][0]), w[0][1] + f * (w[1][1] - w[0][1])]);
        }
    }
    out
}

fn with_ends(w: &World, middle: &[[f64; 2]]) -> Vec<[f64; 2]> {
    let mut points = vec![[w.start().x_m, w.start().y_m]];
    points.extend_from_slice(middle);
    points.push([w.goal().x_m, w.goal().y_m]);
    points
}

#[test]
fn the_same_name_gives_the_same_scene_byte_for_byte() {
    for kind in KINDS {
        for seed in [0, 1, 7, 12345, u64::MAX] {
            let a = scene_text(kind, seed).unwrap_or_else(|e| panic!("{e}"));
            let b = scene_text(kind, seed).unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(a, b, "{}", world_name(kind, seed));
            assert!(a.starts_with(&format!("name = \"gen:{}:{seed}\"\n", kind.name())), "{a}");
        }
    }
    // the world's geometry, not only its text
    let (a, b) = (load("gen:office:3"), load("gen:office:3"));
    assert_eq!(a.geometry(0).boxes, b.geometry(0).boxes);
    assert_eq!(a.floor_plan_route(), b.floor_plan_route());
}

#[test]
fn different_seeds_and_kinds_give_different_layouts() {
    for kind in KINDS {
        let layouts: std::collections::BTreeSet<String> = (0..50)
            .map(|seed| {
                let text = scene_text(kind, seed).unwrap_or_else(|e| panic!("{e}"));
                // everything but the name line
                text.split_once('\n').map(|(_, rest)| rest.to_string()).unwrap_or_default()
            })
            .collect();
        assert_eq!(layouts.len(), 50, "{kind:?}: some seeds gave the same layout");
    }
    assert_ne!(load("gen:office:7").geometry(0).boxes, load("gen:lobby:7").geometry(0).boxes);
    // corridors: widths over their whole range, both shapes, turns both ways
    let (mut narrowest, mut widest, mut legs) = (f64::INFINITY, 0.0f64, std::collections::BTreeSet::new());
    for seed in 0..60 {
        let w = load(&world_name(Kind::Corridor, seed));
        let width = w
            .description()
            .split(", ")
            .find_map(|p| p.strip_suffix(" m wide").and_then(|v| v.parse::<f64>().ok()))
            .unwrap_or_else(|| panic!("no width in {}", w.description()));
        narrowest = narrowest.min(width);
        widest = widest.max(width);
        legs.insert(w.corners().len() + 1);
    }
    assert!(narrowest < 1.35 && widest > 2.25 && narrowest >= 1.2 && widest <= 2.4, "{narrowest} .. {widest}");
    assert_eq!(legs.into_iter().collect::<Vec<_>>(), [2, 3], "L and Z corridors");
}

#[test]
fn a_name_that_is_not_a_generated_world_says_why() {
    let err = |name: &str| World::load(name).err().map(|e| e.to_string()).unwrap_or_default();
    assert!(err("gen:lobby:x").starts_with("gen:lobby:x: seed must be a whole number"), "{}", err("gen:lobby:x"));
    assert!(err("gen:lobby:-3").starts_with("gen:lobby:-3: seed must be a whole number"));
    assert!(err("gen:cave:3").starts_with("gen:cave:3: unknown kind `cave`: use gen:corridor, gen:office"));
    assert!(err("gen:lobby").starts_with("gen:lobby: a generated world needs a seed, as in gen:lobby:7"));
    assert_eq!(parse_name("corridor"), None);
    assert_eq!(parse_name("gen:street:18446744073709551615"), Some(Ok((Kind::Street, u64::MAX))));
}

/// Per kind, over 200 seeds: the world loads by name; its scripted walk (the way the
/// generator found) keeps a 0.5 m wide body off every static obstacle and out of
/// every drop-off, from the start to the goal; the floor-plan route keeps 0.35 m from
/// every wall and drop-off; obstacles stand on or near that route in most worlds, and
/// some stand beside it.
#[test]
fn every_kind_has_a_way_through_on_200_seeds_and_its_route_keeps_clear_of_walls() {
    let mut shares = Vec::new();
    for kind in KINDS {
        let (mut worlds_with_one_on_route, mut near, mut total, mut thinned) = (0, 0, 0, 0);
        for seed in 0..200 {
            let name = world_name(kind, seed);
            let w = load(&name);
            thinned += usize::from(w.description().contains("left out"));
            let all = shapes(&w);
            let way = w.walker().map(|s| s.waypoints.clone()).unwrap_or_else(|| panic!("{name}: no walker"));
            let goal = [w.goal().x_m, w.goal().y_m];
            assert_eq!(way.last(), Some(&goal), "{name}: the way ends at the goal");
            for p in along(&with_ends(&w, &way[..way.len() - 1]), 0.02) {
                for (s, k) in &all {
                    let d = s.body_distance_m(p[0], p[1], 0.25, 1.8);
                    assert!(d > 0.0, "{name}: a body on the way at ({:.2}, {:.2}) touches a {k:?}", p[0], p[1]);
                }
            }
            let route = w.floor_plan_route().unwrap_or_else(|| panic!("{name}: no floor-plan route"));
            let route = along(&with_ends(&w, route), 0.05);
            for p in &route {
                for (s, k) in all.iter().filter(|(_, k)| matches!(k, ObstacleKind::Wall | ObstacleKind::DropOff)) {
                    let d = s.body_distance_m(p[0], p[1], 0.0, 1.8);
                    assert!(d >= 0.35, "{name}: the route at ({:.2}, {:.2}) is {d:.2} m from a {k:?}", p[0], p[1]);
                }
            }
            // furniture a body walking the route (0.45 m wide) would come within 0.3 m of
            let mut on_route = 0;
            for o in 0..w.obstacles().len() {
                let id = crate::ObstacleId(o as u32);
                let kind = w.obstacles()[o].kind;
                if matches!(kind, ObstacleKind::Wall | ObstacleKind::DropOff | ObstacleKind::Person) {
                    continue;
                }
                total += 1;
                let near_route = w
                    .obstacles_at(0, 0.0)
                    .filter(|(i, _)| *i == id)
                    .any(|(_, s)| route.iter().any(|p| s.body_distance_m(p[0], p[1], 0.225, 1.8) < 0.3));
                if near_route {
                    on_route += 1;
                }
            }
            near += on_route;
            if on_route > 0 {
                worlds_with_one_on_route += 1;
            }
        }
        let share = near as f64 / total.max(1) as f64;
        println!(
            "{kind:?}: {worlds_with_one_on_route} of 200 worlds with an obstacle on or near the route; {near} of {total} obstacles ({:.0} %) near it; {thinned} worlds with obstacles left out",
            100.0 * share
        );
        // the placement leaves a way nearly always; leaving obstacles out is the backstop
        assert!(thinned <= 20, "{kind:?}: {thinned} of 200 worlds had obstacles left out");
        shares.push((kind, worlds_with_one_on_route, share));
    }
    for (kind, worlds, share) in shares {
        assert!(worlds >= 150, "{kind:?}: {worlds} of 200 worlds with an obstacle on or near the route");
        assert!((0.2..0.9).contains(&share), "{kind:?}: {share:.2} of the obstacles near the route");
    }
}

#[test]
fn each_kind_holds_the_obstacles_it_promises() {
    let hanging_bottoms = |w: &World| -> Vec<f64> {
        w.geometry(0)
            .boxes
            .iter()
            .filter(|(_, id)| w.obstacle(*id).is_some_and(|o| o.kind == ObstacleKind::Hanging))
            .map(|(b, _)| b.bottom_m)
            .collect()
    };
    let count = |w: &World, kind: ObstacleKind| w.obstacles().iter().filter(|o| o.kind == kind).count();
    let (mut fixed, mut people, mut drops, mut desks, mut overhangs) = (0, 0, 0, 0, 0);
    for seed in 0..40 {
        let c = load(&world_name(Kind::Corridor, seed));
        assert!(c.doors().len() >= 3 && !c.corners().is_empty(), "{}", c.name());
        people += c.people().len();
        // fixed to a wall: boxes off the floor, 0.7 to 2.0 m high
        for (b, id) in &c.geometry(0).boxes {
            if c.obstacle(*id).is_some_and(|o| o.kind == ObstacleKind::Box) {
                assert!(b.bottom_m >= 0.7 && b.top_m <= 2.0, "{}: {b:?}", c.name());
                let out = 2.0 * b.half_size_m[1];
                assert!((0.15..=0.35).contains(&out), "{}: sticks out {out}", c.name());
                fixed += 1;
            }
        }
        let o = load(&world_name(Kind::Office, seed));
        desks += count(&o, ObstacleKind::Table);
        assert!(count(&o, ObstacleKind::Cylinder) >= 1, "{}: a column", o.name());
        let l = load(&world_name(Kind::Lobby, seed));
        let sunken = l.geometry(0).drop_offs.first().map(|(d, _)| d.depth_m).unwrap_or_default();
        assert!((0.15..=0.45).contains(&sunken), "{}: {sunken}", l.name());
        drops += 1;
        for b in hanging_bottoms(&l) {
            assert!((1.5..=1.9).contains(&b), "{}: hanging at {b}", l.name());
            overhangs += 1;
        }
        let s = load(&world_name(Kind::Street, seed));
        let kerb = s.geometry(0).drop_offs.first().map(|(d, _)| d.depth_m).unwrap_or_default();
        assert!((0.12..=0.18).contains(&kerb), "{}: kerb {kerb}", s.name());
        for b in hanging_bottoms(&s) {
            assert!((1.4..=1.9).contains(&b), "{}: branch at {b}", s.name());
        }
    }
    assert!(
        fixed >= 40 && people >= 10 && desks >= 120 && drops == 40 && overhangs >= 40,
        "{fixed} {people} {desks} {overhangs}"
    );
}

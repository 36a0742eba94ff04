//! Where the user heads, for the predictive cue (`perception::predictive`): the route
//! ahead of the user's place on this floor and the floor plan's walls near them, in the
//! body's frame. The compute agent and the study's spoken walks build it alike.

use schemas::RouteState;

use crate::UserPose;

/// The walls near the user handed to the predictive cue: this far either way along
/// each axis, metres (past what its 2.5 s look-ahead reaches).
pub const WALLS_NEAR_M: f64 = 4.5;

/// The route ahead of `pose` on its floor (the user's place first, then the route's
/// points while they stay on that floor) and the walls within [`WALLS_NEAR_M`], in the
/// body's frame (x along the heading, y to the left); true when the way ends at the
/// destination rather than at a gateway to another floor.
pub fn way_ahead(
    pose: &UserPose,
    state: &RouteState,
    walls: &[[f64; 2]],
    way: &mut Vec<[f64; 2]>,
    near: &mut Vec<[f64; 2]>,
) -> bool {
    let (s, c) = pose.heading_rad.sin_cos();
    let body = |x: f64, y: f64| {
        let (dx, dy) = (x - pose.x_m, y - pose.y_m);
        [c * dx + s * dy, -s * dx + c * dy]
    };
    way.clear();
    way.push([0.0, 0.0]);
    let on_floor = state.route.iter().take_while(|p| p.floor == pose.floor);
    way.extend(on_floor.map(|p| body(f64::from(p.x_m), f64::from(p.y_m))));
    near.clear();
    near.extend(walls.iter().filter_map(|p| {
        let (dx, dy) = (p[0] - pose.x_m, p[1] - pose.y_m);
        (dx.abs() <= WALLS_NEAR_M && dy.abs() <= WALLS_NEAR_M).then(|| body(p[0], p[1]))
    }));
    way.len() == state.route.len() + 1
}

#[cfg(test)]
mod tests {
    use super::*;
    use schemas::{MapPoint, RouteStatus};

    #[test]
    fn the_way_ahead_is_the_route_on_this_floor_and_the_walls_near_in_the_body_frame() {
        // the user at (2, 1) facing +y (the body's x is the map's +y, its y the map's -x);
        // the route goes north to (2, 5), then to a gateway and on upstairs
        let pose = UserPose { x_m: 2.0, y_m: 1.0, heading_rad: std::f64::consts::FRAC_PI_2, floor: 0, confident: true };
        let at = |x_m: f32, y_m: f32, floor: i32| MapPoint { x_m, y_m, floor };
        let mut state = RouteState {
            destination: "room 204".into(),
            next_waypoint: Some(at(2.0, 5.0, 0)),
            distance_left_m: 10.0,
            instruction: String::new(),
            floor: 0,
            status: RouteStatus::Guiding,
            route: vec![at(2.0, 5.0, 0), at(4.0, 5.0, 0), at(4.0, 5.0, 1), at(8.0, 5.0, 1)],
        };
        // a wall 1 m to the user's left (map x = 1) and one 10 m away
        let walls = [[1.0, 1.0], [1.0, 2.0], [12.0, 1.0]];
        let (mut way, mut near) = (Vec::new(), Vec::new());
        let ends_at_goal = way_ahead(&pose, &state, &walls, &mut way, &mut near);
        let close = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).abs() < 1e-9 && (a[1] - b[1]).abs() < 1e-9;
        assert!(!ends_at_goal, "the way on this floor ends at the gateway");
        assert_eq!(way.len(), 3, "{way:?}");
        assert!(close(way[0], [0.0, 0.0]) && close(way[1], [4.0, 0.0]) && close(way[2], [4.0, -2.0]), "{way:?}");
        assert_eq!(near.len(), 2, "{near:?}");
        assert!(close(near[0], [0.0, 1.0]) && close(near[1], [1.0, 1.0]), "{near:?}");
        state.route.truncate(2);
        assert!(way_ahead(&pose, &state, &walls, &mut way, &mut near), "the way ends at the destination");
    }
}

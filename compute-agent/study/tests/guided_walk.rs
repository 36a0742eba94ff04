//! The whole navigation loop without the bus, on the simulated `building`: the user
//! asks for room 204 (floor 1) at the entrance (floor 0); the compute agent's tracker
//! localizes on the exported floor plan from the simulator's odometry, IMUs and depth
//! (never its truth), the navigator plans by the elevator and guides, and the simulated
//! user walks by what it is told, rides up and says so.

use study::guided_walk::guided_walk;

#[test]
fn a_guided_walk_reaches_room_204_on_floor_1_by_the_elevator_within_a_metre() {
    let r = guided_walk("building", "room 204", 1, 60.0).unwrap();
    let said: Vec<&str> = r.said.iter().map(|(_, s)| s.as_str()).collect();
    let first = |prefix: &str| r.said.iter().position(|(_, s)| s.starts_with(prefix));
    // the order of what the user hears: the route at once (from the told start, followed
    // by the motion while the scans confirm it), elevator, floor 1, arrival
    let order = [
        first("Route to room 204:"),
        first("Elevator ahead; take it to floor 1"),
        first("You are at the elevator."),
        first("Floor 1:"),
        first("You have arrived at room 204."),
    ];
    assert!(order.iter().all(Option::is_some), "{said:#?}");
    assert!(order.windows(2).all(|w| w[0] < w[1]), "{said:#?}");
    assert!(first("Position found.").is_some(), "the scans never confirmed the place: {said:#?}");
    // no route before guidance could take the place
    let route_at = r.said[order[0].unwrap()].0;
    let at_route = r.frames.iter().rfind(|f| f.t_s <= route_at).expect("a frame before the route");
    assert!(at_route.guided, "the route came before the place: {at_route:?}");
    let arrived = r.arrived_s.expect("arrived");
    assert!(arrived < 45.0, "arrived after {arrived} s");
    assert_eq!(r.floor, 1);
    assert!(r.off_m <= 1.0, "the user stands {:.2} m from room 204", r.off_m);
    // while guidance took the filter's place, it was never more than 1 m off (the
    // invariant of docs/localization.md). Along the 11 m of featureless corridor before
    // the stair hall the estimate falls behind by up to ~0.5 m, until the hall's opening
    // pins it.
    let worst = r
        .frames
        .iter()
        .filter(|f| f.guided && f.truth[3] == f.estimate[3])
        .map(|f| (f.truth[0] - f.estimate[0]).hypot(f.truth[1] - f.estimate[1]))
        .fold(0.0, f64::max);
    assert!(worst < 1.0, "guided from a place {worst:.2} m off");
    // the sweep the scan is read with follows the cane's
    let sweep_err: Vec<f64> = r.frames.iter().skip(60).map(|f| (f.sweep_deg - f.true_sweep_deg).abs()).collect();
    let mean = sweep_err.iter().sum::<f64>() / sweep_err.len() as f64;
    assert!(mean < 3.0, "sweep off by {mean:.1} degrees on average");
}

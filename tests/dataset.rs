//! The real data set: on simple_curve (data-set head and platform, placed
//! at z = 40.5 mm as the original software did) the cpu and parry backends
//! give the same verdict for every waypoint and for tilted poses, at
//! margin 0 and at the planner's default safety margin (0.05 mm).

mod common;

use maamplan::collide::cpu::CpuBackend;
use maamplan::collide::parry::ParryBackend;
use maamplan::collide::sample::tilted_queries;
use maamplan::collide::Backend;
use maamplan::scene::{Query, Scene};

fn simple_curve() -> Scene {
    common::simple_curve().1
}

fn compare(scene: &Scene, queries: &[Query]) -> usize {
    let cpu = CpuBackend::new(scene).evaluate(queries).unwrap();
    let parry = ParryBackend::new(scene).unwrap().evaluate(queries).unwrap();
    common::near_contacts_only(scene, queries, &cpu, &parry, "parry vs cpu");
    cpu.iter().filter(|&&c| c).count()
}

#[test]
fn simple_curve_every_waypoint_and_tilted_poses_agree() {
    let scene = simple_curve();
    let own = compare(&scene, &scene.waypoint_queries);
    // The data set's own orientations are almost all free; a handful touch.
    assert!(own < 50, "{own} of the data set's own poses collide");
    let tilted = tilted_queries(&scene.waypoint_queries, 8000, 3);
    let hits = compare(&scene, &tilted);
    assert!(
        hits > 100 && hits < tilted.len() - 100,
        "{hits} colliding tilted poses"
    );
    let with_margin = common::with_margin(&tilted, 0.05);
    let hits_margin = compare(&scene, &with_margin);
    assert!(
        hits_margin > hits,
        "margin 0.05: {hits_margin} colliding, margin 0: {hits}"
    );
}

//! The real data set: on simple_curve (data-set head and platform, placed
//! at z = 40.5 mm as the original software did) the cpu and parry backends
//! give the same verdict for every waypoint and for tilted poses, at
//! margin 0 and at the planner's default safety margin (0.05 mm); and
//! every layer surface of the data set reads to the same mesh by the plain
//! OBJ reader as by tobj.

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

/// Every layer surface of the three models (3.3 M lines on dome_cut)
/// reads to the same mesh, bit for bit, by the plain reader as by tobj.
#[test]
fn every_layer_surface_reads_as_tobj_reads_it() {
    use maamplan::io::{mesh::read_with_tobj, obj_plain};
    let mut files = 0;
    for model in ["simple_curve", "freeform", "dome_cut"] {
        let dir = common::data().join(model).join("layer");
        for entry in std::fs::read_dir(&dir).expect("layer folder") {
            let path = entry.unwrap().path();
            let text = std::fs::read_to_string(&path).unwrap();
            let plain = obj_plain::parse(&text)
                .unwrap_or_else(|| panic!("{} is not plain OBJ", path.display()));
            let reference = read_with_tobj(&text).unwrap();
            let bits = |m: &maamplan::geometry::Mesh| -> Vec<u32> {
                m.vertices.iter().flatten().map(|x| x.to_bits()).collect()
            };
            assert_eq!(bits(&plain), bits(&reference), "{}", path.display());
            assert_eq!(plain.triangles, reference.triangles, "{}", path.display());
            files += 1;
        }
    }
    assert!(files > 200, "{files} layer files");
}

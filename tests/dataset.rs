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
use std::sync::OnceLock;

/// simple_curve's scene, built once.
fn simple_curve() -> &'static Scene {
    static SCENE: OnceLock<Scene> = OnceLock::new();
    SCENE.get_or_init(|| common::simple_curve().1)
}

/// simple_curve's cpu and parry backends, built once.
fn backends() -> &'static (CpuBackend<'static>, ParryBackend) {
    static BACKENDS: OnceLock<(CpuBackend<'static>, ParryBackend)> = OnceLock::new();
    BACKENDS.get_or_init(|| {
        let scene = simple_curve();
        (CpuBackend::new(scene), ParryBackend::new(scene).unwrap())
    })
}

/// The cpu's and parry's verdicts on simple_curve's `queries` agree but
/// for near contacts; the number the cpu finds colliding.
fn compare(queries: &[Query]) -> usize {
    let (cpu, parry) = backends();
    let cpu = cpu.evaluate(queries).unwrap();
    let parry = parry.evaluate(queries).unwrap();
    common::near_contacts_only(simple_curve(), queries, &cpu, &parry, "parry vs cpu");
    cpu.iter().filter(|&&c| c).count()
}

/// Tilted poses of simple_curve's waypoints and how many of them collide
/// at margin 0 (the backends agreeing), once.
fn tilted() -> &'static (Vec<Query>, usize) {
    static TILTED: OnceLock<(Vec<Query>, usize)> = OnceLock::new();
    TILTED.get_or_init(|| {
        let scene = simple_curve();
        let tilted = tilted_queries(&scene.waypoint_queries, 8000, 3);
        let hits = compare(&tilted);
        (tilted, hits)
    })
}

/// The data set's own orientations are almost all free; a handful touch.
#[test]
fn simple_curve_every_waypoint_agrees() {
    let scene = simple_curve();
    let own = compare(&scene.waypoint_queries);
    assert!(own < 50, "{own} of the data set's own poses collide");
}

#[test]
fn simple_curve_tilted_poses_agree() {
    let (tilted, hits) = tilted();
    assert!(
        *hits > 100 && *hits < tilted.len() - 100,
        "{hits} colliding tilted poses"
    );
}

#[test]
fn simple_curve_tilted_poses_agree_at_the_default_margin() {
    let (tilted, hits) = tilted();
    let with_margin = common::with_margin(tilted, 0.05);
    let hits_margin = compare(&with_margin);
    assert!(
        hits_margin > *hits,
        "margin 0.05: {hits_margin} colliding, margin 0: {hits}"
    );
}

/// Every layer surface of `model` reads to the same mesh, bit for bit, by
/// the plain reader as by tobj; the number of layer files.
fn assert_layers_read_as_tobj_reads_them(model: &str) -> usize {
    use maamplan::io::{mesh::read_with_tobj, obj_plain};
    let mut files = 0;
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
    files
}

#[test]
fn simple_curve_layers_read_as_tobj_reads_them() {
    assert_eq!(assert_layers_read_as_tobj_reads_them("simple_curve"), 20);
}

#[test]
fn freeform_layers_read_as_tobj_reads_them() {
    assert_eq!(assert_layers_read_as_tobj_reads_them("freeform"), 24);
}

/// 3.3 M lines.
#[test]
fn dome_cut_layers_read_as_tobj_reads_them() {
    assert_eq!(assert_layers_read_as_tobj_reads_them("dome_cut"), 169);
}

//! The part as deposited: scenes modelled from the beads a toolpath lays
//! (no layer surfaces) answer as brute force does, and are conservative —
//! a pose the beads call clear keeps the head out of the material really
//! deposited, sampled densely along every printed segment.

mod common;

use common::*;
use maamplan::collide::brute::winding_number;
use maamplan::collide::cpu::{to_head, CpuBackend};
use maamplan::collide::parry::ParryBackend;
use maamplan::collide::Backend;
use maamplan::default_job::cone_head;
use maamplan::geometry::Mesh;
use maamplan::scene::beads::BeadSettings;
use maamplan::scene::{HeadConfig, PartModel, PartSource, Query, Scene, SceneConfig};
use rand::Rng;
use rand_chacha::ChaCha8Rng;

const WIDTH: f64 = 0.7;
const DZ: f64 = 0.5;

fn cfg(part: PartModel) -> SceneConfig {
    SceneConfig {
        head: HeadConfig {
            tip_clearance: 0.2,
            grid_resolution: 48,
        },
        max_edge: None,
        head_cache: false,
        part,
        beads: BeadSettings::new(WIDTH, DZ, 5.0),
        ..SceneConfig::default()
    }
}

fn head() -> Mesh {
    cone_head(8.0, 2.0, 14.0, 16)
}

/// The scene of `part` from its beads: with its layers as given, or (with
/// `stacked`) from the waypoints alone as one list, its layers found from
/// how the beads stack.
fn bead_scene(part: &PrintedPart, stacked: bool) -> Scene {
    let config = cfg(PartModel::Beads);
    if !stacked {
        return Scene::build(&part.toolpath, &head(), &part.platform, &config).unwrap();
    }
    let mut one = part.toolpath.clone();
    let all = one
        .layers
        .iter()
        .flat_map(|l| l.waypoints.clone())
        .collect();
    one.layers.truncate(1);
    one.layers[0].waypoints = all;
    let (toolpath, _, groups) = maamplan::job::stacked(&one, &part.platform, &config.beads, false);
    assert_eq!(
        toolpath.layers.len(),
        part.toolpath.layers.len(),
        "the layers found from how the beads stack"
    );
    Scene::build_deposited(&toolpath, &head(), &part.platform, &config, Some(groups)).unwrap()
}

/// Of the queries `clear` calls free, those that hold a point of the
/// deposited material inside the head (material with a stamp below the
/// query's cutoff).
fn into_material(
    scene: &Scene,
    part: &PrintedPart,
    queries: &[Query],
    clear: &[bool],
) -> Vec<usize> {
    let head = &scene.head.mesh;
    let (lo, hi) = head
        .vertices
        .iter()
        .fold(([f32::MAX; 3], [f32::MIN; 3]), |(lo, hi), v| {
            (
                [0, 1, 2].map(|i| lo[i].min(v[i])),
                [0, 1, 2].map(|i| hi[i].max(v[i])),
            )
        });
    let mut bad = Vec::new();
    for (i, q) in queries.iter().enumerate() {
        if !clear[i] {
            continue;
        }
        let g = q.to_gpu();
        let hit = part.material.iter().any(|&(p, stamp)| {
            if stamp >= q.cutoff {
                return false;
            }
            let h = to_head(&g, p);
            (0..3).all(|k| h[k] >= lo[k] && h[k] <= hi[k]) && winding_number(head, h) > 0.5
        });
        if hit {
            bad.push(i);
        }
    }
    bad
}

/// Poses with the nozzle tip just beside the material (0.05 to 1.5 mm
/// from a random sample of it), the axis within 80° of up, and the
/// material's own segment or up to 200 later ones printed.
fn near_material_queries(r: &mut ChaCha8Rng, part: &PrintedPart, count: usize) -> Vec<Query> {
    let last = part.material.iter().map(|m| m.1).max().unwrap_or(0);
    (0..count)
        .map(|_| {
            let (p, stamp) = part.material[r.random_range(0..part.material.len())];
            let off = loop {
                let v = [0; 3].map(|_| r.random_range(-1.0f32..1.0));
                let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                if (0.1..=1.0).contains(&l) {
                    break v.map(|c| c / l * r.random_range(0.05f32..1.5));
                }
            };
            let tip = [p[0] + off[0], p[1] + off[1], p[2] + off[2]];
            let up = pose(tip, [0.0, 0.0, 1.0]);
            let tilt: f64 = r.random_range(0.0f64..80.0).to_radians();
            let az: f64 = r.random_range(0.0..std::f64::consts::TAU);
            Query {
                pose: up.tilted(tilt, az),
                cutoff: (stamp + r.random_range(1..=200)).min(last + 1),
                margin: 0.0,
                slope: 0.0,
            }
        })
        .collect()
}

#[test]
fn a_pose_clear_of_the_beads_is_clear_of_the_deposited_material() {
    for seed in 0..4u64 {
        let mut r = rng(300 + seed);
        let tilt = [0.0, 15.0, 30.0, 45.0][seed as usize];
        let part = printed_part(&mut r, 4, DZ, WIDTH, tilt);
        for stacked in [false, true] {
            let scene = bead_scene(&part, stacked);
            assert_eq!(scene.part, PartSource::Beads);
            let mut queries = random_queries(&mut r, &scene, 200);
            queries.extend(near_material_queries(&mut r, &part, 600));
            let verdicts = CpuBackend::new(&scene).evaluate(&queries).unwrap();
            let clear: Vec<bool> = verdicts.iter().map(|&c| !c).collect();
            let free = clear.iter().filter(|&&c| c).count();
            assert!(free > 50, "seed {seed}: want free poses, got {free}");
            let bad = into_material(&scene, &part, &queries, &clear);
            assert!(
                bad.is_empty(),
                "seed {seed}, tilt {tilt}°, stacked {stacked}: {} poses called clear hold deposited material: {:?}",
                bad.len(),
                &bad[..bad.len().min(8)]
            );
        }
    }
}

/// The check above can fail: without the beads (only the platform
/// modelled) many poses called clear go into the material.
#[test]
fn without_the_beads_clear_poses_go_into_the_material() {
    let mut r = rng(300);
    let part = printed_part(&mut r, 4, DZ, WIDTH, 0.0);
    let scene = Scene::build(
        &part.toolpath,
        &head(),
        &part.platform,
        &cfg(PartModel::Surfaces),
    )
    .unwrap();
    assert_eq!(scene.part, PartSource::PlatformOnly);
    let mut queries = random_queries(&mut r, &scene, 200);
    queries.extend(near_material_queries(&mut r, &part, 600));
    let verdicts = CpuBackend::new(&scene).evaluate(&queries).unwrap();
    let clear: Vec<bool> = verdicts.iter().map(|&c| !c).collect();
    let bad = into_material(&scene, &part, &queries, &clear);
    assert!(
        bad.len() > 20,
        "only {} poses go into the material",
        bad.len()
    );
}

#[test]
fn bead_scenes_agree_with_brute_force() {
    for seed in 0..3u64 {
        let mut r = rng(400 + seed);
        let part = printed_part(&mut r, 3, DZ, WIDTH, 20.0 * seed as f64);
        let scene = bead_scene(&part, seed == 2);
        let base = random_queries(&mut r, &scene, 300);
        let truth_of = maamplan::collide::brute::BruteBackend::new(&scene);
        let cpu = CpuBackend::new(&scene);
        let parry = ParryBackend::new(&scene).unwrap();
        for margin in MARGINS {
            let queries = with_margin(&base, margin);
            let truth = truth_of.evaluate(&queries).unwrap();
            let hit = truth.iter().filter(|&&c| c).count();
            assert!(
                hit > 20 && hit + 20 < queries.len(),
                "seed {seed}: want both verdicts, {hit} of {}",
                queries.len()
            );
            for b in [&cpu as &dyn Backend, &parry] {
                let got = b.evaluate(&queries).unwrap();
                let what = format!("seed {seed}, margin {margin}, {} vs brute force", b.name());
                near_contacts_only(&scene, &queries, &truth, &got, &what);
            }
        }
    }
}

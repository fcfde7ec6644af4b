//! Shared helpers for integration tests: random scenes and a near-contact
//! measure for judging disagreements.
#![allow(dead_code)]

use maamplan::geometry::{Mesh, Pose, V3};
use maamplan::scene::{Query, Scene};
use maamplan::toolpath::{Layer, Toolpath, Waypoint};
use parry3d::math::{Matrix, Pose as PPose, Rotation, Vector};
use parry3d::shape::TriMesh;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Seeded RNG.
pub fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}

#[allow(unused_imports)]
pub use maamplan::default_job::star_head;

/// A bumpy height-field patch `z = base + amp·sin(fx·x)·cos(fy·y)` over
/// `[x0, x1] × [y0, y1]`, `n × n` quads.
pub fn height_patch(x: [f32; 2], y: [f32; 2], n: u32, f: impl Fn(f32, f32) -> f32) -> Mesh {
    let mut m = Mesh::default();
    for j in 0..=n {
        for i in 0..=n {
            let px = x[0] + (x[1] - x[0]) * i as f32 / n as f32;
            let py = y[0] + (y[1] - y[0]) * j as f32 / n as f32;
            m.vertices.push([px, py, f(px, py)]);
        }
    }
    let at = |i: u32, j: u32| j * (n + 1) + i;
    for j in 0..n {
        for i in 0..n {
            m.triangles.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            m.triangles.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    m
}

/// A random layered toolpath: `layers` bumpy patches stacked `dz` apart,
/// waypoints zig-zagging over each, plus a few tiny isolated triangles per
/// layer (so heads can swallow them whole).
pub fn random_toolpath(rng: &mut ChaCha8Rng, layers: usize, dz: f32) -> Toolpath {
    let ax: f32 = rng.random_range(0.1..0.4);
    let ay: f32 = rng.random_range(0.1..0.4);
    let amp: f32 = rng.random_range(0.5..3.0);
    let mut out = Toolpath::default();
    for k in 0..layers {
        let z0 = 1.0 + k as f32 * dz;
        let f = move |x: f32, y: f32| z0 + amp * (ax * x).sin() * (ay * y).cos();
        let mut surface = height_patch([-15.0, 15.0], [-10.0, 10.0], 24, f);
        // Isolated tiny triangles floating above the surface.
        for _ in 0..4 {
            let c = [
                rng.random_range(-12.0..12.0),
                rng.random_range(-8.0..8.0),
                0.0,
            ];
            let z = f(c[0], c[1]) + rng.random_range(2.0..8.0);
            let b = surface.vertices.len() as u32;
            let s: f32 = rng.random_range(0.05..0.4);
            surface.vertices.extend([
                [c[0], c[1], z],
                [c[0] + s, c[1], z],
                [c[0], c[1] + s, z + s * 0.3],
            ]);
            surface.triangles.push([b, b + 1, b + 2]);
        }
        let mut waypoints = Vec::new();
        for row in 0..10 {
            let y = -9.0 + 2.0 * row as f32;
            for col in 0..14 {
                let x = if row % 2 == 0 {
                    -14.0 + 2.0 * col as f32
                } else {
                    12.0 - 2.0 * col as f32
                };
                // Surface normal of the height field.
                let h = 1e-3;
                let gx = (f(x + h, y) - f(x - h, y)) / (2.0 * h);
                let gy = (f(x, y + h) - f(x, y - h)) / (2.0 * h);
                let l = (gx * gx + gy * gy + 1.0).sqrt();
                waypoints.push(Waypoint {
                    pos: [x, y, f(x, y)],
                    dir: [-gx / l, -gy / l, 1.0 / l],
                });
            }
        }
        out.layers.push(Layer {
            name: k.to_string(),
            waypoints,
            surface: Some(surface),
        });
    }
    out
}

/// Random queries near the printed surfaces: each waypoint's pose, moved a
/// little along its axis, tilted at random, with cutoffs anywhere in the
/// print (cutting layers in half), plus poses centred on the isolated
/// triangles.
pub fn random_queries(rng: &mut ChaCha8Rng, scene: &Scene, count: usize) -> Vec<Query> {
    let wq = &scene.waypoint_queries;
    let n = wq.len() as u32;
    (0..count)
        .map(|_| {
            let base = wq[rng.random_range(0..wq.len())];
            let tilt: f64 = rng.random_range(0.0f64..75.0).to_radians();
            let az: f64 = rng.random_range(0.0..std::f64::consts::TAU);
            let mut pose = base.pose.tilted(tilt, az);
            let lift: f32 = rng.random_range(-1.0..4.0);
            let a = pose.axis();
            pose.tip = [
                pose.tip[0] + a[0] * lift,
                pose.tip[1] + a[1] * lift,
                pose.tip[2] + a[2] * lift,
            ];
            let cutoff = if rng.random_bool(0.5) {
                base.cutoff
            } else {
                rng.random_range(1..=n + 1)
            };
            Query {
                pose,
                cutoff,
                margin: 0.0,
            }
        })
        .collect()
}

/// Distance between the head at `q` and the existing part triangles
/// (surfaces only), by parry — how "near" a contact is.
pub fn surface_distance(scene: &Scene, q: &Query) -> f32 {
    let tris: Vec<&maamplan::scene::GpuTriangle> = scene
        .part_tris
        .iter()
        .filter(|t| t.stamp < q.cutoff)
        .collect();
    if tris.is_empty() {
        return f32::INFINITY;
    }
    let v = |p: V3| Vector::new(p[0], p[1], p[2]);
    let verts: Vec<Vector> = tris
        .iter()
        .flat_map(|t| [v(t.v0), v(t.v1), v(t.v2)])
        .collect();
    let idx: Vec<[u32; 3]> = (0..tris.len() as u32)
        .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
        .collect();
    let part = TriMesh::new(verts, idx).expect("part mesh");
    let h = &scene.head.mesh;
    let head = TriMesh::new(
        h.vertices.iter().map(|p| v(*p)).collect(),
        h.triangles.clone(),
    )
    .expect("head mesh");
    let c = &q.pose.cols;
    let rot = Rotation::from_mat3(&Matrix::from_cols(v(c[0]), v(c[1]), v(c[2])));
    let pose = PPose::from_parts(v(q.pose.tip), rot);
    parry3d::query::distance(&pose, &head, &PPose::identity(), &part)
        .expect("distance")
        .distance
}

/// A pose with the head axis `axis` at `tip`.
pub fn pose(tip: V3, axis: V3) -> Pose {
    Pose::from_axis(tip, axis)
}

/// Compare `got` with `truth`: every disagreement must be a near-contact
/// (surfaces closer than 1e-3 mm), and is listed. Returns their count.
pub fn near_contacts_only(
    scene: &Scene,
    queries: &[Query],
    truth: &[bool],
    got: &[bool],
    what: &str,
) -> usize {
    let mut near = Vec::new();
    for (i, (t, g)) in truth.iter().zip(got).enumerate() {
        if t != g {
            let d = surface_distance(scene, &queries[i]);
            assert!(
                d < 1e-3,
                "{what}: query {i} ({:?}): {g} vs {t}, surfaces {d} mm apart",
                queries[i]
            );
            near.push((i, d));
        }
    }
    if !near.is_empty() {
        eprintln!("{what}: near-contact disagreements: {near:?}");
    }
    near.len()
}

/// The data set folder (`../shared/datasets/zhang2021`); fails loudly if absent.
pub fn data() -> std::path::PathBuf {
    let d = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/datasets/zhang2021");
    assert!(
        d.is_dir(),
        "the data set must sit at {} (see README)",
        d.display()
    );
    d
}

/// simple_curve with the data-set head and platform, placed as the original
/// software did (z + 40.5 mm): its toolpath and scene.
pub fn simple_curve() -> (Toolpath, Scene) {
    use maamplan::io::{mesh::load_mesh, toolpath::load_toolpath, Placement};
    let d = data();
    let place = Placement {
        y_up: false,
        offset: [0.0, 0.0, 40.5],
    };
    let tp = load_toolpath(&d.join("simple_curve"), &place).unwrap();
    let head = load_mesh(&d.join("extruderHead.obj")).unwrap();
    let platform = load_mesh(&d.join("printingPlatform.obj")).unwrap();
    let scene = Scene::build(
        &tp,
        &head,
        &platform,
        &maamplan::scene::SceneConfig::default(),
    )
    .unwrap();
    (tp, scene)
}

/// The embedded default job and its scene.
pub fn default_scene() -> (maamplan::default_job::Job, Scene) {
    let job = maamplan::default_job::job();
    let scene = Scene::build(
        &job.toolpath,
        &job.head,
        &job.platform,
        &maamplan::scene::SceneConfig::default(),
    )
    .unwrap();
    (job, scene)
}

//! Shared helpers for integration tests: random scenes, the margins to
//! sweep, a near-contact measure (brute force's f64 distance) for judging
//! disagreements, the plans several tests of a binary share (each planned
//! once per binary), and the `maamplan` command with its head cache in a
//! scratch folder of the test binary's own.
#![allow(dead_code)]

use maamplan::collide::brute::BruteBackend;
use maamplan::collide::cpu::CpuBackend;
use maamplan::geometry::{Mesh, Pose, V3};
use maamplan::kinematics::Machine;
use maamplan::plan::{plan, Plan, PlanOptions};
use maamplan::scene::{Query, Scene, SceneConfig};
use maamplan::toolpath::{Layer, Toolpath, Waypoint};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

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
                slope: 0.0,
            }
        })
        .collect()
}

/// How far the nearest existing part triangle is from its margin at `q`
/// (distance − margin, the margin grown by the query's slope), by brute
/// force in f64 (`BruteBackend::margin_slack`), capped at 0.01 mm — how
/// "near" a contact is.
pub fn margin_slack(scene: &Scene, q: &Query) -> f64 {
    BruteBackend::new(scene).margin_slack(q, 0.01)
}

/// The same queries with safety margin `margin` (mm).
pub fn with_margin(queries: &[Query], margin: f32) -> Vec<Query> {
    queries.iter().map(|q| Query { margin, ..*q }).collect()
}

/// The safety margins the differential tests sweep (mm).
pub const MARGINS: [f32; 4] = [0.0, 0.05, 0.3, 1.0];

/// Margins with a slope (mm, mm per mm) the differential tests sweep: the
/// planner's kind (a margin growing away from the tip), and a slope alone.
pub const SLOPED: [(f32, f32); 2] = [(0.05, 0.02), (0.0, 0.04)];

/// The same queries with margin `margin` growing by `slope` per mm from
/// the tip.
pub fn with_slope(queries: &[Query], margin: f32, slope: f32) -> Vec<Query> {
    queries
        .iter()
        .map(|q| Query {
            margin,
            slope,
            ..*q
        })
        .collect()
}

/// A pose with the head axis `axis` at `tip`.
pub fn pose(tip: V3, axis: V3) -> Pose {
    Pose::from_axis(tip, axis)
}

/// Compare `got` with `truth`: every disagreement must be a near-contact —
/// the nearest existing triangle within 1e-3 mm of its margin
/// ([`margin_slack`]; for margin 0, surfaces closer than 1e-3 mm) — and is
/// listed. Returns their count.
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
            let d = margin_slack(scene, &queries[i]);
            assert!(
                d.abs() < 1e-3,
                "{what}: query {i} ({:?}): {g} vs {t}, {d} mm beyond the margin",
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

/// simple_curve loaded as the CLI loads it (the data set's conventions
/// applied), with the data-set head and platform, placed as the original
/// software did (z + 40.5 mm).
pub fn simple_curve_job() -> maamplan::job::LoadedJob {
    simple_curve_job_tilted(None)
}

/// [`simple_curve_job`] with every nozzle direction rotated by `tilt_deg`
/// about x first (as `--tilt`).
pub fn simple_curve_job_tilted(tilt_deg: Option<f64>) -> maamplan::job::LoadedJob {
    let d = data();
    maamplan::job::LoadedJob::load(&maamplan::job::JobSpec {
        toolpath: Some(d.join("simple_curve")),
        head: Some(d.join("extruderHead.obj")),
        platform: Some(d.join("printingPlatform.obj")),
        placement: maamplan::io::Placement {
            y_up: false,
            offset: [0.0, 0.0, 40.5],
        },
        clearance: 0.3,
        tilt_deg,
        ..Default::default()
    })
    .unwrap()
}

/// simple_curve's toolpath and scene ([`simple_curve_job`]).
pub fn simple_curve() -> (Toolpath, Scene) {
    let job = simple_curve_job();
    (job.toolpath, job.scene)
}

/// The embedded default job and its scene.
pub fn default_scene() -> (maamplan::default_job::JobInputs, Scene) {
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

/// A small scene whose verdicts only the safety margin decides, with its
/// queries and the verdicts every backend must give.
pub struct MarginCase {
    /// What the case shows.
    pub what: &'static str,
    /// The scene (box head, no tip clearance).
    pub scene: Scene,
    /// The queries.
    pub queries: Vec<Query>,
    /// The verdict each query must get.
    pub expected: Vec<bool>,
}

/// A one-layer toolpath whose surface is `surface`, printed from `at`
/// with the nozzle up.
pub fn one_layer(surface: Mesh, at: V3) -> Toolpath {
    Toolpath {
        layers: vec![Layer {
            name: "0".into(),
            waypoints: vec![Waypoint {
                pos: at,
                dir: [0.0, 0.0, 1.0],
            }],
            surface: Some(surface),
        }],
    }
}

/// The two margin cases: a box head hovering 0.04 mm above a flat square
/// (face to face), and a triangle whose only close approach to the box
/// head is edge to edge (0.04 mm between skew edges; every vertex–face
/// distance is over 0.7 mm and every edge–plane crossing over 0.05 mm).
/// Both collide at margin 0.05 and are free at 0.03 and 0.
pub fn margin_cases() -> Vec<MarginCase> {
    use maamplan::default_job::box_mesh;
    use maamplan::scene::{HeadConfig, SceneConfig};
    let head = box_mesh([-2.0, -2.0, 0.0], [2.0, 2.0, 4.0]);
    let platform = box_mesh([-50.0, -50.0, -50.0], [50.0, 50.0, -49.0]);
    let cfg = |max_edge: Option<f32>| SceneConfig {
        head: HeadConfig {
            tip_clearance: 0.0,
            grid_resolution: 48,
        },
        max_edge,
        head_cache: false,
        ..SceneConfig::default()
    };
    let at = |tip: V3, margin: f32| Query {
        pose: pose(tip, [0.0, 0.0, 1.0]),
        cutoff: 2,
        margin,
        slope: 0.0,
    };
    let mut cases = Vec::new();

    // The head's bottom face 0.04 mm above the square at z = 1.
    let square = plate([-1.0, 1.0], [-1.0, 1.0], 1.0);
    let tp = one_layer(square, [0.0, 0.0, 1.0]);
    let scene = Scene::build(&tp, &head, &platform, &cfg(None)).unwrap();
    let hover = [0.0, 0.0, 1.04];
    cases.push(MarginCase {
        what: "head 0.04 mm above a square",
        scene,
        queries: vec![
            at(hover, 0.05),
            at(hover, 0.03),
            at(hover, 0.0),
            at(hover, 1.0),
            // Sideways and up: 0.3 mm edge to edge, diagonally.
            at(
                [3.0 + 0.3 / 2f32.sqrt(), 0.0, 1.0 + 0.3 / 2f32.sqrt()],
                0.29,
            ),
            at(
                [3.0 + 0.3 / 2f32.sqrt(), 0.0, 1.0 + 0.3 / 2f32.sqrt()],
                0.31,
            ),
        ],
        expected: vec![true, false, false, true, false, true],
    });

    // Skew edges: the head's edge x = 2, z = 4 and the triangle's edge AB,
    // 0.04 mm apart at (2, 0, 4) along (1, 0, 1)/√2. Not subdivided, so the
    // closest points stay inside the two edges.
    let s = std::f32::consts::FRAC_1_SQRT_2;
    let p = [2.0 + 0.04 * s, 0.0, 4.0 + 0.04 * s];
    let a = [p[0] + s, 0.0, p[2] - s];
    let b = [p[0] - s, 0.0, p[2] + s];
    let c = [
        p[0] + std::f32::consts::SQRT_2,
        3.0,
        p[2] + std::f32::consts::SQRT_2,
    ];
    let tri = Mesh {
        vertices: vec![a, b, c],
        triangles: vec![[0, 1, 2]],
    };
    let tp = one_layer(tri, c);
    let scene = Scene::build(&tp, &head, &platform, &cfg(Some(1000.0))).unwrap();
    let origin = [0.0, 0.0, 0.0];
    cases.push(MarginCase {
        what: "edge to edge, 0.04 mm",
        scene,
        queries: vec![at(origin, 0.05), at(origin, 0.03), at(origin, 0.0)],
        expected: vec![true, false, false],
    });
    cases
}

/// A scene of three random layers, an asymmetric star head of `rays` rays
/// (radii 4 to 4 + `spread` mm) leaning off its axis by `lean`, a box
/// platform, clearance 0.2 mm. The margin-flip tests share `(11, 3.0,
/// [-1.0, 0.8])`.
pub fn star_scene(r: &mut ChaCha8Rng, rays: usize, spread: f32, lean: [f32; 2]) -> Scene {
    use maamplan::default_job::box_mesh;
    use maamplan::scene::{HeadConfig, SceneConfig};
    let tp = random_toolpath(r, 3, 0.7);
    let radii: Vec<f32> = (0..rays)
        .map(|j| 4.0 + spread * ((j * 5 % rays) as f32 / rays as f32))
        .collect();
    let head = star_head(&radii, 6.0, 14.0, lean);
    let platform = box_mesh([-40.0, -40.0, -3.0], [40.0, 40.0, 0.0]);
    let cfg = SceneConfig {
        head: HeadConfig {
            tip_clearance: 0.2,
            grid_resolution: 48,
        },
        max_edge: None,
        head_cache: false,
        ..SceneConfig::default()
    };
    Scene::build(&tp, &head, &platform, &cfg).unwrap()
}

/// Queries straddling each free pose's own distance: for every query of
/// `base` that is free at margin 0 with the head's surface `d < cap` mm
/// from the nearest existing triangle (brute force, f64), the same pose at
/// margin `d + 2e-3` (must collide) and, when `d > 2e-3`, at `d − 2e-3`
/// (must stay free). 2e-3 mm is twice the near-contact allowance, so every
/// backend must give exactly these verdicts. Returns the queries and the
/// verdicts they must get.
pub fn margin_boundary_queries(scene: &Scene, base: &[Query], cap: f32) -> (Vec<Query>, Vec<bool>) {
    use maamplan::collide::Backend;
    let base = with_margin(base, 0.0);
    let brute = BruteBackend::new(scene);
    let free = brute.evaluate(&base).unwrap();
    let mut queries = Vec::new();
    let mut expected = Vec::new();
    for (q, hit) in base.iter().zip(free) {
        if hit {
            continue;
        }
        let d = brute.surface_distance(q, cap as f64) as f32;
        if d >= cap {
            continue;
        }
        queries.push(Query {
            margin: d + 2e-3,
            ..*q
        });
        expected.push(true);
        if d > 2e-3 {
            queries.push(Query {
                margin: d - 2e-3,
                ..*q
            });
            expected.push(false);
        }
    }
    (queries, expected)
}

/// `simulate`'s three stages on the cpu backend, as the command runs them.
#[allow(dead_code)]
pub fn simulate_cpu(
    toolpath: &Toolpath,
    scene: &Scene,
    m: &maamplan::kinematics::Machine,
    moves: &[maamplan::io::gcode_read::GcodeMove],
) -> maamplan::simulate::Simulation {
    use maamplan::simulate;
    let timeline = simulate::timeline(m, toolpath, moves);
    let mut scene = scene.clone();
    scene.restamp(|s| timeline.stamp(s));
    let cpu = maamplan::collide::cpu::CpuBackend::new(&scene);
    let (hits, queries) = simulate::check_moves(
        m,
        &cpu,
        &scene,
        m.margin,
        maamplan::plan::PlanOptions::default().edge_step,
        moves,
        &timeline.cutoffs,
        None,
    )
    .unwrap();
    simulate::report(
        m,
        moves,
        &timeline,
        &hits,
        queries,
        m.margin,
        simulate::Deviation::Sampled,
    )
}

/// A flat square of two triangles at height `z`.
#[allow(dead_code)]
pub fn plate(x: [f32; 2], y: [f32; 2], z: f32) -> Mesh {
    Mesh {
        vertices: vec![
            [x[0], y[0], z],
            [x[1], y[0], z],
            [x[1], y[1], z],
            [x[0], y[1], z],
        ],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
    }
}

/// The name of the test binary this module is compiled into.
fn binary_name() -> &'static str {
    module_path!().split("::").next().unwrap()
}

/// This test binary's own scratch folder (under Cargo's
/// `CARGO_TARGET_TMPDIR`), emptied the first time a test asks for it, so
/// that every run starts from nothing and nothing is written outside the
/// build folder.
pub fn scratch() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(binary_name());
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    })
}

/// The `maamplan` binary as a command: the head cache in this test
/// binary's scratch folder (`MAAMPLAN_CACHE_DIR`, never the user's home)
/// and Mesa's loader pointed at a harmless runtime folder.
pub fn maamplan() -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_maamplan"));
    command
        .env("MAAMPLAN_CACHE_DIR", scratch().join("cache"))
        .env("XDG_RUNTIME_DIR", std::env::temp_dir());
    command
}

/// Run the `maamplan` binary with `args` ([`maamplan`]).
pub fn cli(args: &[&str]) -> Output {
    maamplan().args(args).output().unwrap()
}

/// What a finished command wrote to stderr.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Panic with the command's stderr unless it succeeded.
pub fn assert_success(o: &Output) {
    assert!(o.status.success(), "{}", stderr(o));
}

/// A JSON file the CLI wrote.
pub fn read_json(path: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap()
}

/// `maamplan plan --backend cpu` with `args` on the embedded default job,
/// written into `name` in this binary's scratch folder; the folder. For
/// fixtures that run the command once per binary.
pub fn plan_default_job(name: &str, args: &[&str]) -> PathBuf {
    let out = scratch().join(name);
    let o = maamplan()
        .args(["plan", "--backend", "cpu"])
        .args(args)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    assert_success(&o);
    out
}

/// `plan` on the cpu backend, progress ignored.
pub fn plan_cpu(scene: &Scene, toolpath: &Toolpath, machine: &Machine, opts: &PlanOptions) -> Plan {
    let cpu = CpuBackend::new(scene);
    plan(scene, toolpath, machine, &cpu, opts, &mut |_| {}).unwrap()
}

/// The scene of `toolpath`, `head` and `platform` (default configuration)
/// and its plan on the cpu backend with the default options.
pub fn plan_scene(
    toolpath: &Toolpath,
    head: &Mesh,
    platform: &Mesh,
    machine: &Machine,
) -> (Scene, Plan) {
    let scene = Scene::build(toolpath, head, platform, &SceneConfig::default()).unwrap();
    let p = plan_cpu(&scene, toolpath, machine, &PlanOptions::default());
    (scene, p)
}

/// simple_curve ([`simple_curve_job`]) planned once per test binary with
/// the default machine and options on the cpu backend.
pub fn simple_curve_plan() -> &'static (maamplan::job::LoadedJob, Plan) {
    static PLAN: OnceLock<(maamplan::job::LoadedJob, Plan)> = OnceLock::new();
    PLAN.get_or_init(|| {
        let job = simple_curve_job();
        let p = plan_cpu(
            &job.scene,
            &job.toolpath,
            &Machine::default(),
            &PlanOptions::default(),
        );
        (job, p)
    })
}

/// The embedded default job ([`default_scene`]) planned once per test
/// binary with the default machine and options on the cpu backend.
pub fn default_plan() -> &'static (maamplan::default_job::JobInputs, Scene, Plan) {
    static PLAN: OnceLock<(maamplan::default_job::JobInputs, Scene, Plan)> = OnceLock::new();
    PLAN.get_or_init(|| {
        let (job, scene) = default_scene();
        let p = plan_cpu(
            &scene,
            &job.toolpath,
            &Machine::default(),
            &PlanOptions::default(),
        );
        (job, scene, p)
    })
}

/// `v` as a unit vector in f32.
pub fn unit(v: [f64; 3]) -> [f32; 3] {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    [(v[0] / l) as f32, (v[1] / l) as f32, (v[2] / l) as f32]
}

/// Write a job the CLI can read into `dir`: the toolpath folder `tp`,
/// `head.obj` and `platform.obj`. Returns the toolpath folder.
pub fn write_job(dir: &Path, toolpath: &Toolpath, head: &Mesh, platform: &Mesh) -> PathBuf {
    use maamplan::io::output::write_folder_atomic;
    use maamplan::io::toolpath_folder::{mesh_obj, toolpath_files};
    let tp = dir.join("tp");
    write_folder_atomic(&tp, &toolpath_files(toolpath)).unwrap();
    std::fs::write(dir.join("head.obj"), mesh_obj(head)).unwrap();
    std::fs::write(dir.join("platform.obj"), mesh_obj(platform)).unwrap();
    tp
}

/// A part printed in `layers` parallel curved layers `dz` apart on a
/// platform of the same shape, given as waypoints only (no surfaces), and
/// the material it deposits, sampled densely.
pub struct PrintedPart {
    /// The toolpath: each layer's passes side by side `width` apart, no
    /// surfaces.
    pub toolpath: Toolpath,
    /// The platform: the surface the first layer rests on.
    pub platform: Mesh,
    /// Points inside the deposited material (a bead `width` wide and `dz`
    /// deep under each printed segment, following the true surface), each
    /// with the stamp of the segment that laid it.
    pub material: Vec<(V3, u32)>,
}

/// [`PrintedPart`] over a random bumpy surface (slopes up to about 30°),
/// with every layer's nozzle axes tilted `tilt_deg` from the surface normal
/// in a random direction: the material follows the surface whatever the
/// nozzle does.
pub fn printed_part(
    rng: &mut ChaCha8Rng,
    layers: usize,
    dz: f64,
    width: f64,
    tilt_deg: f64,
) -> PrintedPart {
    use glam::DVec3;
    let ax: f64 = rng.random_range(0.1..0.3);
    let ay: f64 = rng.random_range(0.1..0.3);
    let amp: f64 = rng.random_range(0.5..1.5);
    let bump = move |x: f64, y: f64| amp * (ax * x).sin() * (ay * y).cos();
    let normal = |x: f64, y: f64| {
        let h = 1e-4;
        let gx = (bump(x + h, y) - bump(x - h, y)) / (2.0 * h);
        let gy = (bump(x, y + h) - bump(x, y - h)) / (2.0 * h);
        DVec3::new(-gx, -gy, 1.0).normalize()
    };
    let platform = height_patch([-30.0, 30.0], [-30.0, 30.0], 120, |x, y| {
        bump(x as f64, y as f64) as f32
    });
    let mut toolpath = Toolpath::default();
    let mut path: Vec<(DVec3, DVec3)> = Vec::new();
    for k in 0..layers {
        let z = (k + 1) as f64 * dz;
        let lean = DVec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            0.0,
        );
        let mut waypoints = Vec::new();
        for row in 0..12 {
            let y = -4.0 + width * row as f64;
            for col in 0..17 {
                let x = if row % 2 == 0 {
                    -8.0 + col as f64
                } else {
                    8.0 - col as f64
                };
                let n = normal(x, y);
                let off = (lean - n * lean.dot(n)).normalize_or(DVec3::X);
                let t = tilt_deg.to_radians();
                let dir = n * t.cos() + off * t.sin();
                let pos = DVec3::new(x, y, bump(x, y) + z);
                waypoints.push(Waypoint {
                    pos: pos.as_vec3().to_array(),
                    dir: dir.as_vec3().to_array(),
                });
                path.push((pos, n));
            }
        }
        toolpath.layers.push(Layer {
            name: k.to_string(),
            waypoints,
            surface: None,
        });
    }
    // The material under each segment within a layer (consecutive
    // waypoints of a layer are at most a pass width plus 1 mm apart).
    let per_layer = path.len() / layers.max(1);
    let mut material = Vec::new();
    for g in 1..path.len() {
        if g % per_layer == 0 {
            continue;
        }
        let ((a, na), (b, nb)) = (path[g - 1], path[g]);
        let t = (b - a).normalize();
        for s in 0..=4 {
            let at = a + (b - a) * (s as f64 / 4.0);
            let n = (na * (4 - s) as f64 + nb * s as f64).normalize();
            let side = t.cross(n).normalize();
            for u in [-0.4, 0.0, 0.4] {
                for d in [0.05, 0.5, 0.9] {
                    let p = at + side * (u * width) - n * (d * dz * n.z);
                    material.push((p.as_vec3().to_array(), maamplan::scene::stamp_of(g)));
                }
            }
        }
    }
    PrintedPart {
        toolpath,
        platform,
        material,
    }
}

/// Must the external tools (node with gltf-validator, chromium) be there?
/// (`MAAMPLAN_REQUIRE_TOOLS=1`, as CI sets.)
pub fn require_tools() -> bool {
    std::env::var("MAAMPLAN_REQUIRE_TOOLS").is_ok_and(|v| v == "1")
}

/// The repository's root.
pub fn manifest() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Run the Khronos validator on `glb`; `None` when it is not installed.
pub fn validate(glb: &Path) -> Option<serde_json::Value> {
    let script = manifest().join("tools/gltf_validate.cjs");
    let installed = manifest()
        .join("tools/node_modules/gltf-validator")
        .is_dir();
    let node = Command::new("node").arg("--version").output().is_ok();
    if !(installed && node) {
        assert!(!require_tools(), "MAAMPLAN_REQUIRE_TOOLS=1 but node or gltf-validator is missing (npm install --prefix tools)");
        eprintln!("skipping: node or gltf-validator missing (run `npm install --prefix tools`)");
        return None;
    }
    let out = Command::new("node").arg(script).arg(glb).output().unwrap();
    Some(
        serde_json::from_slice(&out.stdout)
            .unwrap_or_else(|_| panic!("validator said: {}", String::from_utf8_lossy(&out.stdout))),
    )
}

/// The first Chromium-like browser on the PATH.
pub fn chromium() -> Option<&'static str> {
    ["chromium", "chromium-browser", "google-chrome"]
        .into_iter()
        .find(|b| {
            Command::new(b)
                .arg("--version")
                .output()
                .is_ok_and(|o| o.status.success())
        })
}

/// A headless Chromium screenshot of `page`, `width` × `height`; `None`
/// (saying why) when there is no browser and the tools are not required.
pub fn screenshot(page: &Path, width: u32, height: u32) -> Option<image::RgbImage> {
    let Some(browser) = chromium() else {
        assert!(
            !require_tools(),
            "MAAMPLAN_REQUIRE_TOOLS=1 but chromium is missing"
        );
        eprintln!("skipping the screenshot: no chromium");
        return None;
    };
    let dir = tempfile::tempdir().unwrap();
    let shot = dir.path().join("shot.png");
    let s = Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--hide-scrollbars",
            "--disable-background-networking",
            "--disable-component-update",
            "--no-first-run",
        ])
        .arg(format!("--window-size={width},{height}"))
        .arg(format!("--screenshot={}", shot.display()))
        .arg(format!("file://{}", page.display()))
        .output()
        .unwrap();
    assert!(
        shot.is_file(),
        "no screenshot: {}",
        String::from_utf8_lossy(&s.stderr)
    );
    Some(image::open(&shot).unwrap().to_rgb8())
}

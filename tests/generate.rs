//! The toolpath generators end to end: paper 003's oblique cuboids with
//! and without cavities (MZZ vs zig-zag vs one-way, Table 1's pattern),
//! paper 001's deposition-rate curve on a saddle and on a plane, `slice`
//! followed by `plan`, waypoints on the planes / on the surface within the
//! chord error, the written folder read back, and malformed meshes through
//! the CLI (one line, exit 2, nothing written).

mod common;

use maamplan::collide::brute::mesh_distance64;
use maamplan::collide::cpu::CpuBackend;
use maamplan::default_job::{box_mesh, cone_head, height_field as grid};
use maamplan::generate::slice::frame;
use maamplan::generate::{
    isoplanar, slice, Fill, IsoplanarOptions, IsoplanarResult, SliceOptions, SliceResult,
};
use maamplan::geometry::Mesh;
use maamplan::io::output::write_folder_atomic;
use maamplan::io::toolpath_folder::{load_toolpath, mesh_obj, toolpath_files};
use maamplan::io::Placement;
use maamplan::kinematics::Machine;
use maamplan::plan::{plan, Plan, PlanOptions, Stage};
use maamplan::scene::{Scene, SceneConfig};
use maamplan::toolpath::Toolpath;
use std::path::Path;
use std::sync::OnceLock;

/// The paper's oblique direction.
fn oblique() -> [f64; 3] {
    let (b, c) = (30f64.to_radians(), 20f64.to_radians());
    [b.sin() * c.cos(), b.sin() * c.sin(), b.cos()]
}

/// A box `[0,a]×[0,b]×[0,c]` in the frame `(u, v, d)` of `d` (so slices
/// along `d` are rectangles aligned with the grid rows), lifted by `lift`
/// along z, with closed interior voids `cavities` (local min, max) wound
/// inwards.
fn oblique_cuboid(
    d: [f64; 3],
    size: [f32; 3],
    cavities: &[([f32; 3], [f32; 3])],
    lift: f32,
) -> Mesh {
    let (u, v) = frame(d);
    let mut m = box_mesh([0.0; 3], size);
    for (lo, hi) in cavities {
        let c = box_mesh(*lo, *hi);
        let base = m.vertices.len() as u32;
        m.vertices.extend(c.vertices);
        m.triangles.extend(
            c.triangles
                .iter()
                .map(|t| [base + t[0], base + t[2], base + t[1]]),
        );
    }
    m.map_vertices(|p| {
        let (x, y, z) = (p[0] as f64, p[1] as f64, p[2] as f64);
        [0, 1, 2].map(|k| (x * u[k] + y * v[k] + z * d[k]) as f32 + if k == 2 { lift } else { 0.0 })
    })
}

/// (within-layer path, within-layer travel, travel between layers).
fn path_length(mesh: &Mesh, fill: Fill) -> (f64, f64, f64) {
    let r = slice(
        mesh,
        &SliceOptions {
            dir: oblique(),
            layer: 2.0,
            spacing: 0.3,
            fill,
        },
    )
    .unwrap();
    let l = r.lengths();
    (
        l.total(),
        l.travel,
        r.layers.iter().map(|l| l.entry_length).sum(),
    )
}

/// Table 1's pattern on one geometry: MZZ no longer than zig-zag,
/// one-way the longest, MZZ starting each layer nearer where the last
/// ended; with no cavity MZZ is zig-zag and never travels, with cavities
/// it is shorter and travels less.
fn assert_table_1_pattern(name: &str, mesh: &Mesh, cavities: bool) {
    let (z, zt, ze) = path_length(mesh, Fill::Zigzag);
    let (o, ot, oe) = path_length(mesh, Fill::Oneway);
    let (m, mt, me) = path_length(mesh, Fill::Mzz);
    eprintln!(
        "{name}: zig-zag {z:.1} (travel {zt:.1}, between layers {ze:.1}), one-way {o:.1} (travel {ot:.1}, {oe:.1}), MZZ {m:.1} (travel {mt:.1}, {me:.1}), saving {:.1} %",
        100.0 * (z - m) / z
    );
    assert!(m <= z + 1e-6, "{name}: MZZ {m} longer than zig-zag {z}");
    assert!(
        o > z && o > m,
        "{name}: one-way {o} is not the longest ({z}, {m})"
    );
    // MZZ starts each layer near where the last one ended.
    assert!(me < ze, "{name}: MZZ between layers {me} vs zig-zag {ze}");
    if cavities {
        assert!(m < z - 1.0, "{name}: MZZ {m} not shorter than zig-zag {z}");
        assert!(mt < zt, "{name}: MZZ travels more");
    } else {
        assert!((m - z).abs() < 1e-6, "{name}: no cavity, MZZ = zig-zag");
        assert_eq!(zt, 0.0, "{name}: a plain zig-zag never travels");
    }
}

const CUBOID: [f32; 3] = [20.0, 20.0, 10.0];

#[test]
fn paper_003_table_1_pattern_solid() {
    let mesh = oblique_cuboid(oblique(), CUBOID, &[], 0.0);
    assert_table_1_pattern("(a) solid", &mesh, false);
}

#[test]
fn paper_003_table_1_pattern_one_cavity() {
    let cavity = ([5.0, 5.0, 1.5], [15.0, 15.0, 8.5]);
    let mesh = oblique_cuboid(oblique(), CUBOID, &[cavity], 0.0);
    assert_table_1_pattern("(b) one cavity", &mesh, true);
}

#[test]
fn paper_003_table_1_pattern_two_cavities() {
    let cavities = [
        ([3.0, 4.0, 1.5], [7.0, 16.0, 8.5]),
        ([13.0, 4.0, 1.5], [17.0, 16.0, 8.5]),
    ];
    let mesh = oblique_cuboid(oblique(), CUBOID, &cavities, 0.0);
    assert_table_1_pattern("(c) two cavities", &mesh, true);
}

#[test]
fn cavities_and_islands_are_respected() {
    // A solid with a void, and a smaller solid (an island) inside the void.
    let d = [0.0, 0.0, 1.0];
    let mut m = oblique_cuboid(
        d,
        [10.0, 10.0, 2.0],
        &[([2.0, 2.0, 0.5], [8.0, 8.0, 1.5])],
        0.0,
    );
    let island = box_mesh([4.0, 4.0, 0.5], [6.0, 6.0, 1.5]);
    let base = m.vertices.len() as u32;
    m.vertices.extend(island.vertices);
    m.triangles
        .extend(island.triangles.iter().map(|t| t.map(|i| i + base)));
    // Layers at 0.2, 0.6, 1.0, 1.4, 1.8: the middle three cross the void.
    let r = slice(
        &m,
        &SliceOptions {
            dir: d,
            layer: 0.4,
            spacing: 0.5,
            fill: Fill::Mzz,
        },
    )
    .unwrap();
    let inside_void = |p: [f32; 3]| {
        let inv = p[0] > 2.0 && p[0] < 8.0 && p[1] > 2.0 && p[1] < 8.0;
        let isl = p[0] > 4.0 && p[0] < 6.0 && p[1] > 4.0 && p[1] < 6.0;
        inv && !isl
    };
    let mut island_points = 0;
    for (k, l) in r.toolpath.layers.iter().enumerate() {
        let t = r.layers[k].offset as f32;
        let crosses = t > 0.5 && t < 1.5;
        for w in &l.waypoints {
            if crosses {
                assert!(!inside_void(w.pos), "layer {k}: {:?} is in the void", w.pos);
                if w.pos[0] > 4.0 && w.pos[0] < 6.0 && w.pos[1] > 4.0 && w.pos[1] < 6.0 {
                    island_points += 1;
                }
            }
        }
        let expected = if crosses { 400 - 144 + 16 } else { 400 };
        assert_eq!(l.waypoints.len(), expected, "layer {k} at {t}");
    }
    assert!(island_points > 0);
}

/// A small oblique cuboid with a cavity, sliced along the paper's
/// direction, the folder written and read back, and the read-back
/// toolpath planned (a wide cone head over a plate) — once.
struct Sliced {
    result: SliceResult,
    back: Toolpath,
    plan: Plan,
    /// The stages as progress reported them ending.
    ended: Vec<Stage>,
}

fn sliced() -> &'static Sliced {
    static SLICED: OnceLock<Sliced> = OnceLock::new();
    SLICED.get_or_init(|| {
        let part = oblique_cuboid(
            oblique(),
            [6.0, 6.0, 3.0],
            &[([2.0, 2.0, 0.8], [4.0, 4.0, 2.2])],
            1.0,
        );
        let result = slice(
            &part,
            &SliceOptions {
                dir: oblique(),
                layer: 1.0,
                spacing: 1.0,
                fill: Fill::Mzz,
            },
        )
        .unwrap();
        let out = common::scratch().join("sliced");
        write_folder_atomic(&out, &toolpath_files(&result.toolpath)).unwrap();
        let back = load_toolpath(&out, &Placement::default()).unwrap();
        let zmin = part
            .vertices
            .iter()
            .map(|v| v[2])
            .fold(f32::INFINITY, f32::min);
        let platform = box_mesh([-40.0, -40.0, zmin - 5.0], [40.0, 40.0, zmin]);
        let head = cone_head(20.0, 20.0, 30.0, 32);
        let scene = Scene::build(&back, &head, &platform, &SceneConfig::default()).unwrap();
        let backend = CpuBackend::new(&scene);
        let mut ended = Vec::new();
        let plan = plan(
            &scene,
            &back,
            &Machine::default(),
            &backend,
            &PlanOptions::default(),
            &mut |e| {
                if let maamplan::plan::Progress::Done(s) = e {
                    ended.push(s.clone());
                }
            },
        )
        .unwrap();
        Sliced {
            result,
            back,
            plan,
            ended,
        }
    })
}

/// Every waypoint on its slice plane, nozzle along the slicing direction.
#[test]
fn sliced_waypoints_lie_on_their_planes() {
    let r = &sliced().result;
    let d = oblique();
    let tp = &r.toolpath;
    assert!(tp.layers.len() >= 3, "{} layers", tp.layers.len());
    for (l, s) in tp.layers.iter().zip(&r.layers) {
        for w in &l.waypoints {
            let t: f64 = (0..3).map(|k| w.pos[k] as f64 * d[k]).sum();
            assert!((t - s.offset).abs() < 1e-4, "{t} vs {}", s.offset);
            assert!((0..3).all(|k| (w.dir[k] as f64 - d[k]).abs() < 1e-6));
        }
    }
}

#[test]
fn a_sliced_toolpath_reads_back_as_written() {
    let Sliced { result, back, .. } = sliced();
    let tp = &result.toolpath;
    assert_eq!(back.layers.len(), tp.layers.len());
    for (a, b) in back.layers.iter().zip(&tp.layers) {
        assert_eq!(a.name, b.name);
        assert_eq!(a.waypoints.len(), b.waypoints.len());
        for (x, y) in a.waypoints.iter().zip(&b.waypoints) {
            assert_eq!(x.pos, y.pos);
            assert!((0..3).all(|k| (x.dir[k] - y.dir[k]).abs() < 1e-6));
        }
        assert!(
            a.surface.as_ref().unwrap().triangles.len()
                == b.surface.as_ref().unwrap().triangles.len()
        );
    }
}

/// Planned, every waypoint is there, printable; every stage was reported
/// as it ended, with the figures the plan keeps.
#[test]
fn a_sliced_toolpath_plans_printably() {
    let Sliced {
        back, plan, ended, ..
    } = sliced();
    assert_eq!(plan.waypoints.len(), back.waypoint_count());
    assert_eq!(ended, &plan.stages);
    assert_plan_is_printable(plan, &Machine::default());
}

/// Planar layers need no tilt: the nozzle stays along the slicing
/// direction wherever nothing forces it away.
#[test]
fn planar_layers_keep_the_slicing_direction() {
    let p = &sliced().plan;
    let d = oblique();
    let along = p
        .waypoints
        .iter()
        .filter(|w| {
            w.skipped.is_none()
                && (0..3).map(|k| w.n[k] * d[k]).sum::<f64>() > (5f64.to_radians()).cos()
        })
        .count();
    assert!(
        along * 10 >= p.waypoints.len() * 9,
        "only {along} of {} waypoints keep the slicing direction",
        p.waypoints.len()
    );
}

/// What every plan must be: no pose or move within the margin, every
/// waypoint with a bead visited, the tip on its bead, no travel turning C
/// more than half a turn, within the machine's ranges.
fn assert_plan_is_printable(p: &maamplan::plan::Plan, m: &Machine) {
    assert_eq!(p.plan.residual_collisions, 0);
    assert_eq!(p.plan.colliding_edges, 0);
    assert_eq!(
        p.plan.skipped_waypoints - p.plan.isolated_waypoints,
        0,
        "{:?}",
        p.warnings
    );
    assert_eq!(p.plan.axis_limit_violations, 0);
    assert!(p.plan.tip_deviation_max_mm <= m.tip_tolerance + 1e-9);
    assert!(p.plan.travel_c_max_deg <= 180.0 + 1e-6);
    assert!(p.plan.program_moves > p.waypoints.len());
    assert!(p
        .waypoints
        .iter()
        .all(|w| w.axes.xyz.iter().all(|x| x.is_finite())));
}

const R: f32 = 20.0;

fn saddle() -> Mesh {
    grid(24, 10.0, |x, y| (x * x - y * y) / (2.0 * R) + 5.0)
}

/// The saddle's iso-planar toolpath with the default options, once.
fn saddle_isoplanar() -> &'static IsoplanarResult {
    static RESULT: OnceLock<IsoplanarResult> = OnceLock::new();
    RESULT.get_or_init(|| isoplanar(&saddle(), &IsoplanarOptions::default()).unwrap())
}

/// How far a curve of deposition rates is from mirror symmetry about 90°:
/// the largest relative difference between θ and 180° − θ.
fn asymmetry(c: &[maamplan::generate::isoplanar::CurvePoint]) -> f64 {
    let n = c.len() - 1;
    (0..=n)
        .map(|i| (c[i].v_e - c[n - i].v_e).abs() / c[i].v_e.max(c[n - i].v_e))
        .fold(0.0, f64::max)
}

#[test]
fn saddle_curve_is_symmetric_about_90_degrees() {
    let r = saddle_isoplanar();
    let c = &r.curve;
    assert_eq!(c.len(), 91);
    let n = c.len() - 1;
    for i in 0..=n {
        assert!((c[i].theta_deg + c[n - i].theta_deg - 180.0).abs() < 1e-9);
    }
    let worst = asymmetry(c);
    let hi = c.iter().map(|p| p.v_e).fold(0.0, f64::max);
    let lo = c.iter().map(|p| p.v_e).fold(f64::INFINITY, f64::min);
    eprintln!(
        "saddle: v_e from {lo:.3} to {hi:.3} mm³/s, θ* = {}°, asymmetry {worst:.2e}",
        r.theta_star_deg
    );
    assert!(worst < 1e-3, "asymmetry {worst}");
    // The normal turns at 1/R per mm in every direction on this saddle, so
    // the curve is shallow, but the B/C split still makes it vary.
    assert!(
        hi > 1.01 * lo,
        "the saddle's curve should not be flat: {lo}..{hi}"
    );
    assert!(r.theta_star_deg <= 90.0, "ties go to the first maximum");
}

/// The symmetry check can fail: a cylinder whose axis is 30° off x is not
/// mirror-symmetric about the y = 0 plane, and neither is its curve.
#[test]
fn a_tilted_cylinders_curve_is_not_symmetric() {
    let (c30, s30) = (30f32.to_radians().cos(), 30f32.to_radians().sin());
    let cyl = grid(24, 10.0, |x, y| {
        (x * c30 + y * s30).powi(2) / (2.0 * R) + 5.0
    });
    let c = isoplanar(&cyl, &IsoplanarOptions::default()).unwrap().curve;
    assert_eq!(c.len(), 91);
    let asym = asymmetry(&c);
    eprintln!("tilted cylinder: asymmetry {asym:.3}");
    assert!(asym > 0.01, "{asym}");
}

#[test]
fn plane_curve_is_flat() {
    for (a, b) in [(0.0f32, 0.0f32), (0.3, 0.1)] {
        let plane = grid(10, 10.0, |x, y| a * x + b * y + 2.0);
        let r = isoplanar(&plane, &IsoplanarOptions::default()).unwrap();
        let hi = r.curve.iter().map(|p| p.v_e).fold(0.0, f64::max);
        let lo = r.curve.iter().map(|p| p.v_e).fold(f64::INFINITY, f64::min);
        assert!(hi - lo <= 0.01 * hi, "plane {a},{b}: {lo}..{hi}");
        // Straight curves: one side step everywhere, the flat width π s / 4.
        let w = std::f64::consts::PI * 0.7 / 4.0;
        assert!(
            r.side_steps.iter().all(|s| (s - w).abs() < 1e-3 * w),
            "{:?}",
            r.side_steps
        );
    }
}

#[test]
fn isoplanar_waypoints_lie_on_the_surface_within_the_chord_error() {
    let mesh = saddle();
    let opts = IsoplanarOptions::default();
    let r = saddle_isoplanar();
    let wp = &r.toolpath.layers[0].waypoints;
    assert!(wp.len() > 100);
    let mut worst_chord = 0.0f64;
    for (k, w) in wp.iter().enumerate() {
        let p = w.pos.map(|x| x as f64);
        assert!(
            mesh_distance64(&mesh, p) < 1e-4,
            "waypoint {k} off the surface"
        );
        // Nozzle along the surface normal (analytic, within the mesh's error).
        let (x, y) = (p[0], p[1]);
        let n = [-x / R as f64, y / R as f64, 1.0];
        let l = (n[0] * n[0] + n[1] * n[1] + 1.0).sqrt();
        let cos: f64 = (0..3).map(|i| n[i] / l * w.dir[i] as f64).sum();
        assert!(
            cos > 3f64.to_radians().cos(),
            "waypoint {k}: nozzle {:?} vs normal",
            w.dir
        );
        if k > 0 {
            let a = wp[k - 1].pos.map(|x| x as f64);
            let len: f64 = (0..3).map(|i| (p[i] - a[i]).powi(2)).sum::<f64>().sqrt();
            if len < 2.0 * opts.max_step {
                for s in 1..8 {
                    let t = s as f64 / 8.0;
                    let q = [0, 1, 2].map(|i| a[i] + t * (p[i] - a[i]));
                    worst_chord = worst_chord.max(mesh_distance64(&mesh, q));
                }
            }
        }
    }
    eprintln!(
        "isoplanar saddle: {} waypoints, {} curves, θ* {}°, largest chord error {worst_chord:.4} mm",
        wp.len(),
        r.side_steps.len() + 1,
        r.theta_star_deg
    );
    assert!(worst_chord <= opts.chord_error + 1e-4, "{worst_chord}");
}

/// Zig-zag: consecutive curves are joined mostly by short links, and the
/// path covers the surface.
#[test]
fn isoplanar_curves_are_joined_by_short_links() {
    let r = saddle_isoplanar();
    assert!(
        r.travel_length < 0.1 * r.print_length,
        "travel {} print {}",
        r.travel_length,
        r.print_length
    );
    assert!(r.side_steps.len() > 20);
}

/// The saddle's iso-planar toolpath on a plate under a wide cone head.
fn saddle_scene() -> &'static Scene {
    static SCENE: OnceLock<Scene> = OnceLock::new();
    SCENE.get_or_init(|| {
        let mesh = saddle();
        let zmin = mesh
            .vertices
            .iter()
            .map(|v| v[2])
            .fold(f32::INFINITY, f32::min);
        let platform = box_mesh([-40.0, -40.0, zmin - 8.0], [40.0, 40.0, zmin - 3.0]);
        let head = cone_head(20.0, 20.0, 30.0, 32);
        Scene::build(
            &saddle_isoplanar().toolpath,
            &head,
            &platform,
            &SceneConfig::default(),
        )
        .unwrap()
    })
}

#[test]
fn isoplanar_then_plan_end_to_end() {
    let tp = &saddle_isoplanar().toolpath;
    let p = common::plan_cpu(
        saddle_scene(),
        tp,
        &Machine::default(),
        &PlanOptions::default(),
    );
    assert_eq!(p.waypoints.len(), tp.waypoint_count());
    assert_plan_is_printable(&p, &Machine::default());
    assert!(p.plan.speed_violation_pct <= p.input.speed_violation_pct);
}

/// Unsmoothed, the nozzle follows the surface normal: nothing collides,
/// so orientations move only in the singular region (α) and to spread
/// fast turns (the spread tolerance).
#[test]
fn unsmoothed_isoplanar_plans_keep_the_surface_normal() {
    let opts = PlanOptions {
        smoothing: maamplan::plan::smooth::Smoothing::None,
        ..PlanOptions::default()
    };
    let tp = &saddle_isoplanar().toolpath;
    let raw = common::plan_cpu(saddle_scene(), tp, &Machine::default(), &opts);
    assert_plan_is_printable(&raw, &Machine::default());
    let bound = (opts.alpha + opts.spread_tolerance).to_degrees() + 0.01;
    assert!(
        raw.plan.mean_deviation_deg < 1.0 && raw.plan.max_deviation_deg <= bound,
        "orientation change mean {:.2}°, max {:.2}° (bound {bound:.2}°)",
        raw.plan.mean_deviation_deg,
        raw.plan.max_deviation_deg
    );
}

/// Run the CLI with `args`: (exit code, stderr).
fn cli(args: &[&str]) -> (i32, String) {
    let out = common::cli(args);
    (out.status.code().unwrap_or(-1), common::stderr(&out))
}

/// Write `mesh` as `name` into `dir` and run `command` on it with `args`
/// and `-o out` (in `dir`): (exit code, stderr, the output folder).
fn generate(
    dir: &Path,
    command: &str,
    name: &str,
    mesh: &Mesh,
    args: &[&str],
) -> (i32, String, std::path::PathBuf) {
    let input = dir.join(name);
    std::fs::write(&input, mesh_obj(mesh)).unwrap();
    let out = dir.join(format!("out-{name}"));
    let (code, err) = cli(&[
        &[command, input.to_str().unwrap()],
        args,
        &["-o", out.to_str().unwrap()],
    ]
    .concat());
    (code, err, out)
}

#[test]
fn slice_writes_the_folder_and_its_summary() {
    let dir = tempfile::tempdir().unwrap();
    let part = oblique_cuboid([0.0, 0.0, 1.0], [4.0, 3.0, 2.0], &[], 0.0);
    let (code, err, out) = generate(
        dir.path(),
        "slice",
        "part.obj",
        &part,
        &[
            "--dir",
            "0,0,1",
            "--layer",
            "1",
            "--fill",
            "zigzag",
            "--spacing",
            "0.5",
        ],
    );
    assert_eq!(code, 0, "{err}");
    let s = common::read_json(&out.join("summary.json"));
    assert_eq!(s["layers"].as_array().unwrap().len(), 2);
    assert_eq!(s["total"]["waypoints"], 2 * 8 * 6);
    assert!(out.join("waypoint/1.txt").is_file() && out.join("layer/1.obj").is_file());
}

#[test]
fn isoplanar_writes_the_folder_and_its_summary() {
    let dir = tempfile::tempdir().unwrap();
    let surface = grid(8, 5.0, |x, y| (x * x - y * y) / 40.0);
    let (code, err, out) = generate(dir.path(), "isoplanar", "saddle.obj", &surface, &[]);
    assert_eq!(code, 0, "{err}");
    let s = common::read_json(&out.join("summary.json"));
    assert!(s["theta_star_deg"].is_number());
    assert_eq!(s["curve"].as_array().unwrap().len(), 91);
    assert!(out.join("waypoint/0.txt").is_file() && out.join("layer/0.obj").is_file());
}

/// Each of `commands` refuses `mesh` in one line naming the file and
/// saying `needle`, exit 2, and writes nothing.
fn assert_mesh_refused(commands: &[&str], mesh: &Mesh, needle: &str) {
    let dir = tempfile::tempdir().unwrap();
    for command in commands {
        let name = format!("{command}.obj");
        let (code, err, out) = generate(dir.path(), command, &name, mesh, &[]);
        assert_eq!(code, 2, "{command} {name}: {err}");
        let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
        assert_eq!(lines.len(), 1, "{err}");
        assert!(err.contains(&name) && err.contains(needle), "{err}");
        assert!(!out.exists(), "{command} {name} wrote output");
    }
}

/// A closed box.
fn closed() -> Mesh {
    box_mesh([0.0; 3], [2.0; 3])
}

/// The box with one triangle gone.
fn open() -> Mesh {
    let mut open = closed();
    open.triangles.pop();
    open
}

/// The box with a fin: a triangle on one of its edges (three triangles
/// at that edge).
fn fin() -> Mesh {
    let mut fin = closed();
    fin.vertices.push([5.0, 5.0, 5.0]);
    fin.triangles
        .push([fin.triangles[0][0], fin.triangles[0][1], 8]);
    fin
}

/// The box with a degenerate triangle (three points on a line) beside it.
fn degenerate() -> Mesh {
    let mut deg = closed();
    deg.vertices
        .extend([[0.5, 0.5, 0.5], [0.6, 0.6, 0.6], [0.7, 0.7, 0.7]]);
    deg.triangles.push([8, 9, 10]);
    deg
}

#[test]
fn slice_refuses_an_open_mesh() {
    assert_mesh_refused(&["slice"], &open(), "not closed");
}

#[test]
fn a_non_manifold_mesh_is_refused() {
    assert_mesh_refused(&["slice", "isoplanar"], &fin(), "non-manifold");
}

#[test]
fn a_degenerate_triangle_is_refused() {
    assert_mesh_refused(&["slice", "isoplanar"], &degenerate(), "degenerate");
}

/// An open surface is fine for isoplanar.
#[test]
fn isoplanar_takes_an_open_surface() {
    let dir = tempfile::tempdir().unwrap();
    let flat = grid(4, 2.0, |_, _| 0.0);
    let (code, err, _) = generate(dir.path(), "isoplanar", "open-ok.obj", &flat, &[]);
    assert_eq!(code, 0, "{err}");
}

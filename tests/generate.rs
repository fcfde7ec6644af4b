//! The toolpath generators end to end: paper 003's oblique cuboids with
//! and without cavities (MZZ vs zig-zag vs one-way, Table 1's pattern),
//! paper 001's deposition-rate curve on a saddle and on a plane, `slice`
//! followed by `plan`, waypoints on the planes / on the surface within the
//! chord error, the written folder read back, and malformed meshes through
//! the CLI (one line, exit 2, nothing written).

use maamplan::collide::cpu::CpuBackend;
use maamplan::default_job::{box_mesh, cone_head, height_field as grid};
use maamplan::generate::slice::frame;
use maamplan::generate::{isoplanar, slice, Fill, IsoplanarOptions, SliceOptions};
use maamplan::geometry::point_triangle_distance::point_triangle_distance;
use maamplan::geometry::Mesh;
use maamplan::io::output::write_folder_atomic;
use maamplan::io::toolpath_folder::{load_toolpath, mesh_obj, toolpath_files};
use maamplan::io::Placement;
use maamplan::kinematics::Machine;
use maamplan::plan::{plan, PlanOptions};
use maamplan::scene::{Scene, SceneConfig};
use std::process::Command;

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

#[test]
fn paper_003_table_1_pattern() {
    let d = oblique();
    let size = [20.0, 20.0, 10.0];
    let geometries = [
        ("(a) solid", oblique_cuboid(d, size, &[], 0.0)),
        (
            "(b) one cavity",
            oblique_cuboid(d, size, &[([5.0, 5.0, 1.5], [15.0, 15.0, 8.5])], 0.0),
        ),
        (
            "(c) two cavities",
            oblique_cuboid(
                d,
                size,
                &[
                    ([3.0, 4.0, 1.5], [7.0, 16.0, 8.5]),
                    ([13.0, 4.0, 1.5], [17.0, 16.0, 8.5]),
                ],
                0.0,
            ),
        ),
    ];
    for (k, (name, mesh)) in geometries.iter().enumerate() {
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
        if k == 0 {
            assert!((m - z).abs() < 1e-6, "{name}: no cavity, MZZ = zig-zag");
            assert_eq!(zt, 0.0, "{name}: a plain zig-zag never travels");
        } else {
            assert!(m < z - 1.0, "{name}: MZZ {m} not shorter than zig-zag {z}");
            assert!(mt < zt, "{name}: MZZ travels more");
        }
    }
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

#[test]
fn slice_then_plan_end_to_end() {
    let d = oblique();
    let part = oblique_cuboid(
        d,
        [6.0, 6.0, 3.0],
        &[([2.0, 2.0, 0.8], [4.0, 4.0, 2.2])],
        1.0,
    );
    let r = slice(
        &part,
        &SliceOptions {
            dir: d,
            layer: 1.0,
            spacing: 1.0,
            fill: Fill::Mzz,
        },
    )
    .unwrap();
    let tp = &r.toolpath;
    assert!(tp.layers.len() >= 3, "{} layers", tp.layers.len());
    // Every waypoint on its slice plane, nozzle along d.
    for (l, s) in tp.layers.iter().zip(&r.layers) {
        for w in &l.waypoints {
            let t: f64 = (0..3).map(|k| w.pos[k] as f64 * d[k]).sum();
            assert!((t - s.offset).abs() < 1e-4, "{t} vs {}", s.offset);
            assert!((0..3).all(|k| (w.dir[k] as f64 - d[k]).abs() < 1e-6));
        }
    }
    // Written and read back.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("tp");
    write_folder_atomic(&out, &toolpath_files(tp)).unwrap();
    let back = load_toolpath(&out, &Placement::default()).unwrap();
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
    let p = plan(
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
    assert_eq!(p.waypoints.len(), back.waypoint_count());
    // Every stage was reported as it ended, with the figures the plan keeps.
    assert_eq!(ended, p.stages);
    assert_plan_is_printable(&p, &Machine::default());
    // Planar layers need no tilt: the nozzle stays along the slicing
    // direction wherever nothing forces it away.
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

#[test]
fn saddle_curve_is_symmetric_about_90_degrees() {
    let r = isoplanar(&saddle(), &IsoplanarOptions::default()).unwrap();
    let c = &r.curve;
    assert_eq!(c.len(), 91);
    let n = c.len() - 1;
    let mut worst = 0.0f64;
    for i in 0..=n {
        let (a, b) = (c[i], c[n - i]);
        assert!((a.theta_deg + b.theta_deg - 180.0).abs() < 1e-9);
        worst = worst.max((a.v_e - b.v_e).abs() / a.v_e.max(b.v_e));
    }
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

    // The check can fail: a cylinder whose axis is 30° off x is not
    // mirror-symmetric about the y = 0 plane, and neither is its curve.
    let (c30, s30) = (30f32.to_radians().cos(), 30f32.to_radians().sin());
    let cyl = grid(24, 10.0, |x, y| {
        (x * c30 + y * s30).powi(2) / (2.0 * R) + 5.0
    });
    let c = isoplanar(&cyl, &IsoplanarOptions::default()).unwrap().curve;
    let asym = (0..=n)
        .map(|i| (c[i].v_e - c[n - i].v_e).abs() / c[i].v_e.max(c[n - i].v_e))
        .fold(0.0, f64::max);
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

fn distance_to_mesh(m: &Mesh, p: [f64; 3]) -> f64 {
    (0..m.triangles.len())
        .map(|i| {
            let [a, b, c] = m.corners(i).map(|v| v.map(|x| x as f64));
            point_triangle_distance(p, a, b, c)
        })
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn isoplanar_waypoints_lie_on_the_surface_within_the_chord_error() {
    let mesh = saddle();
    let opts = IsoplanarOptions::default();
    let r = isoplanar(&mesh, &opts).unwrap();
    let wp = &r.toolpath.layers[0].waypoints;
    assert!(wp.len() > 100);
    let mut worst_chord = 0.0f64;
    for (k, w) in wp.iter().enumerate() {
        let p = w.pos.map(|x| x as f64);
        assert!(
            distance_to_mesh(&mesh, p) < 1e-4,
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
                    worst_chord = worst_chord.max(distance_to_mesh(&mesh, q));
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
    // Zig-zag: consecutive curves are joined mostly by short links, and the path covers the surface.
    assert!(
        r.travel_length < 0.1 * r.print_length,
        "travel {} print {}",
        r.travel_length,
        r.print_length
    );
    assert!(r.side_steps.len() > 20);
}

#[test]
fn isoplanar_then_plan_end_to_end() {
    let mesh = saddle();
    let r = isoplanar(&mesh, &IsoplanarOptions::default()).unwrap();
    let zmin = mesh
        .vertices
        .iter()
        .map(|v| v[2])
        .fold(f32::INFINITY, f32::min);
    let platform = box_mesh([-40.0, -40.0, zmin - 8.0], [40.0, 40.0, zmin - 3.0]);
    let head = cone_head(20.0, 20.0, 30.0, 32);
    let scene = Scene::build(&r.toolpath, &head, &platform, &SceneConfig::default()).unwrap();
    let backend = CpuBackend::new(&scene);
    let p = plan(
        &scene,
        &r.toolpath,
        &Machine::default(),
        &backend,
        &PlanOptions::default(),
        &mut |_| {},
    )
    .unwrap();
    assert_eq!(p.waypoints.len(), r.toolpath.waypoint_count());
    assert_plan_is_printable(&p, &Machine::default());
    // Unsmoothed, the nozzle follows the surface normal: nothing collides,
    // so orientations move only in the singular region (α) and to spread
    // fast turns (the spread tolerance).
    let opts = PlanOptions {
        smoothing: maamplan::plan::smooth::Smoothing::None,
        ..PlanOptions::default()
    };
    let raw = plan(
        &scene,
        &r.toolpath,
        &Machine::default(),
        &backend,
        &opts,
        &mut |_| {},
    )
    .unwrap();
    assert_plan_is_printable(&raw, &Machine::default());
    let bound = (opts.alpha + opts.spread_tolerance).to_degrees() + 0.01;
    assert!(
        raw.plan.mean_deviation_deg < 1.0 && raw.plan.max_deviation_deg <= bound,
        "orientation change mean {:.2}°, max {:.2}° (bound {bound:.2}°)",
        raw.plan.mean_deviation_deg,
        raw.plan.max_deviation_deg
    );
    assert!(p.plan.speed_violation_pct <= p.input.speed_violation_pct);
}

fn cli(args: &[&str]) -> (i32, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_maamplan"))
        .args(args)
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn cli_writes_the_folder_and_summaries() {
    let dir = tempfile::tempdir().unwrap();
    let part = dir.path().join("part.obj");
    std::fs::write(
        &part,
        mesh_obj(&oblique_cuboid([0.0, 0.0, 1.0], [4.0, 3.0, 2.0], &[], 0.0)),
    )
    .unwrap();
    let out = dir.path().join("sliced");
    let (code, err) = cli(&[
        "slice",
        part.to_str().unwrap(),
        "--dir",
        "0,0,1",
        "--layer",
        "1",
        "--fill",
        "zigzag",
        "--spacing",
        "0.5",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(s["layers"].as_array().unwrap().len(), 2);
    assert_eq!(s["total"]["waypoints"], 2 * 8 * 6);
    assert!(out.join("waypoint/1.txt").is_file() && out.join("layer/1.obj").is_file());
    let surf = dir.path().join("saddle.obj");
    std::fs::write(
        &surf,
        mesh_obj(&grid(8, 5.0, |x, y| (x * x - y * y) / 40.0)),
    )
    .unwrap();
    let out2 = dir.path().join("iso");
    let (code, err) = cli(&[
        "isoplanar",
        surf.to_str().unwrap(),
        "-o",
        out2.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    let s: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out2.join("summary.json")).unwrap()).unwrap();
    assert!(s["theta_star_deg"].is_number());
    assert_eq!(s["curve"].as_array().unwrap().len(), 91);
    assert!(out2.join("waypoint/0.txt").is_file() && out2.join("layer/0.obj").is_file());
}

#[test]
fn malformed_meshes_are_one_line_errors_with_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let b = box_mesh([0.0; 3], [2.0; 3]);
    let mut open = b.clone();
    open.triangles.pop();
    let mut fin = b.clone();
    fin.vertices.push([5.0, 5.0, 5.0]);
    fin.triangles
        .push([fin.triangles[0][0], fin.triangles[0][1], 8]);
    let mut deg = b.clone();
    deg.vertices
        .extend([[0.5, 0.5, 0.5], [0.6, 0.6, 0.6], [0.7, 0.7, 0.7]]);
    deg.triangles.push([8, 9, 10]);
    let cases: [(&str, &Mesh, &str, &str); 5] = [
        ("open.obj", &open, "slice", "not closed"),
        ("fin.obj", &fin, "slice", "non-manifold"),
        ("fin2.obj", &fin, "isoplanar", "non-manifold"),
        ("deg.obj", &deg, "slice", "degenerate"),
        ("deg2.obj", &deg, "isoplanar", "degenerate"),
    ];
    for (name, mesh, cmd, needle) in cases {
        let p = dir.path().join(name);
        std::fs::write(&p, mesh_obj(mesh)).unwrap();
        let out = dir.path().join(format!("out-{name}"));
        let (code, err) = cli(&[cmd, p.to_str().unwrap(), "-o", out.to_str().unwrap()]);
        assert_eq!(code, 2, "{cmd} {name}: {err}");
        let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
        assert_eq!(lines.len(), 1, "{err}");
        assert!(err.contains(name) && err.contains(needle), "{err}");
        assert!(!out.exists(), "{cmd} {name} wrote output");
    }
    // An open surface is fine for isoplanar.
    let p = dir.path().join("open-ok.obj");
    std::fs::write(&p, mesh_obj(&grid(4, 2.0, |_, _| 0.0))).unwrap();
    let (code, err) = cli(&[
        "isoplanar",
        p.to_str().unwrap(),
        "-o",
        dir.path().join("ok").to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
}

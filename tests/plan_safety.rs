//! What the written program does, on small scenes built to provoke each
//! rule: a waypoint no orientation can reach is skipped (and `--strict`
//! refuses), a waypoint free only in a narrow cone far from its input gets
//! one, a move that collides only between its endpoints is caught, and the
//! machine's ranges are planned around.

use maamplan::collide::cpu::CpuBackend;
use maamplan::default_job::{box_mesh, cone_head};
use maamplan::geometry::Mesh;
use maamplan::io::gcode::{axes_of, read_program, write_gcode, GcodeHeader};
use maamplan::io::output::write_folder_atomic;
use maamplan::io::toolpath_folder::{mesh_obj, toolpath_files};
use maamplan::kinematics::{orientation, Axes, Machine};
use maamplan::plan::{head_reach, plan, Plan, PlanOptions, Skip};
use maamplan::prove::{displacement_bound, MoveSpec, Prover};
use maamplan::scene::{Scene, SceneConfig};
use maamplan::toolpath::{Layer, Toolpath, Waypoint};
use std::path::Path;
use std::process::Command;

fn unit(v: [f64; 3]) -> [f32; 3] {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    [(v[0] / l) as f32, (v[1] / l) as f32, (v[2] / l) as f32]
}

/// A flat strip `y ∈ [−w, w]` under `x ∈ [x0, x1]` at height `z`.
fn strip(x0: f32, x1: f32, w: f32, z: f32) -> Mesh {
    Mesh {
        vertices: vec![[x0, -w, z], [x1, -w, z], [x1, w, z], [x0, w, z]],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
    }
}

fn merge(mut a: Mesh, b: &Mesh) -> Mesh {
    let o = a.vertices.len() as u32;
    a.vertices.extend(&b.vertices);
    a.triangles
        .extend(b.triangles.iter().map(|t| [t[0] + o, t[1] + o, t[2] + o]));
    a
}

fn line(name: &str, xs: &[f32], y: f32, z: f32, dir: [f32; 3], surface: Mesh) -> Layer {
    Layer {
        name: name.into(),
        waypoints: xs
            .iter()
            .map(|&x| Waypoint {
                pos: [x, y, z],
                dir,
            })
            .collect(),
        surface: Some(surface),
    }
}

fn plan_of(tp: &Toolpath, head: &Mesh, platform: &Mesh, m: &Machine) -> (Scene, Plan) {
    let scene = Scene::build(tp, head, platform, &SceneConfig::default()).unwrap();
    let cpu = CpuBackend::new(&scene);
    let p = plan(&scene, tp, m, &cpu, &PlanOptions::default(), &mut |_| {}).unwrap();
    (scene, p)
}

/// How near any G-code line of `p`'s written program puts the tip to `at`.
fn nearest_written_tip(m: &Machine, p: &Plan, at: [f64; 3]) -> f64 {
    let text = write_gcode(m, &p.program, &GcodeHeader::default());
    read_program(&text, m)
        .unwrap()
        .iter()
        .map(|mv| dist(m.tip(&axes_of(&mv.to)), at))
        .fold(f64::INFINITY, f64::min)
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1]).hypot(a[2] - b[2])
}

/// Layer 1 runs through a small closed cube printed in layer 0: its middle
/// waypoint sits inside the cube, where every orientation collides.
fn caged() -> (Toolpath, Mesh, Mesh, usize) {
    let xs0: Vec<f32> = (0..9).map(|i| -12.0 + 3.0 * i as f32).collect();
    let cage = box_mesh([-0.6, -0.6, 2.4], [0.6, 0.6, 3.6]);
    let xs1: Vec<f32> = (0..13).map(|i| -9.0 + 1.5 * i as f32).collect();
    let tp = Toolpath {
        layers: vec![
            line(
                "0",
                &xs0,
                0.0,
                0.5,
                [0.0, 0.0, 1.0],
                merge(strip(-13.0, 13.0, 1.0, 0.5), &cage),
            ),
            line(
                "1",
                &xs1,
                0.0,
                3.0,
                unit([0.3, 0.0, 1.0]),
                strip(-10.0, 10.0, 0.5, 3.0),
            ),
        ],
    };
    let head = cone_head(5.0, 5.0, 8.0, 24);
    let platform = box_mesh([-40.0, -40.0, -2.0], [40.0, 40.0, 0.0]);
    // Waypoint x = 0 of layer 1.
    (tp, head, platform, 9 + 6)
}

#[test]
fn a_waypoint_every_orientation_of_which_collides_is_never_visited() {
    let (tp, head, platform, g) = caged();
    let m = Machine::default();
    let (_, p) = plan_of(&tp, &head, &platform, &m);
    assert_eq!(p.waypoints[g].skipped, Some(Skip::Residual));
    assert_eq!(p.plan.skipped_waypoints - p.plan.isolated_waypoints, 1);
    assert!(p
        .warnings
        .iter()
        .any(|w| w.contains(&format!("waypoint {g} "))));
    // Its neighbours are printed, the program keeps its margin.
    assert!(p.waypoints[g - 1].skipped.is_none() && p.waypoints[g + 1].skipped.is_none());
    assert_eq!(p.plan.residual_collisions, 0);
    assert_eq!(p.plan.colliding_edges, 0);
    // No line of the written program puts the tip there.
    let nearest = nearest_written_tip(&m, &p, p.waypoints[g].p);
    assert!(
        nearest > 0.5,
        "a G-code line puts the tip {nearest} mm from it"
    );
}

fn write_job(dir: &Path, tp: &Toolpath, head: &Mesh, platform: &Mesh) {
    write_folder_atomic(&dir.join("tp"), &toolpath_files(tp)).unwrap();
    std::fs::write(dir.join("head.obj"), mesh_obj(head)).unwrap();
    std::fs::write(dir.join("platform.obj"), mesh_obj(platform)).unwrap();
}

fn run(dir: &Path, extra: &[&str]) -> std::process::Output {
    let mut args: Vec<String> = vec![
        "plan".into(),
        dir.join("tp").display().to_string(),
        "--head".into(),
        dir.join("head.obj").display().to_string(),
        "--platform".into(),
        dir.join("platform.obj").display().to_string(),
        "--backend".into(),
        "cpu".into(),
        "--no-plots".into(),
    ];
    args.extend(extra.iter().map(|s| s.to_string()));
    Command::new(env!("CARGO_BIN_EXE_maamplan"))
        .args(&args)
        .output()
        .unwrap()
}

#[test]
fn skipped_waypoints_are_reported_and_strict_refuses() {
    let (tp, head, platform, g) = caged();
    let dir = tempfile::tempdir().unwrap();
    write_job(dir.path(), &tp, &head, &platform);
    let out = dir.path().join("out");
    let o = run(dir.path(), &["-o", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains(&format!("warning: waypoint {g} ")), "{err}");
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    let listed: Vec<(u64, String)> = r["skipped"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| {
            (
                s["index"].as_u64().unwrap(),
                s["reason"].as_str().unwrap().to_string(),
            )
        })
        .collect();
    assert!(
        listed.contains(&(g as u64, "residual".into())),
        "{listed:?}"
    );
    let csv = std::fs::read_to_string(out.join("plan.csv")).unwrap();
    let row = csv.lines().nth(1 + g).unwrap();
    assert!(row.ends_with(",residual"), "{row}");
    // --strict: exit 3, one line, nothing written.
    let out2 = dir.path().join("strict");
    let o = run(dir.path(), &["--strict", "-o", out2.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(3));
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(err.contains("--strict"), "{err}");
    assert!(!out2.exists());
    let leftovers: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().starts_with(".maamplan"))
        .collect();
    assert!(leftovers.is_empty());
}

/// A closed sphere of radius `r` around `c` with a round hole of angular
/// radius `psi` around direction `d`, built in rings about `d` so the
/// hole's rim is exact.
fn sphere_with_hole(c: [f64; 3], r: f64, d: [f64; 3], psi: f64) -> Mesh {
    let helper = if d[0].abs() < 0.9 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let norm = |a: [f64; 3]| {
        let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
        a.map(|x| x / l)
    };
    let u = norm(cross(d, helper));
    let v = cross(d, u);
    let (rings, seg) = (90usize, 180usize);
    let mut m = Mesh::default();
    for i in 0..=rings {
        let th = psi + (std::f64::consts::PI - psi) * i as f64 / rings as f64;
        for j in 0..seg {
            let ph = std::f64::consts::TAU * j as f64 / seg as f64;
            let (st, ct) = th.sin_cos();
            let (sp, cp) = ph.sin_cos();
            m.vertices.push(std::array::from_fn(|k| {
                (c[k] + r * (ct * d[k] + st * (cp * u[k] + sp * v[k]))) as f32
            }));
        }
    }
    let at = |i: usize, j: usize| (i * seg + j % seg) as u32;
    for i in 0..rings {
        for j in 0..seg {
            m.triangles.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            m.triangles.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    m
}

#[test]
fn a_narrow_free_cone_far_from_the_input_is_found() {
    // Two waypoints inside a sphere (radius 10) whose only opening, 7° in
    // angular radius, faces 75° away from their input orientation. The head
    // is a pencil (radius 0.3 mm) that fits through the opening only within
    // about 4° of its axis.
    let c = [0.0, 0.0, 20.0];
    let input = [10f64.to_radians().sin(), 0.0, 10f64.to_radians().cos()];
    let d = [-(65f64.to_radians().sin()), 0.0, 65f64.to_radians().cos()];
    let shell = sphere_with_hole(c, 10.0, d, 7f64.to_radians());
    let tp = Toolpath {
        layers: vec![
            line(
                "0",
                &[30.0, 31.0, 32.0],
                0.0,
                0.5,
                [0.0, 0.0, 1.0],
                merge(strip(29.0, 33.0, 1.0, 0.5), &shell),
            ),
            line(
                "1",
                &[-0.1, 0.1],
                0.0,
                20.0,
                unit(input),
                strip(-0.2, 0.2, 0.2, 20.0),
            ),
        ],
    };
    let pencil = cone_head(0.3, 0.3, 16.0, 16);
    let platform = box_mesh([-60.0, -60.0, -2.0], [60.0, 60.0, 0.0]);
    let m = Machine::default();
    let (_, p) = plan_of(&tp, &pencil, &platform, &m);
    for g in [3, 4] {
        let w = &p.waypoints[g];
        assert_eq!(w.skipped, None, "waypoint {g} skipped");
        let cos = w.n[0] * d[0] + w.n[1] * d[1] + w.n[2] * d[2];
        assert!(
            cos.acos().to_degrees() < 7.0,
            "waypoint {g} leaves through the opening: {}° from its axis",
            cos.acos().to_degrees()
        );
    }
    assert_eq!(p.plan.residual_collisions, 0);
    assert_eq!(p.plan.colliding_edges, 0);
    assert!(p.waypoints[3].was_colliding);
}

/// Two waypoints 3 mm apart, tilted 10° away from each other about y, and
/// a small triangle printed 12 mm above their midpoint: each pose clears
/// it, but the joint-linear move between them swings the head through
/// vertical, into it. The swing is slow enough to print (no dwell), so
/// only the motion check can stop the planner from printing it.
fn post_scene() -> (Toolpath, Mesh, Mesh) {
    let post = Mesh {
        vertices: vec![[-0.5, -0.5, 12.5], [0.5, -0.5, 12.5], [0.0, 0.5, 12.5]],
        triangles: vec![[0, 1, 2]],
    };
    let a = 10f64.to_radians();
    let tp = Toolpath {
        layers: vec![
            line(
                "0",
                &[20.0, 21.0],
                0.0,
                0.5,
                [0.0, 0.0, 1.0],
                merge(strip(19.0, 22.0, 1.0, 0.5), &post),
            ),
            Layer {
                name: "1".into(),
                waypoints: vec![
                    Waypoint {
                        pos: [-1.5, 0.0, 0.5],
                        dir: unit([-a.sin(), 0.0, a.cos()]),
                    },
                    Waypoint {
                        pos: [1.5, 0.0, 0.5],
                        dir: unit([a.sin(), 0.0, a.cos()]),
                    },
                ],
                surface: Some(strip(-2.0, 2.0, 0.5, 0.5)),
            },
        ],
    };
    // A slim cone: 5° half-angle.
    (
        tp,
        cone_head(1.0, 12.0, 15.0, 24),
        box_mesh([-40.0, -40.0, -2.0], [40.0, 40.0, 0.0]),
    )
}

#[test]
fn a_move_that_collides_only_between_its_endpoints_is_caught_and_counted() {
    let (tp, head, platform) = post_scene();
    let m = Machine::default();
    let scene = Scene::build(&tp, &head, &platform, &SceneConfig::default()).unwrap();
    let cpu = CpuBackend::new(&scene);
    let prover = Prover::new(&m, &cpu, head_reach(&scene), m.margin, 0.3);
    // The input's own move: B from 10° to −10° (direct IK), C fixed.
    let a = m.axes_at([-1.5, 0.0, 0.5], (10f64.to_radians(), 0.0));
    let b = m.axes_at([1.5, 0.0, 0.5], (-10f64.to_radians(), 0.0));
    assert!((orientation(m.rotary, a.tilt, a.c)[0] + 10f64.to_radians().sin()).abs() < 1e-6);
    let poses = prover.poses(&[(a, 3), (b, 4)]).unwrap();
    assert_eq!(poses, vec![false, false], "both endpoints are free");
    let hits = prover
        .moves(&[MoveSpec {
            from: a,
            to: b,
            cutoff: 3,
        }])
        .unwrap();
    assert_eq!(hits, vec![true], "the swing through vertical hits the post");

    let p = plan(&scene, &tp, &m, &cpu, &PlanOptions::default(), &mut |_| {}).unwrap();
    // Counted on the input, avoided by the plan (a break: lift, turn at
    // height, approach).
    assert_eq!(p.input.colliding_edges, 1);
    assert_eq!(p.plan.colliding_edges, 0);
    assert_eq!(p.plan.breaks, 1);
    assert_eq!(p.plan.residual_collisions, 0);
    // Re-checked independently: no move of the written program comes
    // within the margin at any of 400 poses along it.
    let moves = p.program.moves(&m);
    let specs: Vec<MoveSpec> = moves
        .iter()
        .filter(|(f, mv)| *f != mv.to)
        .map(|(f, mv)| MoveSpec {
            from: *f,
            to: mv.to,
            cutoff: mv.cutoff,
        })
        .collect();
    let dense = prover.sampled_moves(&specs, 0.01, 400).unwrap();
    assert!(dense.iter().all(|&h| !h));
    // check --plan counts the move when a plan makes it.
    let dir = tempfile::tempdir().unwrap();
    write_job(dir.path(), &tp, &head, &platform);
    let csv = dir.path().join("plan.csv");
    let row = |x: &Axes, travel: u8| {
        format!(
            "{:.3},{:.3},{:.3},{:.3},{:.3},{travel},0,\n",
            x.xyz[0],
            x.xyz[1],
            x.xyz[2],
            x.tilt.to_degrees(),
            x.c.to_degrees()
        )
    };
    let flat = |x: f64| m.axes_at([x, 0.0, 0.5], (0.0, 0.0));
    std::fs::write(
        &csv,
        format!(
            "X,Y,Z,B,C,section_start,break,skipped\n{}{}{}{}",
            row(&flat(20.0), 1),
            row(&flat(21.0), 0),
            row(&a, 1),
            row(&b, 0)
        ),
    )
    .unwrap();
    let json = dir.path().join("check.json");
    let o = Command::new(env!("CARGO_BIN_EXE_maamplan"))
        .args(["check", dir.path().join("tp").to_str().unwrap()])
        .args(["--head", dir.path().join("head.obj").to_str().unwrap()])
        .args([
            "--platform",
            dir.path().join("platform.obj").to_str().unwrap(),
        ])
        .args(["--backend", "cpu", "--plan", csv.to_str().unwrap()])
        .args(["--json", json.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(r["colliding"], 0, "{r}");
    assert_eq!(r["colliding_moves"], 1, "{r}");
    assert_eq!(r["colliding_moves_into"][0], 3, "{r}");
}

/// A turn swings a wide head's rim much farther than its tip (a 20 mm
/// cone turned 8° moves its rim ~5 mm), while the material a printing
/// move passes lies under the tip. The proof spaces its samples by the
/// tip's travel and lets the margin grow away from the tip, so such moves
/// need a fraction of the samples the rim's sweep would — and stay sound:
/// dense sampling finds nothing the proof let through.
#[test]
fn turning_moves_are_proven_by_the_tips_travel_not_the_rims() {
    let m = Machine::default();
    let floor = strip(-30.0, 30.0, 30.0, 0.0);
    let tp = Toolpath {
        layers: vec![line(
            "0",
            &[-20.0, 0.0, 20.0],
            0.0,
            0.0,
            [0.0, 0.0, 1.0],
            floor,
        )],
    };
    let head = cone_head(20.0, 20.0, 30.0, 64);
    let platform = box_mesh([-40.0, -40.0, -12.0], [40.0, 40.0, -10.0]);
    let scene = Scene::build(&tp, &head, &platform, &SceneConfig::default()).unwrap();
    let cpu = CpuBackend::new(&scene);
    let reach = head_reach(&scene);
    let prover = Prover::new(&m, &cpu, reach, m.margin, 0.3);
    let specs: Vec<MoveSpec> = (0..12)
        .map(|k| {
            let x = -6.0 + k as f64;
            let c = (10.0 * k as f64).to_radians();
            MoveSpec {
                from: m.axes_at([x, 0.0, 0.6], (10f64.to_radians(), c)),
                to: m.axes_at(
                    [x + 0.5, 0.1, 0.6],
                    (12f64.to_radians(), c + 8f64.to_radians()),
                ),
                cutoff: 10,
            }
        })
        .collect();
    let hits = prover.moves(&specs).unwrap();
    assert!(hits.iter().all(|&h| !h), "every move is free: {hits:?}");
    // What one margin for the whole head would have sampled.
    let rim: usize = specs
        .iter()
        .map(|mv| (displacement_bound(&m, &mv.from, &mv.to, reach) / 0.3).ceil() as usize - 1)
        .sum();
    let asked = prover.queries() as usize;
    eprintln!(
        "{asked} queries for {} moves; the rim's sweep: {rim} samples",
        specs.len()
    );
    assert!(asked * 2 < rim, "{asked} queries, the rim's sweep {rim}");
    // Sound: 400 poses along each move keep the margin.
    let dense = prover.sampled_moves(&specs, 0.01, 400).unwrap();
    assert!(dense.iter().all(|&h| !h));
}

/// Layer 1 runs over a flat strip printed in layer 0, every nozzle tipped
/// 60° towards +x: the cone's flank dips into the strip, so every
/// waypoint collides as given and needs a variant. With `caged`, its
/// middle waypoint sits inside a small closed cube printed in layer 0,
/// where every orientation collides.
fn tipped_run(n: usize, caged: bool) -> (Toolpath, Mesh, Mesh, usize) {
    let xs1: Vec<f32> = (0..n)
        .map(|i| -0.75 * (n / 2) as f32 + 0.75 * i as f32)
        .collect();
    let half = 0.75 * (n / 2) as f32 + 4.0;
    let mut floor = strip(-half, half, 6.0, 0.5);
    if caged {
        floor = merge(floor, &box_mesh([-0.4, -0.4, 0.6], [0.4, 0.4, 1.4]));
    }
    let tp = Toolpath {
        layers: vec![
            line(
                "0",
                &[-half + 1.0, half - 1.0],
                0.0,
                0.5,
                [0.0, 0.0, 1.0],
                floor,
            ),
            line(
                "1",
                &xs1,
                0.0,
                1.0,
                unit([60f64.to_radians().sin(), 0.0, 60f64.to_radians().cos()]),
                strip(-half, half, 6.0, 1.0),
            ),
        ],
    };
    let head = cone_head(5.0, 5.0, 8.0, 24);
    let platform = box_mesh([-60.0, -60.0, -2.0], [60.0, 60.0, 0.0]);
    (tp, head, platform, 2 + n / 2)
}

#[test]
fn a_caged_waypoint_inside_a_run_of_colliding_ones_is_skipped_and_its_section_split() {
    // The caged waypoint is no probe (its run's ends are), so its variants
    // are asked only when the search's path takes them: all die, the
    // eager search finds nothing either, and it is skipped mid-search —
    // its section split in two, both printed.
    let (tp, head, platform, g) = tipped_run(13, true);
    let m = Machine::default();
    let (_, p) = plan_of(&tp, &head, &platform, &m);
    assert!(
        p.input.residual_collisions >= 13,
        "the run collides as given"
    );
    assert_eq!(p.waypoints[g].skipped, Some(Skip::Residual));
    assert_eq!(p.plan.skipped_waypoints - p.plan.isolated_waypoints, 1);
    assert!(p.waypoints[g - 1].skipped.is_none() && p.waypoints[g + 1].skipped.is_none());
    assert!(
        p.waypoints[g + 1].section_start,
        "printing resumes after it as a new section"
    );
    assert_eq!(p.plan.residual_collisions, 0);
    assert_eq!(p.plan.colliding_edges, 0);
    let nearest = nearest_written_tip(&m, &p, p.waypoints[g].p);
    assert!(
        nearest > 0.5,
        "a G-code line puts the tip {nearest} mm from it"
    );
}

#[test]
fn colliding_waypoints_ask_only_what_their_path_takes() {
    // 400 waypoints that all collide as given. An eager column asks its
    // whole first round of variants (25 here) to keep up to 16 free ones,
    // of which the path takes one; the probes ask that for every 8th
    // waypoint and the others only the variants their path takes, so the
    // columns and the graph together ask a few queries a waypoint (6.7).
    let n = 400;
    let (tp, head, platform, _) = tipped_run(n, false);
    let m = Machine::default();
    let (_, p) = plan_of(&tp, &head, &platform, &m);
    assert!(
        p.input.residual_collisions >= n,
        "the run collides as given"
    );
    assert_eq!(p.plan.skipped_waypoints - p.plan.isolated_waypoints, 0);
    assert_eq!(p.plan.residual_collisions, 0);
    assert_eq!(p.plan.colliding_edges, 0);
    let asked = |stage: &str| p.stages.iter().find(|s| s.name == stage).unwrap().queries;
    let (columns, graph) = (asked("columns"), asked("graph"));
    assert!(
        columns + graph < 8 * n as u64,
        "columns {columns} + graph {graph} queries for {n} waypoints"
    );
}

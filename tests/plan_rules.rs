//! The machine's limits as constraints, the data set's input conventions,
//! the support extruder, and the command-line promises of `plan` and
//! `check`, each on a small scene built to exercise it.

mod common;

use common::{cli, plate};

use maamplan::collide::cpu::CpuBackend;
use maamplan::default_job::{box_mesh, cone_head};
use maamplan::geometry::Mesh;
use maamplan::io::gcode::{axes_of, read_program, write_gcode, GcodeHeader};
use maamplan::io::output::write_folder_atomic;
use maamplan::io::toolpath_folder::{mesh_obj, toolpath_files};
use maamplan::kinematics::Machine;
use maamplan::plan::{plan, Plan, PlanOptions, Skip};
use maamplan::scene::{Scene, SceneConfig};
use maamplan::toolpath::{Layer, Toolpath, Waypoint};
use std::path::Path;
use std::process::Command;

fn unit(v: [f64; 3]) -> [f32; 3] {
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    [(v[0] / l) as f32, (v[1] / l) as f32, (v[2] / l) as f32]
}

/// A straight row of waypoints along x at height `z`, nozzle `dir`, on its
/// own strip of surface.
fn row(name: &str, n: usize, z: f32, dir: [f32; 3]) -> Layer {
    Layer {
        name: name.into(),
        waypoints: (0..n)
            .map(|i| Waypoint {
                pos: [i as f32 * 0.6, 0.0, z],
                dir,
            })
            .collect(),
        surface: Some(plate([-0.5, n as f32 * 0.6], [-0.5, 0.5], z)),
    }
}

fn head() -> Mesh {
    cone_head(5.0, 5.0, 8.0, 24)
}

fn platform() -> Mesh {
    box_mesh([-60.0, -60.0, -2.0], [60.0, 60.0, 0.0])
}

fn plan_with(tp: &Toolpath, m: &Machine) -> Plan {
    let scene = Scene::build(tp, &head(), &platform(), &SceneConfig::default()).unwrap();
    let cpu = CpuBackend::new(&scene);
    plan(&scene, tp, m, &cpu, &PlanOptions::default(), &mut |_| {}).unwrap()
}

#[test]
fn the_tilt_range_is_a_constraint_of_the_search() {
    // Every nozzle direction leans 45°; the machine tilts 30° at most.
    let lean = unit([45f64.to_radians().sin(), 0.0, 45f64.to_radians().cos()]);
    let tp = Toolpath {
        layers: vec![row("0", 20, 0.6, lean), row("1", 20, 1.2, lean)],
    };
    let mut m = Machine::default();
    m.tilt.min = -30.0;
    m.tilt.max = 30.0;
    let p = plan_with(&tp, &m);
    assert!(p.input.axis_limit_violations > 0);
    assert_eq!(p.plan.skipped_waypoints, 0, "{:?}", p.warnings);
    assert_eq!(p.plan.axis_limit_violations, 0);
    for (_, mv) in p.program.moves(&m) {
        assert!(mv.to.tilt.to_degrees().abs() <= 30.0 + 1e-9);
    }
}

#[test]
fn a_c_range_is_planned_around() {
    // Three laps of a ring, nozzle leaning out 20°: C turns 1080°, the
    // machine's cables allow [−200°, 200°].
    let n = 3 * 126;
    let waypoints: Vec<Waypoint> = (0..n)
        .map(|i| {
            let a = i as f64 * std::f64::consts::TAU / 126.0;
            let t = 20f64.to_radians();
            Waypoint {
                pos: [(10.0 * a.cos()) as f32, (10.0 * a.sin()) as f32, 5.0],
                dir: unit([t.sin() * a.cos(), t.sin() * a.sin(), t.cos()]),
            }
        })
        .collect();
    let tp = Toolpath {
        layers: vec![Layer {
            name: "0".into(),
            waypoints,
            surface: None,
        }],
    };
    let mut m = Machine::default();
    m.c.range = Some([-200.0, 200.0]);
    let p = plan_with(&tp, &m);
    assert!(
        p.input.axis_limit_violations > 0,
        "the input winds beyond the range"
    );
    assert_eq!(p.plan.skipped_waypoints, 0);
    assert_eq!(p.plan.colliding_edges, 0);
    for (_, mv) in p.program.moves(&m) {
        let c = mv.to.c.to_degrees();
        assert!((-200.0 - 1e-9..=200.0 + 1e-9).contains(&c), "C {c}");
    }
    assert_eq!(p.plan.axis_limit_violations, 0);
    // Unwinding takes breaks: 1080° does not fit in 400° without them.
    assert!(p.plan.breaks >= 2, "{} breaks", p.plan.breaks);
}

#[test]
fn waypoints_outside_the_axis_ranges_are_unreachable_and_skipped() {
    // One waypoint of layer 1 sits 30 mm up; the machine's Z ends at 10 mm
    // and it tilts 10° at most, so no orientation brings it within range.
    let mut spike = row("1", 12, 1.2, [0.0, 0.0, 1.0]);
    spike.waypoints[6].pos[2] = 30.0;
    let tp = Toolpath {
        layers: vec![row("0", 12, 0.6, [0.0, 0.0, 1.0]), spike],
    };
    let mut m = Machine::default();
    m.z.max = 10.0;
    m.travel.home_z = 10.0;
    m.tilt.min = -10.0;
    m.tilt.max = 10.0;
    let p = plan_with(&tp, &m);
    let g = 12 + 6;
    assert_eq!(p.waypoints[g].skipped, Some(Skip::Unreachable));
    assert_eq!(p.plan.unreachable_waypoints, 1);
    assert_eq!(p.plan.axis_limit_violations, 0);
    assert!(p.warnings.iter().any(|w| w.contains("axis ranges")));
    for (_, mv) in p.program.moves(&m) {
        assert!(mv.to.xyz[2] <= 10.0 + 1e-9);
    }
}

#[test]
fn machine_z_below_zero_is_warned() {
    let tp = Toolpath {
        layers: vec![row("0", 10, -4.0, [0.0, 0.0, 1.0])],
    };
    let scene = Scene::build(
        &tp,
        &head(),
        &box_mesh([-60.0, -60.0, -7.0], [60.0, 60.0, -5.0]),
        &SceneConfig::default(),
    )
    .unwrap();
    let m = Machine::default();
    let p = plan(
        &scene,
        &tp,
        &m,
        &CpuBackend::new(&scene),
        &PlanOptions::default(),
        &mut |_| {},
    )
    .unwrap();
    assert!(
        p.warnings.iter().any(|w| w.contains("machine Z below 0")),
        "{:?}",
        p.warnings
    );
}

#[test]
fn support_layers_use_the_support_extruder() {
    let up = [0.0, 0.0, 1.0];
    let tp = Toolpath {
        layers: vec![
            row("0", 15, 0.5, up),
            row("1S", 15, 1.0, up),
            row("2", 15, 1.5, up),
        ],
    };
    let m = Machine::default();
    let p = plan_with(&tp, &m);
    assert!(p.waypoints[15].support && !p.waypoints[0].support);
    let text = write_gcode(&m, &p.program, &GcodeHeader::default());
    // The switch to T2 and back to T1, each waiting for its temperature,
    // happens at the safe height: between a lift and the travel.
    let lines: Vec<&str> = text.lines().collect();
    let t2 = lines
        .iter()
        .position(|l| *l == "T2")
        .expect("a change to T2");
    assert!(lines[t2 + 1].starts_with("M109 S205 T2"));
    assert!(lines[t2 - 1].starts_with("G0 Z"), "{}", lines[t2 - 1]);
    let t1 = lines[t2..]
        .iter()
        .position(|l| *l == "T1")
        .expect("back to T1")
        + t2;
    // Extrusion per millimetre of bead: the support's is 0.9 of the main's
    // (equal layer heights here); its feed is 2500 mm/min.
    let moves = read_program(&text, &m).unwrap();
    let rate = |from: usize, to: usize| {
        let (mut e, mut l) = (0.0, 0.0);
        for mv in moves
            .iter()
            .filter(|mv| mv.line > from && mv.line < to && mv.de > 0.0 && mv.from != mv.to)
        {
            e += mv.de;
            let (a, b) = (m.tip(&axes_of(&mv.from)), m.tip(&axes_of(&mv.to)));
            l += (a[0] - b[0]).hypot(a[1] - b[1]).hypot(a[2] - b[2]);
        }
        e / l
    };
    let main = rate(0, t2);
    let support = rate(t2, t1);
    assert!(
        (support / main - 0.9).abs() < 0.01,
        "support {support} vs main {main}"
    );
    let support_feeds: Vec<f64> = moves
        .iter()
        .filter(|mv| mv.line > t2 && mv.line < t1 && mv.de > 0.0 && mv.from != mv.to)
        .map(|mv| mv.f)
        .collect();
    assert!(
        support_feeds.iter().all(|&f| f == 2500.0),
        "{support_feeds:?}"
    );
}

fn write_folder(dir: &Path, tp: &Toolpath) -> String {
    let p = dir.join("tp");
    write_folder_atomic(&p, &toolpath_files(tp)).unwrap();
    std::fs::write(dir.join("head.obj"), mesh_obj(&head())).unwrap();
    std::fs::write(dir.join("platform.obj"), mesh_obj(&platform())).unwrap();
    p.display().to_string()
}

#[test]
fn downward_layers_are_reversed_and_named_unless_kept() {
    let up = [0.0, 0.0, 1.0];
    let tp = Toolpath {
        layers: vec![row("0", 10, 0.6, up), row("1", 10, 1.2, [0.0, 0.0, -1.0])],
    };
    let dir = tempfile::tempdir().unwrap();
    let tpath = write_folder(dir.path(), &tp);
    let head = dir.path().join("head.obj").display().to_string();
    let plat = dir.path().join("platform.obj").display().to_string();
    let base = [
        "plan",
        &tpath,
        "--head",
        &head,
        "--platform",
        &plat,
        "--backend",
        "cpu",
        "--no-plots",
    ];
    let out = dir.path().join("out");
    let o = cli(&[&base[..], &["-o", out.to_str().unwrap()]].concat());
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("reversed the nozzle directions of 1 layer(s)"),
        "{stdout}"
    );
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    assert_eq!(r["flipped_layers"], serde_json::json!(["1"]));
    assert_eq!(r["plan"]["skipped_waypoints"], 0);
    // Kept as stored, the downward nozzles point into the layer below.
    let kept = dir.path().join("kept");
    let o = cli(&[&base[..], &["--keep-normals", "-o", kept.to_str().unwrap()]].concat());
    assert!(o.status.success());
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(kept.join("report.json")).unwrap()).unwrap();
    assert_eq!(r["flipped_layers"], serde_json::json!([]));
    assert!(r["input"]["residual_collisions"].as_u64().unwrap() >= 10);
}

#[test]
fn the_output_folder_is_checked_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("taken");
    std::fs::write(&file, "x").unwrap();
    // A toolpath that does not exist: the -o problem is found first.
    let o = cli(&["plan", "/no/such/toolpath", "-o", file.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("taken") && err.contains("is a file"), "{err}");
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "x");
    // Inside a file: cannot be created.
    let o = cli(&[
        "plan",
        "/no/such/toolpath",
        "-o",
        file.join("sub").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    // No -o at all: a usage error naming it.
    let o = cli(&["plan"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--out"));
}

/// Rows of a plan.csv as maps.
fn csv_rows(path: &Path) -> Vec<std::collections::HashMap<String, String>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let head: Vec<String> = lines.next().unwrap().split(',').map(String::from).collect();
    lines
        .map(|l| {
            head.iter()
                .cloned()
                .zip(l.split(',').map(String::from))
                .collect()
        })
        .collect()
}

#[test]
fn check_and_plan_pose_the_head_alike_and_count_the_same_flags() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let o = cli(&[
        "plan",
        "--backend",
        "cpu",
        "--no-plots",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let json = dir.path().join("check.json");
    let o = cli(&[
        "check",
        "--backend",
        "cpu",
        "--json",
        json.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let c: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let rows = csv_rows(&out.join("plan.csv"));
    let was: Vec<u64> = rows
        .iter()
        .enumerate()
        .filter(|(_, r)| r["was_colliding"] == "1")
        .map(|(i, _)| i as u64)
        .collect();
    let checked: Vec<u64> = c["colliding_waypoints"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_u64().unwrap())
        .collect();
    assert!(!was.is_empty());
    assert_eq!(was, checked, "check and plan disagree on the input's poses");
    // plan.csv's flags are what report.json counts.
    let r: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    let count = |k: &str| rows.iter().filter(|r| r[k] == "1").count() as u64;
    assert_eq!(
        count("singular"),
        r["plan"]["singular_waypoints"].as_u64().unwrap()
    );
    assert_eq!(
        count("was_singular"),
        r["input"]["singular_waypoints"].as_u64().unwrap()
    );
    assert_eq!(
        count("was_colliding"),
        r["input"]["residual_collisions"].as_u64().unwrap()
    );
    assert!(count("was_singular") > 0);
    // check --plan re-checks the written plan: poses and printing moves.
    let o = cli(&[
        "check",
        "--backend",
        "cpu",
        "--plan",
        out.join("plan.csv").to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let c: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(c["colliding"], 0);
    assert_eq!(c["colliding_moves"], 0);
    assert!(c["moves"].as_u64().unwrap() > 1000);
}

/// Under `-v` with stdout piped, each stage's line arrives as the stage
/// ends, not with the summary: the load line is readable while the
/// planner still works (nothing written yet).
#[test]
fn verbose_stage_lines_arrive_as_stages_end_when_piped() {
    use std::io::{BufRead, BufReader};
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    // The embedded default job: seconds of planning after its load.
    let mut child = Command::new(env!("CARGO_BIN_EXE_maamplan"))
        .args(["plan", "--backend", "cpu", "--no-plots", "-v", "-o"])
        .arg(&out)
        .env("XDG_RUNTIME_DIR", std::env::temp_dir())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let mut lines = BufReader::new(child.stdout.take().unwrap()).lines();
    let first = lines.next().unwrap().unwrap();
    let planning = !out.join("report.json").exists();
    child.kill().ok();
    child.wait().ok();
    assert!(first.starts_with("stage load"), "{first}");
    assert!(first.trim_end().ends_with(" s"), "{first}");
    assert!(
        planning,
        "the first stage line came only after the run ended"
    );
}

//! The machine's limits as constraints, the data set's input conventions,
//! the support extruder, and the command-line promises of `plan` and
//! `check`, each on a small scene built to exercise it.

mod common;

use common::{assert_success, cli, plate, read_json, unit};

use maamplan::default_job::{box_mesh, cone_head};
use maamplan::geometry::Mesh;
use maamplan::io::gcode::{axes_of, read_program, write_gcode, GcodeHeader};
use maamplan::io::gcode_read::GcodeMove;
use maamplan::kinematics::Machine;
use maamplan::plan::{Plan, PlanOptions, Skip};
use maamplan::scene::{Scene, SceneConfig};
use maamplan::toolpath::{Layer, Toolpath, Waypoint};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

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
    common::plan_scene(tp, &head(), &platform(), m).1
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
    let p = common::plan_cpu(&scene, &tp, &Machine::default(), &PlanOptions::default());
    assert!(
        p.warnings.iter().any(|w| w.contains("machine Z below 0")),
        "{:?}",
        p.warnings
    );
}

/// Three rows, the middle one a support layer (its name ends in S),
/// planned and written once.
struct SupportJob {
    plan: Plan,
    /// The G-code's lines.
    lines: Vec<String>,
    /// The G-code read back.
    moves: Vec<GcodeMove>,
    /// The index of the line changing to T2.
    t2: usize,
    /// The index of the line changing back to T1.
    t1: usize,
}

fn support_job() -> &'static SupportJob {
    static JOB: OnceLock<SupportJob> = OnceLock::new();
    JOB.get_or_init(|| {
        let up = [0.0, 0.0, 1.0];
        let tp = Toolpath {
            layers: vec![
                row("0", 15, 0.5, up),
                row("1S", 15, 1.0, up),
                row("2", 15, 1.5, up),
            ],
        };
        let m = Machine::default();
        let plan = plan_with(&tp, &m);
        let text = write_gcode(&m, &plan.program, &GcodeHeader::default());
        let lines: Vec<String> = text.lines().map(String::from).collect();
        let t2 = lines
            .iter()
            .position(|l| *l == "T2")
            .expect("a change to T2");
        let t1 = lines[t2..]
            .iter()
            .position(|l| *l == "T1")
            .expect("back to T1")
            + t2;
        let moves = read_program(&text, &m).unwrap();
        SupportJob {
            plan,
            lines,
            moves,
            t2,
            t1,
        }
    })
}

#[test]
fn support_layers_are_marked_support() {
    let p = &support_job().plan;
    assert!(p.waypoints[15].support && !p.waypoints[0].support);
}

/// The switch to T2 and back to T1, each waiting for its temperature,
/// happens at the safe height: between a lift and the travel.
#[test]
fn the_extruder_changes_at_the_safe_height() {
    let SupportJob { lines, t2, .. } = support_job();
    assert!(lines[t2 + 1].starts_with("M109 S205 T2"));
    assert!(lines[t2 - 1].starts_with("G0 Z"), "{}", lines[t2 - 1]);
}

/// The extruding moves between lines `from` and `to` (moves that go
/// somewhere).
fn extruding_between(from: usize, to: usize) -> impl Iterator<Item = &'static GcodeMove> {
    support_job()
        .moves
        .iter()
        .filter(move |mv| mv.line > from && mv.line < to && mv.de > 0.0 && mv.from != mv.to)
}

/// Extrusion per millimetre of bead: the support's is 0.9 of the main's
/// (equal layer heights here).
#[test]
fn support_extrudes_its_own_rate() {
    let SupportJob { t2, t1, .. } = *support_job();
    let m = Machine::default();
    let rate = |from: usize, to: usize| {
        let (mut e, mut l) = (0.0, 0.0);
        for mv in extruding_between(from, to) {
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
}

/// The support's feed is 2500 mm/min.
#[test]
fn support_prints_at_its_own_feed() {
    let SupportJob { t2, t1, .. } = *support_job();
    let support_feeds: Vec<f64> = extruding_between(t2, t1).map(|mv| mv.f).collect();
    assert!(
        support_feeds.iter().all(|&f| f == 2500.0),
        "{support_feeds:?}"
    );
}

/// Two rows, the second's nozzles pointing down, written as a job into
/// a fresh folder and planned by the CLI (with `extra` options): the
/// report it wrote.
fn plan_downward_layers(extra: &[&str]) -> serde_json::Value {
    let up = [0.0, 0.0, 1.0];
    let tp = Toolpath {
        layers: vec![row("0", 10, 0.6, up), row("1", 10, 1.2, [0.0, 0.0, -1.0])],
    };
    let dir = tempfile::tempdir().unwrap();
    let tpath = common::write_job(dir.path(), &tp, &head(), &platform());
    let out = dir.path().join("out");
    let o = common::maamplan()
        .arg("plan")
        .arg(&tpath)
        .arg("--head")
        .arg(dir.path().join("head.obj"))
        .arg("--platform")
        .arg(dir.path().join("platform.obj"))
        .args(["--backend", "cpu", "--no-plots", "-q"])
        .args(extra)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    assert_success(&o);
    read_json(&out.join("report.json"))
}

#[test]
fn downward_layers_are_reversed_and_named() {
    let r = plan_downward_layers(&[]);
    assert_eq!(r["flipped_layers"], serde_json::json!(["1"]));
    assert_eq!(r["plan"]["skipped_waypoints"], 0);
}

/// Kept as stored, the downward nozzles point into the layer below.
#[test]
fn kept_normals_point_downward_layers_into_the_layer_below() {
    let r = plan_downward_layers(&["--keep-normals"]);
    assert_eq!(r["flipped_layers"], serde_json::json!([]));
    assert!(r["input"]["residual_collisions"].as_u64().unwrap() >= 10);
}

/// A toolpath that does not exist: the -o problem is found first.
#[test]
fn an_output_folder_that_is_a_file_is_refused_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("taken");
    std::fs::write(&file, "x").unwrap();
    let o = cli(&["plan", "/no/such/toolpath", "-o", file.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let err = common::stderr(&o);
    assert!(err.contains("taken") && err.contains("is a file"), "{err}");
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "x");
}

/// Inside a file: cannot be created, found before the missing toolpath.
#[test]
fn an_output_folder_inside_a_file_is_refused_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("taken");
    std::fs::write(&file, "x").unwrap();
    let o = cli(&[
        "plan",
        "/no/such/toolpath",
        "-o",
        file.join("sub").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
}

/// No -o at all: a usage error naming it.
#[test]
fn plan_without_an_output_folder_is_a_usage_error() {
    let o = cli(&["plan"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(common::stderr(&o).contains("--out"));
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

/// The output folder of `maamplan plan --backend cpu --no-plots` (the
/// embedded default job), run once.
fn default_plan_folder() -> &'static Path {
    static OUT: OnceLock<PathBuf> = OnceLock::new();
    OUT.get_or_init(|| common::plan_default_job("plan", &["--no-plots", "-q"]))
}

/// `maamplan check --backend cpu` with `args` (the embedded default job
/// unless they name a toolpath): the JSON it wrote.
fn check_json(args: &[&str]) -> serde_json::Value {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("check.json");
    let o = common::maamplan()
        .args(["check", "--backend", "cpu"])
        .args(args)
        .arg("--json")
        .arg(&json)
        .output()
        .unwrap();
    assert_success(&o);
    read_json(&json)
}

#[test]
fn check_and_plan_pose_the_head_alike() {
    let c = check_json(&[]);
    let rows = csv_rows(&default_plan_folder().join("plan.csv"));
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
}

/// plan.csv's flags are what report.json counts.
#[test]
fn plan_csv_flags_are_what_report_json_counts() {
    let rows = csv_rows(&default_plan_folder().join("plan.csv"));
    let r = read_json(&default_plan_folder().join("report.json"));
    let count = |k: &str| rows.iter().filter(|r| r[k] == "1").count() as u64;
    for (flag, side, figure) in [
        ("singular", "plan", "singular_waypoints"),
        ("was_singular", "input", "singular_waypoints"),
        ("was_colliding", "input", "residual_collisions"),
    ] {
        assert_eq!(
            count(flag),
            r[side][figure].as_u64().unwrap(),
            "{flag} vs {side}.{figure}"
        );
    }
    assert!(count("was_singular") > 0);
}

/// check --plan re-checks the written plan: poses and printing moves.
#[test]
fn check_rechecks_the_written_plan() {
    let csv = default_plan_folder().join("plan.csv");
    let c = check_json(&["--plan", csv.to_str().unwrap()]);
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
    // The embedded default job: its planning goes on well after its load.
    let mut child = common::maamplan()
        .args(["plan", "--backend", "cpu", "--no-plots", "-v", "-o"])
        .arg(&out)
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

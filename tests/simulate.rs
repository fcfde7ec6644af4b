//! Post-processors and `simulate`: every dialect reads back as the motion
//! that was planned, `G93` feeds encode each move's planned duration, a
//! plan made for a tool-centre-point controller passes the simulator, and
//! on the data set's reference G-code the simulator finds what the
//! independent FCL audit finds.

mod common;

use common::{cli, plate};

use maamplan::default_job::{box_mesh, cone_head};
use maamplan::io::gcode::{axes_of, read_program, write_gcode, GcodeHeader};
use maamplan::io::output::write_folder_atomic;
use maamplan::io::toolpath_folder::{mesh_obj, toolpath_files};
use maamplan::kinematics::{Axes, Dialect, ExtrusionMode, FeedMode, Interpolation, Machine, Post};
use maamplan::plan::program::{move_seconds, Move, MoveKind};
use maamplan::plan::{Plan, PlanOptions};
use maamplan::scene::{cutoff, stamp_of, Scene, SceneConfig};
use maamplan::simulate::{ProblemKind, Simulation};
use maamplan::toolpath::{Layer, Toolpath, Waypoint};
use std::path::PathBuf;
use std::process::Output;
use std::sync::OnceLock;

/// Three rows of waypoints whose nozzles lean, the first turning fast
/// along its row (the rotary axes set the pace), the others slowly (the
/// feed does), the middle one a support layer (the second extruder, with a
/// nozzle offset): travels, a tool change and back.
fn small_toolpath() -> Toolpath {
    let row = |name: &str, z: f32, turn: f32| Layer {
        name: name.into(),
        waypoints: (0..24)
            .map(|i| {
                let a = i as f32 * turn;
                Waypoint {
                    pos: [i as f32 * 0.6 - 7.0, 0.0, z],
                    dir: [0.3 * a.cos(), 0.3 * a.sin(), 1.0],
                }
            })
            .collect(),
        surface: Some(plate([-7.5, 7.5], [-0.5, 0.5], z)),
    };
    Toolpath {
        layers: vec![
            row("0", 0.6, 0.05),
            row("1S", 1.2, 0.0),
            row("2", 1.8, -0.01),
        ],
    }
}

/// The scene of `tp` under a small cone head, over a plate.
fn cone_over_plate(tp: &Toolpath) -> Scene {
    Scene::build(
        tp,
        &cone_head(5.0, 5.0, 8.0, 24),
        &box_mesh([-60.0, -60.0, -2.0], [60.0, 60.0, 0.0]),
        &SceneConfig::default(),
    )
    .unwrap()
}

/// [`small_toolpath`] and its scene (a cone head over a plate), built once.
fn small_job() -> &'static (Toolpath, Scene) {
    static JOB: OnceLock<(Toolpath, Scene)> = OnceLock::new();
    JOB.get_or_init(|| {
        let tp = small_toolpath();
        let scene = cone_over_plate(&tp);
        (tp, scene)
    })
}

fn machine(post: Post) -> Machine {
    let mut m = Machine::default();
    m.support.offset = [3.0, -2.0];
    m.post = post;
    m
}

fn plan_for(tp: &Toolpath, scene: &Scene, m: &Machine) -> Plan {
    common::plan_cpu(scene, tp, m, &PlanOptions::default())
}

/// The moves of `p`'s program that its G-code writes a line for, in
/// order: those that move an axis, and the retracts and primes.
fn written_moves(p: &Plan, m: &Machine) -> Vec<(Axes, Move)> {
    p.program
        .moves(m)
        .into_iter()
        .filter(|(from, mv)| {
            *from != mv.to || matches!(mv.kind, MoveKind::Retract | MoveKind::Prime)
        })
        .collect()
}

/// Every combination the writer offers, with unusual letters, signs and
/// work offsets.
fn posts() -> Vec<Post> {
    let mut v = Vec::new();
    for dialect in [Dialect::Joint, Dialect::G43_4, Dialect::Traori] {
        for feed in [FeedMode::G94, FeedMode::G93] {
            for extrusion in [ExtrusionMode::Absolute, ExtrusionMode::Relative] {
                let odd = extrusion == ExtrusionMode::Relative;
                v.push(Post {
                    dialect,
                    tilt_letter: odd.then_some('A'),
                    c_letter: odd.then_some('W'),
                    tilt_sign: if odd { -1.0 } else { 1.0 },
                    c_sign: if feed == FeedMode::G93 { -1.0 } else { 1.0 },
                    feed,
                    extrusion,
                    // A converted CNC machine's extruder axis, and a work
                    // offset the program is written relative to.
                    extruder_letter: odd.then_some('U'),
                    dwell_p: None,
                    work_offsets: if odd {
                        [("G54".to_string(), [5.0, -3.0, 2.0])].into()
                    } else {
                        Default::default()
                    },
                });
            }
        }
    }
    v
}

/// The small job planned for each of [`posts`], once; the first is the
/// default post.
fn post_plans() -> &'static [(Post, Plan)] {
    static PLANS: OnceLock<Vec<(Post, Plan)>> = OnceLock::new();
    PLANS.get_or_init(|| {
        let (tp, scene) = small_job();
        posts()
            .into_iter()
            .map(|post| {
                let p = plan_for(tp, scene, &machine(post.clone()));
                (post, p)
            })
            .collect()
    })
}

#[test]
fn each_dialect_reads_back_as_the_planned_motion() {
    let (post, p) = &post_plans()[0];
    assert_eq!(*post, Post::default());
    let all = p.program.moves(&machine(Post::default()));
    assert!(all
        .iter()
        .any(|(f, mv)| mv.kind == MoveKind::Print && f.c != mv.to.c));
    // What a controller sees: lines that move an axis or the extruder.
    let expected: Vec<_> = all
        .iter()
        .filter(|(from, mv)| {
            *from != mv.to || matches!(mv.kind, MoveKind::Retract | MoveKind::Prime)
        })
        .collect();
    // The filament of each line, from the plain dialect (absolute E).
    let plain = read_program(
        &write_gcode(
            &machine(Post::default()),
            &p.program,
            &GcodeHeader::default(),
        ),
        &machine(Post::default()),
    )
    .unwrap();
    for post in posts() {
        let m = machine(post.clone());
        let text = write_gcode(&m, &p.program, &GcodeHeader::default());
        let tcp = post.interpolation() == Interpolation::TipLinear;
        let (on, off) = match post.dialect {
            Dialect::Joint => ("", ""),
            Dialect::G43_4 => ("G43.4 H", "G49"),
            Dialect::Traori => ("TRAORI", "TRAFOOF"),
        };
        assert!(text.contains(on) && text.contains(off), "{post:?}");
        assert_eq!(
            text.contains("\nM83\n"),
            post.extrusion == ExtrusionMode::Relative
        );
        assert_eq!(text.contains("\nG93\n"), post.feed == FeedMode::G93);
        let back = read_program(&text, &m).unwrap();
        assert_eq!(back.len(), expected.len(), "{post:?}");
        // Tips written with three decimals come back through inverse
        // kinematics: within the rounding of the plan.
        let tol = if tcp { 2e-3 } else { 1e-9 };
        for ((g, (_, mv)), base) in back.iter().zip(&expected).zip(&plain) {
            let w = axes_of(&g.to);
            for k in 0..3 {
                assert!(
                    (w.xyz[k] - mv.to.xyz[k]).abs() <= tol,
                    "{post:?} line {}: {:?} vs {:?}",
                    g.line,
                    w.xyz,
                    mv.to.xyz
                );
            }
            assert!((w.tilt - mv.to.tilt).abs() < 1e-9 && (w.c - mv.to.c).abs() < 1e-9);
            // Absolute E is the plan's; relative E the same filament per line.
            if post.extrusion == ExtrusionMode::Absolute {
                assert!((g.e - mv.e).abs() <= 1e-6, "{post:?} line {}", g.line);
            }
            assert!((g.de - base.de).abs() <= 1.5e-3, "{post:?} line {}", g.line);
            assert_eq!(g.tcp, tcp);
            assert_eq!(g.inverse_time, post.feed == FeedMode::G93);
            assert_eq!(
                g.linear,
                !matches!(mv.kind, MoveKind::Lift | MoveKind::Lower | MoveKind::Travel)
            );
        }
    }
}

#[test]
fn g93_feeds_reproduce_each_moves_planned_duration() {
    let (tp, scene) = small_job();
    for dialect in [Dialect::Joint, Dialect::G43_4] {
        let m = machine(Post {
            dialect,
            feed: FeedMode::G93,
            ..Post::default()
        });
        let p = plan_for(tp, scene, &m);
        let text = write_gcode(&m, &p.program, &GcodeHeader::default());
        let back = read_program(&text, &m).unwrap();
        let planned = written_moves(&p, &m);
        let mut prev_e = 0.0;
        let mut feed_limited = 0;
        for (g, (from, mv)) in back.iter().zip(&planned) {
            let de = if matches!(mv.kind, MoveKind::Prime) {
                g.de
            } else {
                mv.e - prev_e
            };
            prev_e = mv.e;
            if !g.linear {
                continue; // Rapids take no feed.
            }
            let want = move_seconds(&m, from, &mv.to, mv.feed, de);
            let got = 60.0 / g.f;
            assert!(
                (got - want).abs() <= 1e-6 * want,
                "{dialect:?} line {}: {got} s vs planned {want} s",
                g.line
            );
            // Where the feed sets the pace, the tip moves at the feed.
            if mv.kind == MoveKind::Print {
                let (a, b) = (m.tip(&axes_of(&g.from)), m.tip(&axes_of(&g.to)));
                let len = (a[0] - b[0]).hypot(a[1] - b[1]).hypot(a[2] - b[2]);
                if (len / mv.feed - want).abs() < 1e-9 * want {
                    feed_limited += 1;
                    assert!((len / got - mv.feed).abs() < 2e-3 * mv.feed + 1e-9 / got);
                }
            }
        }
        assert!(feed_limited > 10, "{dialect:?}: {feed_limited}");
    }
}

#[test]
fn a_plan_for_a_tool_centre_point_controller_passes_the_simulator() {
    let (tp, scene) = small_job();
    for (post, p) in post_plans() {
        let m = machine(post.clone());
        assert_eq!(p.plan.colliding_edges, 0, "{post:?}");
        let prints = p
            .program
            .moves(&m)
            .iter()
            .filter(|(_, mv)| mv.kind == MoveKind::Print)
            .count();
        if post.interpolation() == Interpolation::TipLinear {
            // The tip moves straight: one line per bead segment, no splits.
            assert_eq!(
                prints,
                tp.waypoint_count() - tp.layers.len() - p.plan.breaks,
                "{post:?}"
            );
            assert_eq!(p.plan.tip_deviation_max_mm, 0.0);
        }
        let text = write_gcode(&m, &p.program, &GcodeHeader::default());
        let moves = read_program(&text, &m).unwrap();
        let sim = common::simulate_cpu(tp, scene, &m, &moves);
        assert!(sim.problems.is_empty(), "{post:?}: {:?}", sim.problems);
        assert_eq!(sim.summary.printed_waypoints, tp.waypoint_count());
        assert!(sim.summary.checked_moves > 60);
    }
}

/// `simulate` checks each line of a plan's program against the material
/// the planner proved it against: the same printed waypoints (in the
/// beads written as several lines, the lifts off the last waypoint of a
/// section and the first bead of the next), or fewer where the planner
/// proved a piece against more (one that reads as a later layer).
#[test]
fn simulate_checks_each_line_of_a_plan_against_the_material_the_planner_did() {
    // Two rows whose nozzles lean 31° and turn 20° a waypoint: the tip
    // bows off the beads, which are written as several lines.
    let row = |name: &str, z: f32| Layer {
        name: name.into(),
        waypoints: (0..12)
            .map(|i| {
                let a = i as f32 * 0.35;
                Waypoint {
                    pos: [i as f32 * 0.6 - 3.5, 0.0, z],
                    dir: [0.6 * a.cos(), 0.6 * a.sin(), 1.0],
                }
            })
            .collect(),
        surface: Some(plate([-4.0, 4.0], [-0.5, 0.5], z)),
    };
    let tp = Toolpath {
        layers: vec![row("0", 0.6), row("1", 1.2)],
    };
    let scene = cone_over_plate(&tp);
    let m = Machine::default();
    let p = plan_for(&tp, &scene, &m);
    let planned = written_moves(&p, &m);
    let moves = read_program(&write_gcode(&m, &p.program, &GcodeHeader::default()), &m).unwrap();
    assert_eq!(moves.len(), planned.len());
    let timeline = maamplan::simulate::timeline(&m, &tp, &moves);
    let printed: Vec<usize> = (0..tp.waypoint_count())
        .filter(|&w| timeline.printed[w].is_some())
        .collect();
    let material = |exists: &dyn Fn(usize) -> bool| -> Vec<usize> {
        printed.iter().copied().filter(|&w| exists(w)).collect()
    };
    // The waypoint the plan last reached: the one a print move leaves.
    let mut from = None;
    let (mut pieces, mut lifts) = (0, 0);
    for (i, ((_, mv), g)) in planned.iter().zip(&moves).enumerate() {
        if g.moves_axes() {
            let sim = material(&|w| timeline.stamp(stamp_of(w)) < timeline.cutoffs[i]);
            let plan = material(&|w| stamp_of(w) < mv.cutoff);
            if mv.kind == MoveKind::Print && Some(mv.cutoff) != from.map(cutoff) {
                assert!(sim.iter().all(|w| plan.contains(w)), "line {}", g.line);
            } else {
                assert_eq!(sim, plan, "line {}: {:?}", g.line, mv.kind);
            }
        }
        pieces += (mv.kind == MoveKind::Print && mv.waypoint.is_none()) as usize;
        lifts += (mv.kind == MoveKind::Lift) as usize;
        if mv.waypoint.is_some() {
            from = mv.waypoint;
        }
    }
    assert!(pieces > 0 && lifts > 1, "{pieces} pieces, {lifts} lifts");
    let sim = common::simulate_cpu(&tp, &scene, &m, &moves);
    assert!(
        sim.problems
            .iter()
            .all(|p| p.kind != ProblemKind::Collision),
        "{:?}",
        sim.problems
    );
}

/// What `../shared/tools/gcode_audit.py --fcl` reports on the reference
/// G-code (`gcode_audit.py reference_gcode/simple_curve_Gcode.txt --fcl
/// --toolpath simple_curve --head extruderHead.obj --platform
/// printingPlatform.obj --place 0,0,40.5`; the audit is deterministic): colliding
/// moves at these lines, tip deviation max 6.7747 mm with 98 extruding
/// moves over 0.05 mm, 0.18084 % of extruding moves outside [1, 25] mm/s.
const AUDIT_COLLISION_LINES: [usize; 3] = [25844, 35940, 36071];
const AUDIT_DEVIATION_MAX: f64 = 6.774_678_8;
const AUDIT_DEVIATION_OVER: usize = 98;
const AUDIT_SPEED_PCT: f64 = 0.180_840_5;

/// `simulate` on the data set's reference G-code for simple_curve, once.
fn reference_simulation() -> &'static Simulation {
    static SIM: OnceLock<Simulation> = OnceLock::new();
    SIM.get_or_init(|| {
        let job = common::simple_curve_job();
        let m = Machine::default();
        let text =
            std::fs::read_to_string(common::data().join("reference_gcode/simple_curve_Gcode.txt"))
                .unwrap();
        let moves = read_program(&text, &m).unwrap();
        common::simulate_cpu(&job.toolpath, &job.scene, &m, &moves)
    })
}

/// `got` is within a percent of the audit's `want`.
fn assert_within_a_percent(got: f64, want: f64) {
    assert!(
        (got - want).abs() <= 0.01 * want,
        "{got} vs the audit's {want}"
    );
}

#[test]
fn on_the_reference_gcode_simulate_finds_the_fcl_audits_collisions() {
    let hits: Vec<usize> = reference_simulation()
        .problems
        .iter()
        .filter(|p| p.kind == ProblemKind::Collision)
        .map(|p| p.line)
        .collect();
    for line in AUDIT_COLLISION_LINES {
        assert!(hits.contains(&line), "line {line} not reported: {hits:?}");
    }
    // The audit checks earlier layers at margin 0; the simulator also the
    // current layer's printed part, at the 0.05 mm margin: a few more at most.
    assert!(hits.len() <= 2 * AUDIT_COLLISION_LINES.len(), "{hits:?}");
}

#[test]
fn on_the_reference_gcode_simulate_measures_the_fcl_audits_tip_deviation() {
    let s = &reference_simulation().summary;
    assert_within_a_percent(s.tip_deviation_max_mm, AUDIT_DEVIATION_MAX);
    assert_within_a_percent(
        s.tip_deviation_over_tolerance as f64,
        AUDIT_DEVIATION_OVER as f64,
    );
}

#[test]
fn on_the_reference_gcode_simulate_measures_the_fcl_audits_tip_speed() {
    let s = &reference_simulation().summary;
    assert_within_a_percent(s.speed_violation_pct, AUDIT_SPEED_PCT);
    assert_eq!(s.extruding_moves, 41_473);
}

/// [`small_toolpath`] and a plate written into a fresh folder, and
/// `maamplan simulate` run on the program `text` there: the folder, the
/// output folder and the command's output.
fn simulate_program(text: &str) -> (tempfile::TempDir, PathBuf, Output) {
    let dir = tempfile::tempdir().unwrap();
    let job = dir.path().join("job");
    write_folder_atomic(&job, &toolpath_files(&small_toolpath())).unwrap();
    let platform = dir.path().join("platform.obj");
    std::fs::write(
        &platform,
        mesh_obj(&box_mesh([-60.0, -60.0, -2.0], [60.0, 60.0, 0.0])),
    )
    .unwrap();
    let g = dir.path().join("program.gcode");
    std::fs::write(&g, text).unwrap();
    let out = dir.path().join("out");
    let o = cli(&[
        "simulate",
        g.to_str().unwrap(),
        job.to_str().unwrap(),
        "--platform",
        platform.to_str().unwrap(),
        "--backend",
        "cpu",
        "-o",
        out.to_str().unwrap(),
    ]);
    (dir, out, o)
}

/// A program that sets every axis and prints one move.
const GOOD: &str = "G90\nG28 X0 Y0 Z50 B0 C0\nG1 X1 Y0 Z0.6 E1 F1500\n";

/// `simulate` refuses `text` in one line naming its `line` and saying
/// `what`, exit 2, and writes nothing.
fn assert_bad_gcode(text: &str, line: usize, what: &str) {
    let (_dir, out, o) = simulate_program(text);
    let err = common::stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(
        err.contains(&format!("program.gcode:{line}:")) && err.contains(what),
        "{err}"
    );
    assert!(!out.exists(), "nothing written");
}

#[test]
fn an_unknown_gcode_word_is_refused() {
    assert_bad_gcode(&format!("{GOOD}G1 X2 Q5\n"), 4, "unknown word 'Q'");
}

#[test]
fn a_gcode_word_without_a_finite_number_is_refused() {
    assert_bad_gcode(
        &format!("{GOOD}G1 XNaN\n"),
        4,
        "'XNaN' is not a letter and a finite number",
    );
}

#[test]
fn gcode_moving_before_every_axis_is_known_is_refused() {
    assert_bad_gcode("G90\nG28 X0 Y0 Z50\nG1 X1 E1\n", 3, "B, C unknown");
}

#[test]
fn an_unsupported_gcode_is_refused() {
    assert_bad_gcode(&format!("{GOOD}G2 X1 Y1 I1 J0\n"), 4, "unsupported code G2");
}

/// The good program runs and writes its report.
#[test]
fn simulate_writes_its_report() {
    let (_dir, out, o) = simulate_program(GOOD);
    common::assert_success(&o);
    let report = common::read_json(&out.join("report.json"));
    assert_eq!(report["summary"]["moves"], 1);
    let html = std::fs::read_to_string(out.join("report.html")).unwrap();
    for id in [
        "summary",
        "problems",
        "bc_layer_0",
        "tip_speed",
        "tip_deviation",
        "collisions",
    ] {
        assert!(html.contains(&format!("id=\"{id}\"")), "{id}");
    }
    let csv = std::fs::read_to_string(out.join("moves.csv")).unwrap();
    assert_eq!(csv.lines().count(), 2, "{csv}");
}

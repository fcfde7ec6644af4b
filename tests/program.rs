//! Programs as input: the G-code vocabulary real machines use is read as
//! the motion it makes (and anything else refused with its line),
//! `simulate` without a toolpath checks a program against the beads it
//! lays itself, and `plan` re-plans a program given as its toolpath.

mod common;

use common::{cli, read_json, stderr};
use maamplan::io::gcode::{write_gcode, GcodeHeader};
use maamplan::io::gcode_read::{parse_program, GcodeMove, Program};
use maamplan::kinematics::{DwellUnit, Machine};
use maamplan::program_toolpath::ProgramToolpath;
use maamplan::scene::BeadSettings;
use std::path::{Path, PathBuf};

/// Homing that gives every axis a position, before `body`.
const HOME: &str = "G90\nG28 X0 Y0 Z50 B0 C0\n";

/// `body` after [`HOME`], read for `m`.
fn read(m: &Machine, body: &str) -> Program {
    parse_program(&format!("{HOME}{body}"), m).unwrap_or_else(|e| panic!("{e}\n{body}"))
}

/// The motion of `body` on the default machine.
fn moves(body: &str) -> Vec<GcodeMove> {
    read(&Machine::default(), body).moves
}

/// [`moves`] without their line numbers: the motion alone.
fn motion(body: &str) -> Vec<GcodeMove> {
    let mut mv = moves(body);
    for m in &mut mv {
        m.line = 0;
    }
    mv
}

/// The error `body` gives on the default machine.
fn refusal(body: &str) -> String {
    parse_program(&format!("{HOME}{body}"), &Machine::default())
        .unwrap_err()
        .to_string()
}

const PRINT: &str = "G1 X1 Y0 Z0.6 E1 F1500\n";

#[test]
fn the_extruder_axis_letter_comes_from_the_machine_file() {
    let mut m = Machine::default();
    m.post.extruder_letter = Some('A');
    let mv = read(&m, "G1 X1 Y0 Z0.6 A0.5 F1500\n").moves;
    assert_eq!(mv.len(), 1);
    assert_eq!(mv[0].de, 0.5);
    assert!(mv[0].extrudes());
    // E means nothing on that machine, and A nothing on the default one.
    let e = parse_program(&format!("{HOME}{PRINT}"), &m).unwrap_err();
    assert!(e.to_string().contains("unknown word 'E'"), "{e}");
    assert!(refusal("G1 X1 A0.5\n").contains("unknown word 'A'"));
    // What the planner writes for that machine reads back with its letter.
    m.post.extruder_letter = Some('U');
    let plan = &common::default_plan().2;
    let text = write_gcode(&m, &plan.program, &GcodeHeader::default());
    assert!(text
        .lines()
        .any(|l| l.starts_with("G1 ") && l.contains(" U")));
    assert!(!text
        .lines()
        .any(|l| l.starts_with("G1 ") && l.contains(" E")));
    let back = parse_program(&text, &m).unwrap().moves;
    assert!(back.iter().filter(|mv| mv.extrudes()).count() > 100);
}

#[test]
fn cnc_setup_codes_change_nothing_the_motion_depends_on() {
    let plain = motion(PRINT);
    for setup in [
        "G17 G21 G40 G49 G80 G90 G94\n",
        "G17\nG21\nG40\nG49\nG80\nG90\nG94\n",
        "N10 G21 G40 G49 G80 (setup)\n",
    ] {
        assert_eq!(motion(&format!("{setup}{PRINT}")), plain, "{setup}");
    }
}

#[test]
fn work_offsets_are_identity_unless_the_machine_file_gives_them() {
    let plain = motion(PRINT);
    for g in ["G54", "G55", "G56", "G57", "G58", "G59"] {
        assert_eq!(motion(&format!("{g}\n{PRINT}")), plain, "{g}");
    }
    let mut m = Machine::default();
    m.post.work_offsets.insert("G55".into(), [10.0, -2.0, 5.0]);
    let mv = read(&m, &format!("G55\n{PRINT}G54\n{PRINT}")).moves;
    assert_eq!(&mv[0].to[..3], &[11.0, -2.0, 5.6]);
    assert_eq!(&mv[1].to[..3], &[1.0, 0.0, 0.6]);
    // G53: one line in machine coordinates.
    let mv = read(&m, &format!("G55\nG53 {PRINT}")).moves;
    assert_eq!(&mv[0].to[..3], &[1.0, 0.0, 0.6]);
}

#[test]
fn a_tool_change_by_t_and_m6_selects_the_tool() {
    let mv = moves(&format!("T2 M6\n{PRINT}T1 M06\nG1 X2 E2\n"));
    assert_eq!((mv[0].tool, mv[1].tool), (2, 1));
    // T as a heater's parameter changes no tool.
    let mv = moves(&format!("T2 M6\nM104 S205 T1\n{PRINT}"));
    assert_eq!(mv[0].tool, 2);
}

#[test]
fn spindle_codes_change_nothing_the_motion_depends_on() {
    assert_eq!(motion(&format!("M3 S1000\n{PRINT}M5\n")), motion(PRINT));
}

#[test]
fn temperatures_and_fans_change_nothing_the_motion_depends_on() {
    let codes = "M104 S205 T1\nM109 S205\nM140 S60\nM190 S60\nM106 S255\nM107\n";
    assert_eq!(motion(&format!("{codes}{PRINT}")), motion(PRINT));
}

#[test]
fn a_dwell_waits_where_the_machine_stands() {
    let mv = moves(&format!("{PRINT}G4 P500\nG4 S2\n"));
    assert_eq!(mv.len(), 3);
    assert_eq!((mv[1].dwell, mv[2].dwell), (0.5, 2.0));
    assert!(!mv[1].moves_axes() && mv[1].to == mv[0].to);
    // A CNC controller counts P in seconds.
    let mut m = Machine::default();
    m.post.dwell_p = Some(DwellUnit::Seconds);
    assert_eq!(read(&m, "G4 P3\n").moves[0].dwell, 3.0);
    assert!(refusal("G4\n").contains("G4 P"));
}

#[test]
fn a_line_that_sets_only_the_feed_sets_it_for_the_moves_after() {
    let mv = moves(&format!("F600\n{PRINT}G1 X2 E2\nF900\nG1 X3 E3\n"));
    assert_eq!(
        mv.iter().map(|m| m.f).collect::<Vec<_>>(),
        [1500.0, 1500.0, 900.0]
    );
    let mv = moves("F600\nG1 X2 Y0 Z0.6 E1\n");
    assert_eq!(mv[0].f, 600.0);
}

#[test]
fn inches_are_converted_to_millimetres() {
    let mv = moves("G20\nG1 X1 Y0 Z0.5 E0.1 F60\nG21\nG1 X30 E3\n");
    assert_eq!(&mv[0].to[..3], &[25.4, 0.0, 12.7]);
    assert!((mv[0].de - 2.54).abs() < 1e-12 && mv[0].f == 1524.0);
    assert_eq!(mv[1].to[0], 30.0);
    // Angles are no lengths.
    assert_eq!(moves("G20\nG1 B10 C20\n")[0].to[3..], [10.0, 20.0]);
}

#[test]
fn anything_else_is_refused_with_its_line() {
    for (body, what) in [
        ("G2 X1 Y1 I1 J0\n", "unsupported code G2"),
        ("G91\n", "unsupported code G91"),
        ("M42 P1 S1\n", "unsupported code M42"),
        ("G1 X1 Q2\n", "unknown word 'Q'"),
    ] {
        let e = refusal(body);
        assert!(e.starts_with("line 3:") && e.contains(what), "{body}: {e}");
    }
}

/// Ten layers of one bead each, 0.5 mm apart, a wall along y at x = 0
/// (`;LAYER:` comments with `comments`), then a travel beside it and a
/// move straight through it without extruding: the program and that
/// move's line.
fn wall_program(comments: bool) -> (String, usize) {
    let mut s = String::from("G90\nM83\nG28 X0 Y0 Z50 B0 C0\n");
    for k in 0..10 {
        let z = 0.5 * (k + 1) as f64;
        let (from, to) = if k % 2 == 0 { (-10, 10) } else { (10, -10) };
        if comments {
            s += &format!(";LAYER:{k}\n");
        }
        s += &format!("G0 X0 Y{from} Z{z}\nG1 Y0 E0.5 F1500\nG1 Y{to} E0.5\n");
    }
    s += "G0 Z20\nG0 X-20 Y0\nG1 Z2 F1500\n";
    let through = s.lines().count() + 1;
    (s + "G1 X20\nG0 Z30\n", through)
}

/// `program` written into a fresh folder and `maamplan ARGS… program`:
/// the folder (kept while the result lives), the program's path, the output.
fn run_on(
    program: &str,
    name: &str,
    args: &[&str],
) -> (tempfile::TempDir, PathBuf, std::process::Output) {
    let dir = tempfile::tempdir().unwrap();
    let g = dir.path().join(name);
    std::fs::write(&g, program).unwrap();
    let mut all: Vec<&str> = args.to_vec();
    all.insert(1, g.to_str().unwrap());
    let o = cli(&all);
    (dir, g, o)
}

/// The lines `report.json` in `out` names as colliding.
fn colliding_lines(out: &Path) -> Vec<usize> {
    let r = read_json(&out.join("report.json"));
    r["problems"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|p| p["kind"] == "collision")
        .map(|p| p["line"].as_u64().unwrap() as usize)
        .collect()
}

#[test]
fn simulate_without_a_toolpath_checks_a_program_against_its_own_beads() {
    for comments in [true, false] {
        let (program, through) = wall_program(comments);
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out");
        let (_d, _g, o) = run_on(
            &program,
            "wall.gcode",
            &["simulate", "--backend", "cpu", "-o", out.to_str().unwrap()],
        );
        common::assert_success(&o);
        // The move through the wall, and it alone: the beads it prints on
        // are no obstacle to the nozzle laying the next.
        assert_eq!(colliding_lines(&out), [through], "comments {comments}");
        let printed = String::from_utf8_lossy(&o.stdout);
        assert!(
            printed.contains("the part it deposits (beads)"),
            "{printed}"
        );
    }
}

/// Without a toolpath the options that move or turn one have nothing to
/// act on: `simulate` says they are ignored, and checks the same lines.
#[test]
fn simulate_without_a_toolpath_says_which_options_it_ignores() {
    let (program, through) = wall_program(true);
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let args = ["simulate", "--backend", "cpu", "--place", "0,0,5", "--y-up"];
    let (_d, _g, o) = run_on(
        &program,
        "wall.gcode",
        &[&args[..], &["-o", out.to_str().unwrap()]].concat(),
    );
    common::assert_success(&o);
    let err = common::stderr(&o);
    assert!(err.contains("warning: --place, --y-up ignored"), "{err}");
    assert_eq!(colliding_lines(&out), [through]);
}

/// `simulate PROGRAM` with the data set's head and platform, no toolpath,
/// on the cpu, into `out`.
fn simulate_alone(program: &std::path::Path, out: &std::path::Path) -> std::process::Output {
    let d = common::data();
    cli(&[
        "simulate",
        program.to_str().unwrap(),
        "--head",
        d.join("extruderHead.obj").to_str().unwrap(),
        "--platform",
        d.join("printingPlatform.obj").to_str().unwrap(),
        "--backend",
        "cpu",
        "-o",
        out.to_str().unwrap(),
    ])
}

/// simple_curve's reference G-code simulated without a toolpath.
#[test]
fn on_the_reference_gcode_simulate_alone_finds_the_fcl_audits_collisions() {
    let d = common::data();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let o = simulate_alone(&d.join("reference_gcode/simple_curve_Gcode.txt"), &out);
    common::assert_success(&o);
    let hits = colliding_lines(&out);
    for line in [25844, 35940, 36071] {
        assert!(hits.contains(&line), "line {line} not reported: {hits:?}");
    }
    assert!(hits.len() <= 6, "{hits:?}");
}

/// maamplan's own plan of simple_curve, written as a program and simulated
/// without its toolpath, collides nowhere.
#[test]
fn maamplans_own_plan_of_simple_curve_collides_nowhere_against_its_beads() {
    let (job, plan) = common::simple_curve_plan();
    let m = Machine::default();
    let text = write_gcode(&m, &plan.program, &GcodeHeader::default());
    let dir = tempfile::tempdir().unwrap();
    let (g, out) = (dir.path().join("plan.gcode"), dir.path().join("out"));
    std::fs::write(&g, text).unwrap();
    let o = simulate_alone(&g, &out);
    common::assert_success(&o);
    assert_eq!(colliding_lines(&out), Vec::<usize>::new());
    // Every bead it lays is laid (a program's waypoints include the
    // split points and crossings the plan adds to the toolpath's).
    let s = &read_json(&out.join("report.json"))["summary"];
    assert_eq!(s["printed_waypoints"], s["waypoints"], "{s}");
    assert!(s["waypoints"].as_u64().unwrap() >= job.toolpath.waypoint_count() as u64);
}

/// The distinct layers of a `plan.csv`.
fn planned_layers(out: &Path) -> usize {
    let csv = std::fs::read_to_string(out.join("plan.csv")).unwrap();
    let mut layers: Vec<&str> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(1).unwrap())
        .collect();
    layers.dedup();
    layers.len()
}

#[test]
fn plan_takes_a_program_in_the_layers_its_comments_or_its_beads_give() {
    for comments in [true, false] {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out");
        let (_d, _g, o) = run_on(
            &wall_program(comments).0,
            "wall.nc",
            &[
                "plan",
                "--backend",
                "cpu",
                "--no-plots",
                "-o",
                out.to_str().unwrap(),
            ],
        );
        common::assert_success(&o);
        assert_eq!(planned_layers(&out), 10, "comments {comments}");
        let r = read_json(&out.join("report.json"));
        // Every bead of the wall, and none across the travel.
        assert_eq!(r["plan"]["waypoints"], 30, "{}", r["plan"]);
        assert_eq!(r["plan"]["colliding_edges"], 0, "{}", r["plan"]);
        let program = std::fs::read_to_string(out.join("toolpath.gcode")).unwrap();
        let back = parse_program(&program, &Machine::default()).unwrap();
        assert_eq!(back.moves.iter().filter(|m| m.extrudes()).count(), 20);
    }
}

#[test]
fn a_programs_layer_comments_split_its_toolpath() {
    let m = Machine::default();
    let with = ProgramToolpath::of(&parse_program(&wall_program(true).0, &m).unwrap(), &m);
    assert!(with.layers_from_comments);
    assert_eq!(with.toolpath.layers.len(), 10);
    // Without them the beads say how the layers stack.
    let without = ProgramToolpath::of(&parse_program(&wall_program(false).0, &m).unwrap(), &m);
    assert_eq!(without.toolpath.layers.len(), 1);
    let platform = maamplan::job::plate_under(&without.toolpath, None);
    let d = without.deposit(&platform, &BeadSettings::of_machine(&m), &m);
    assert_eq!(d.toolpath.layers.len(), 10);
}

/// `plan` on simple_curve's reference G-code: the program comes back free
/// of collisions with the true layer surfaces (simulated against the
/// toolpath folder) and within the tip-speed range.
#[test]
fn plan_on_the_reference_gcode_comes_back_collision_free() {
    let d = common::data();
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("plan");
    let (head, platform) = (d.join("extruderHead.obj"), d.join("printingPlatform.obj"));
    let scene = [
        "--head",
        head.to_str().unwrap(),
        "--platform",
        platform.to_str().unwrap(),
        "--backend",
        "cpu",
    ];
    let o = cli(&[
        &[
            "plan",
            d.join("reference_gcode/simple_curve_Gcode.txt")
                .to_str()
                .unwrap(),
        ][..],
        &scene,
        &["--no-plots", "-o", out.to_str().unwrap()],
    ]
    .concat());
    common::assert_success(&o);
    let r = read_json(&out.join("report.json"));
    // The program as given collides at least where the FCL audit finds
    // it does (3 moves).
    let input = r["input"]["colliding_edges"].as_u64().unwrap();
    assert!((3..=8).contains(&input), "{}", r["input"]);
    assert_eq!(r["plan"]["colliding_edges"], 0, "{}", r["plan"]);
    assert_eq!(r["plan"]["waypoints"], 41_494);
    assert!(r["plan"]["speed_violation_pct"].as_f64().unwrap() <= 0.14);
    assert!(r["plan"]["tip_deviation_max_mm"].as_f64().unwrap() <= 0.05);
    assert_eq!(planned_layers(&out), 20);
    // Against the true surfaces, placed as the program's tip path lies.
    let sim = dir.path().join("sim");
    let o = cli(&[
        &["simulate", out.join("toolpath.gcode").to_str().unwrap()][..],
        &[
            d.join("simple_curve").to_str().unwrap(),
            "--place",
            "0,0,40.5",
        ],
        &scene,
        &["-o", sim.to_str().unwrap()],
    ]
    .concat());
    common::assert_success(&o);
    assert_eq!(colliding_lines(&sim), Vec::<usize>::new(), "{}", stderr(&o));
}

/// A program that prints nothing, simulated without a toolpath or a
/// platform: a plate under its lowest tip, and a warning that only the
/// platform was checked — in well under a minute (a plate under no part
/// at all was unbounded).
#[test]
fn simulate_alone_of_a_program_that_prints_nothing_checks_a_plate_under_it() {
    let dir = tempfile::tempdir().unwrap();
    let g = dir.path().join("travel.gcode");
    std::fs::write(&g, format!("{HOME}G0 X10 Y0 Z5\nG1 X20 F600\n")).unwrap();
    let mut child = common::maamplan()
        .args(["simulate", g.to_str().unwrap(), "--backend", "cpu"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let start = std::time::Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed().as_secs() > 60 {
            child.kill().unwrap();
            panic!("simulate did not finish in a minute");
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    let o = child.wait_with_output().unwrap();
    common::assert_success(&o);
    assert!(
        stderr(&o).contains("only the platform was checked"),
        "{}",
        stderr(&o)
    );
}

/// A program as CNC-style multi-axis printing pipelines write it, the
/// extruder as the A axis and F on every line, is read whole.
#[test]
fn a_cnc_style_program_is_read_whole() {
    let text = "%\n(converted mill)\nG21 G40 G49 G80\nG17 G90 G94\nT1 M6\nG54\nM3 S100\n\
                G0 X0 Y-10 Z0.5 B0 C0 F3000\nG1 X0 Y0 Z0.5 B0 C0 A0.5 F1200\n\
                G1 X0 Y10 Z0.5 B0 C0 A1.0 F1200\nG4 P200\nG0 Z30 F3000\nM5\nM30\n%\n";
    let mut m = Machine::default();
    m.post.extruder_letter = Some('A');
    let p = parse_program(text, &m).unwrap();
    let printing: Vec<usize> = p
        .moves
        .iter()
        .filter(|mv| mv.extrudes())
        .map(|mv| mv.line)
        .collect();
    assert_eq!(printing, [9, 10]);
    assert!(p.moves.iter().all(|mv| mv.tool == 1));
    // The first G0 gives every axis: the machine starts there. Then two
    // beads, the dwell and the lift.
    assert_eq!(p.moves.len(), 4);
    assert_eq!(p.moves[2].dwell, 0.2);
}

/// A program that never extrudes gives `plan` no toolpath: one line
/// naming the file, exit 2, nothing written.
#[test]
fn plan_refuses_a_program_that_prints_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let (_d, _g, o) = run_on(
        &format!("{HOME}G0 X10 Y0 Z5\nG1 X20 F600\n"),
        "travel.gcode",
        &["plan", "--backend", "cpu", "-o", out.to_str().unwrap()],
    );
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(
        err.contains("travel.gcode") && err.contains("never extrudes"),
        "{err}"
    );
    assert!(!out.exists());
}

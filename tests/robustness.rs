//! Inputs and surroundings a run must survive: a waypoint far out of the
//! machine's reach (a typo), a reader that closes the pipe early, an output
//! folder holding an earlier run's outputs, and a machine file that gives
//! only some fields or a bad one.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// A scratch folder of this binary for one test.
fn folder(name: &str) -> PathBuf {
    let d = common::scratch().join(name);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A single waypoint file: a 30 mm line of 61 waypoints, nozzles up, the
/// one numbered `far` (if any) moved to `x`.
/// A folder `name` holding `part.txt` ([`line_file`], nothing far), and
/// the output folder to plan it into.
fn line_part(name: &str) -> (PathBuf, PathBuf, PathBuf) {
    let d = folder(name);
    let file = d.join("part.txt");
    line_file(&file, None);
    let out = d.join("out");
    (d, file, out)
}

fn line_file(path: &Path, far: Option<(usize, &str)>) {
    let text: String = (0..61)
        .map(|i| match far {
            Some((g, x)) if g == i => format!("{x} 0 0.5 0 0 1\n"),
            _ => format!("{:.3} 0 0.5 0 0 1\n", i as f64 * 0.5),
        })
        .collect();
    std::fs::write(path, text).unwrap();
}

/// Run `command`, killing it after `limit`: its output, and how long it
/// ran (`None` when it was killed).
fn run_within(command: &mut Command, limit: Duration) -> (Output, Option<Duration>) {
    let t0 = Instant::now();
    let mut child = command
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    while child.try_wait().unwrap().is_none() {
        if t0.elapsed() > limit {
            child.kill().unwrap();
            return (child.wait_with_output().unwrap(), None);
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let took = t0.elapsed();
    (child.wait_with_output().unwrap(), Some(took))
}

/// A waypoint at x = 10⁴, 10⁶ or 10⁹ mm (±200 mm axis ranges) is out of
/// reach in every orientation: it is skipped and reported as unreachable,
/// and it costs the run nothing — it sizes neither the default plate nor
/// the scene's contact tolerance (before, 10⁶ mm took over 30 s and
/// 2.3 GiB).
#[test]
fn a_waypoint_far_out_of_reach_costs_nothing() {
    let d = folder("far");
    let near = d.join("near.txt");
    line_file(&near, None);
    // The head's data cached first, so that only planning is timed.
    let o = common::maamplan()
        .args(["check", "--backend", "cpu", "-q"])
        .arg(&near)
        .output()
        .unwrap();
    common::assert_success(&o);
    for x in ["1e4", "1e6", "1e9"] {
        let file = d.join(format!("far{x}.txt"));
        line_file(&file, Some((30, x)));
        let out = d.join(format!("far{x}.out"));
        let (o, took) = run_within(
            common::maamplan()
                .args(["plan", "--backend", "cpu", "--no-plots", "-o"])
                .arg(&out)
                .arg(&file),
            Duration::from_secs(6),
        );
        let took = took.unwrap_or_else(|| panic!("x = {x}: still planning after 6 s"));
        common::assert_success(&o);
        let report = common::read_json(&out.join("report.json"));
        assert_eq!(report["plan"]["skipped_waypoints"], 1, "x = {x}: {report}");
        assert_eq!(report["plan"]["unreachable_waypoints"], 1, "x = {x}");
        assert_eq!(report["skipped"][0]["index"], 30);
        assert_eq!(report["skipped"][0]["reason"], "unreachable");
        assert_eq!(report["plan"]["residual_collisions"], 0);
        assert!(common::stderr(&o).contains("waypoint 30"), "x = {x}");
        eprintln!("x = {x}: planned in {:.2} s", took.as_secs_f64());
    }
}

/// `maamplan plan -v | head -1`: the reader goes away before the run
/// writes its lines; the run finishes, writes its outputs and exits 0
/// without a word about the pipe (it panicked with exit 101).
#[test]
fn a_closed_stdout_ends_the_run_quietly() {
    let (_, file, out) = line_part("pipe");
    let (reader, writer) = std::io::pipe().unwrap();
    drop(reader);
    let o = common::maamplan()
        .args(["plan", "--backend", "cpu", "--no-plots", "-v", "-o"])
        .arg(&out)
        .arg(&file)
        .stdout(writer)
        .stderr(Stdio::piped())
        .output()
        .unwrap();
    let err = common::stderr(&o);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(out.join("toolpath.gcode").exists());
}

/// A run into a folder that holds an earlier run's outputs replaces them
/// as a set: a `--no-plots` run leaves no report.html, scene.glb or plots
/// of the run before beside its program; files of the user's are kept.
#[test]
fn a_new_run_leaves_none_of_the_last_runs_outputs() {
    let (d, file, out) = line_part("outputs");
    let plan = |extra: &[&str]| {
        let o = common::maamplan()
            .args(["plan", "--backend", "cpu", "-q", "-o"])
            .arg(&out)
            .arg(&file)
            .args(extra)
            .output()
            .unwrap();
        common::assert_success(&o);
    };
    let listing = || {
        let mut names: Vec<String> = std::fs::read_dir(&out)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    };
    plan(&[]);
    assert!(listing().contains(&"report.html".to_string()));
    std::fs::write(out.join("notes.txt"), "mine").unwrap();
    plan(&["--no-plots"]);
    assert_eq!(
        listing(),
        ["notes.txt", "plan.csv", "report.json", "toolpath.gcode"]
    );
    let left = std::fs::read_dir(&d).unwrap().count();
    assert_eq!(left, 2, "only part.txt and out/ in {}", d.display());
}

/// A machine file that gives part of a section keeps the defaults of the
/// rest (`[tilt]` without `speed`, no `configuration` or `rotary`), and a
/// value out of range is reported at its own line, exit 2, nothing
/// written.
#[test]
fn a_machine_file_defaults_what_it_leaves_out_and_names_the_bad_line() {
    let (d, file, out) = line_part("machine");
    let m = d.join("m.toml");
    std::fs::write(&m, "# my printer\nfeed = 20.0\n[tilt]\nmin = -60.0\n").unwrap();
    let o = common::maamplan()
        .args(["plan", "--backend", "cpu", "--no-plots", "-q", "--machine"])
        .arg(&m)
        .arg("-o")
        .arg(&out)
        .arg(&file)
        .output()
        .unwrap();
    common::assert_success(&o);
    let report = common::read_json(&out.join("report.json"));
    assert_eq!(report["machine"]["tilt"]["min"], -60.0, "{report}");
    assert_eq!(report["machine"]["tilt"]["speed"], 14.0);

    std::fs::write(&m, "feed = 20.0\n[tilt]\nmin = -60.0\nmax = -70.0\n").unwrap();
    let bad_out = d.join("bad");
    let o = common::maamplan()
        .args(["plan", "--backend", "cpu", "--machine"])
        .arg(&m)
        .arg("-o")
        .arg(&bad_out)
        .arg(&file)
        .output()
        .unwrap();
    let err = common::stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("m.toml:3: tilt.min must be below tilt.max"),
        "{err}"
    );
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(!bad_out.exists());
}

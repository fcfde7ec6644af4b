//! The planner end to end: simple_curve against the paper's and the
//! reference G-code's figures, the embedded default, G-code parse-back, and
//! the `plan` command's outputs. simple_curve and the default job are
//! planned once ([`common::simple_curve_plan`], [`common::default_plan`])
//! and the `plan` command runs once ([`plan_command`]); each test checks
//! one behaviour of them.

mod common;

use common::{assert_success, data, default_plan, read_json, simple_curve_plan};
use maamplan::collide::cpu::CpuBackend;
use maamplan::collide::Backend;
use maamplan::io::gcode::{
    axes_of, parse_g1, read_program, rotary_motion, write_gcode, GcodeHeader,
};
use maamplan::io::gcode_read::GcodeMove;
use maamplan::kinematics::Machine;
use maamplan::plan::program::MoveKind;
use maamplan::scene::Query;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// Reference G-code figures quoted by the planner issue: (J, largest
/// rotary step), in degrees.
fn reference() -> (f64, f64) {
    static FIGURES: OnceLock<(f64, f64)> = OnceLock::new();
    *FIGURES.get_or_init(|| {
        let text =
            std::fs::read_to_string(data().join("reference_gcode/simple_curve_Gcode.txt")).unwrap();
        assert_eq!(parse_g1(&text).len(), 41_494);
        rotary_motion(&read_program(&text, &Machine::default()).unwrap())
    })
}

#[test]
fn reference_gcode_rotary_motion() {
    let (j, max) = reference();
    assert!((j - 37_303.0).abs() < 5.0, "J {j}");
    assert!((max - 98.0).abs() < 1.0, "max step {max}");
}

#[test]
fn no_simple_curve_layer_points_down() {
    let (job, _) = simple_curve_plan();
    assert!(
        job.flipped_layers.is_empty(),
        "no simple_curve layer points down"
    );
}

/// The input, measured by the same rules, misses the tip-speed range about
/// as often as paper 000's "before" (17.74 %, Fig. 10), collides and
/// passes the singular region.
#[test]
fn simple_curve_input_measures_as_the_papers_before() {
    let (_, p) = simple_curve_plan();
    assert!(
        (p.input.speed_violation_pct - 17.74).abs() < 1.5,
        "input {}",
        p.input.speed_violation_pct
    );
    assert!(p.input.residual_collisions > 0 && p.input.singular_waypoints > 10_000);
}

/// The written program, re-checked: nothing within the margin, every
/// waypoint printed, no breaks.
#[test]
fn simple_curve_plan_keeps_the_margin_and_prints_every_waypoint() {
    let (_, p) = simple_curve_plan();
    assert_eq!(p.plan.residual_collisions, 0);
    assert_eq!(p.plan.colliding_edges, 0);
    assert!(p.plan.program_moves > p.waypoints.len());
    assert_eq!(p.plan.skipped_waypoints, 0);
    assert_eq!(p.plan.breaks, 0);
}

#[test]
fn simple_curve_plan_keeps_the_tip_speed_in_range() {
    let (_, p) = simple_curve_plan();
    assert!(
        p.plan.speed_violation_pct < 0.14,
        "plan {}",
        p.plan.speed_violation_pct
    );
}

/// No worse than before the program was checked move by move (24,614°,
/// 10.9°), and far below the reference G-code.
#[test]
fn simple_curve_plan_turns_less_than_the_reference_gcode() {
    let (_, p) = simple_curve_plan();
    let (ref_j, ref_max) = reference();
    assert!(p.plan.j_deg <= 24_614.5, "J {}", p.plan.j_deg);
    assert!(p.plan.max_step_deg <= 10.95, "step {}", p.plan.max_step_deg);
    assert!(p.plan.j_deg < ref_j && p.plan.max_step_deg < ref_max);
}

/// The tip stays on its bead, travels take the short way round, and layer
/// heights are measured, not clamped.
#[test]
fn simple_curve_tip_stays_on_its_bead_and_travels_take_the_short_way() {
    let (_, p) = simple_curve_plan();
    assert!(p.plan.tip_deviation_max_mm <= Machine::default().tip_tolerance);
    assert!(p.plan.travel_c_max_deg <= 180.0);
    assert!(
        p.plan.height_clamped_pct < 1.0,
        "{}",
        p.plan.height_clamped_pct
    );
}

/// simple_curve's program written as G-code and read back.
fn simple_curve_gcode_read_back() -> &'static [GcodeMove] {
    static BACK: OnceLock<Vec<GcodeMove>> = OnceLock::new();
    BACK.get_or_init(|| {
        let machine = Machine::default();
        let gcode = write_gcode(
            &machine,
            &simple_curve_plan().1.program,
            &GcodeHeader::default(),
        );
        read_program(&gcode, &machine).unwrap()
    })
}

/// The G-code parses back to the program's moves, value for value.
#[test]
fn simple_curve_gcode_parses_back_to_the_program() {
    let back = simple_curve_gcode_read_back();
    let all = simple_curve_plan().1.program.moves(&Machine::default());
    // (A repeated waypoint is a print move going nowhere: written, but no
    // motion for a controller.)
    let moves: Vec<_> = all
        .iter()
        .copied()
        .filter(|(from, mv)| {
            *from != mv.to || matches!(mv.kind, MoveKind::Retract | MoveKind::Prime)
        })
        .collect();
    assert_eq!(back.len(), moves.len());
    for (g, (_, mv)) in back.iter().zip(&moves) {
        let w = axes_of(&g.to);
        for k in 0..3 {
            assert!((w.xyz[k] - mv.to.xyz[k]).abs() <= 1e-9, "line {}", g.line);
        }
        assert!((w.tilt - mv.to.tilt).abs() < 1e-9 && (w.c - mv.to.c).abs() < 1e-9);
        assert!(
            (g.e - mv.e).abs() <= 1e-6,
            "line {}: E {} vs {}",
            g.line,
            g.e,
            mv.e
        );
        // Only printing and priming push filament.
        if g.de > 0.0 {
            assert!(matches!(mv.kind, MoveKind::Print | MoveKind::Prime));
        }
    }
}

/// Vetted as a user would vet it (`simulate`): the program read back,
/// printed in its own order, every move checked — nothing collides, the
/// tip stays on its bead, every waypoint is printed.
#[test]
fn simple_curve_gcode_passes_simulate() {
    let (job, _) = simple_curve_plan();
    let machine = Machine::default();
    let back = simple_curve_gcode_read_back();
    let sim = common::simulate_cpu(&job.toolpath, &job.scene, &machine, back);
    assert_eq!(
        sim.summary.colliding_moves,
        0,
        "{:?}",
        &sim.problems[..sim.problems.len().min(5)]
    );
    assert_eq!(
        sim.summary.checked_moves,
        back.iter().filter(|m| m.moves_axes()).count()
    );
    assert!(sim.summary.tip_deviation_max_mm <= machine.tip_tolerance);
    assert_eq!(sim.summary.printed_waypoints, job.toolpath.waypoint_count());
}

/// The G-code read back turns the rotary axes as much as the plan says.
#[test]
fn simple_curve_gcode_turns_as_planned() {
    let (_, p) = simple_curve_plan();
    let (j, max) = rotary_motion(simple_curve_gcode_read_back());
    assert!(
        (j - p.plan.j_deg).abs() < 0.01 * p.plan.j_deg + 5.0,
        "G-code J {j} vs plan {}",
        p.plan.j_deg
    );
    assert!(max <= p.plan.max_step_deg + 0.01);
}

/// Independently of the planner's bookkeeping: every waypoint the program
/// reaches, posed by its written axes, touches nothing.
#[test]
fn simple_curve_waypoints_as_written_touch_nothing() {
    let (job, p) = simple_curve_plan();
    let machine = Machine::default();
    let queries: Vec<Query> = p
        .program
        .moves(&machine)
        .iter()
        .filter_map(|(_, mv)| {
            mv.waypoint.map(|g| Query {
                pose: machine.pose(&mv.to),
                cutoff: g as u32 + 1,
                margin: 0.0,
                slope: 0.0,
            })
        })
        .collect();
    assert_eq!(queries.len(), p.waypoints.len());
    let hits = CpuBackend::new(&job.scene).evaluate(&queries).unwrap();
    assert_eq!(hits.iter().filter(|&&h| h).count(), 0);
}

#[test]
fn default_job_exercises_collisions_and_the_singular_region() {
    let (_, _, p) = default_plan();
    assert!(
        p.input.residual_collisions > 500,
        "the default job must exercise collisions"
    );
    assert!(
        p.input.singular_waypoints > 0,
        "the default job must pass the singular region"
    );
}

#[test]
fn default_job_plan_removes_collisions() {
    let (_, _, p) = default_plan();
    assert_eq!(p.plan.residual_collisions, 0);
    assert_eq!(p.plan.colliding_edges, 0);
    assert_eq!(p.plan.skipped_waypoints, 0);
}

#[test]
fn default_job_plan_is_smoother_than_its_input() {
    let (_, _, p) = default_plan();
    assert!(p.plan.speed_violation_pct < p.input.speed_violation_pct);
    assert!(p.plan.max_step_deg < p.input.max_step_deg);
}

/// Each layer's waypoints (the report's charts) as a plain filter finds them.
#[test]
fn layer_waypoints_are_what_a_plain_filter_finds() {
    let (_, _, p) = default_plan();
    let layers = p.waypoints.iter().map(|w| w.layer).max().unwrap() + 1;
    assert!(layers > 1);
    for k in 0..layers + 1 {
        let plain: Vec<usize> = (0..p.waypoints.len())
            .filter(|&i| p.waypoints[i].layer == k)
            .collect();
        assert_eq!(p.layer_waypoints(k).collect::<Vec<_>>(), plain, "layer {k}");
    }
}

/// The output folder of `maamplan plan --backend cpu` (the embedded
/// default job), run once.
fn plan_command() -> &'static Path {
    static OUT: OnceLock<PathBuf> = OnceLock::new();
    OUT.get_or_init(|| common::plan_default_job("plan", &[]))
}

#[test]
fn plan_command_reports_the_input_and_the_plan() {
    let r = read_json(&plan_command().join("report.json"));
    for side in ["input", "plan"] {
        for k in [
            "waypoints",
            "residual_collisions",
            "colliding_edges",
            "speed_violation_pct",
            "j_deg",
            "max_step_deg",
            "singular_waypoints",
            "breaks",
        ] {
            assert!(r[side][k].is_number(), "{side}.{k}");
        }
    }
    assert!(r["seconds"].as_f64().unwrap() > 0.0);
    assert!(r["stages"]["graph"].is_number());
    assert!(r["flipped_layers"].as_array().unwrap().is_empty());
    assert!(r["skipped"].as_array().unwrap().is_empty());
    assert_eq!(r["margin"], 0.05);
}

#[test]
fn plan_command_writes_a_csv_row_per_waypoint() {
    let r = read_json(&plan_command().join("report.json"));
    let csv = std::fs::read_to_string(plan_command().join("plan.csv")).unwrap();
    assert_eq!(
        csv.lines().count(),
        1 + r["plan"]["waypoints"].as_u64().unwrap() as usize
    );
}

/// The header names maamplan's version, the machine and the command.
#[test]
fn plan_command_gcode_header_names_version_machine_and_command() {
    let g = std::fs::read_to_string(plan_command().join("toolpath.gcode")).unwrap();
    let head: Vec<&str> = g.lines().take_while(|l| l.starts_with(';')).collect();
    assert!(head[0].contains(concat!("maamplan ", env!("CARGO_PKG_VERSION"))));
    assert!(head
        .iter()
        .any(|l| l.starts_with("; machine: configuration III BC")));
    assert!(head
        .iter()
        .any(|l| l.starts_with("; command: ") && l.contains(" plan ")));
}

/// Absolute positioning, an end, and the feeds from the machine file:
/// print 25 mm/s, travel 87.5 mm/s.
#[test]
fn plan_command_gcode_uses_the_machines_feeds() {
    let g = std::fs::read_to_string(plan_command().join("toolpath.gcode")).unwrap();
    assert!(g.contains("\nG90\n") && g.trim_end().ends_with("M30"));
    assert!(g.contains(" F1500") && g.contains(" F5250"));
}

/// Bad machine file: one line, exit 2, nothing written.
#[test]
fn plan_command_refuses_a_bad_machine_file() {
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("m.toml");
    std::fs::write(&bad, "configuration = \"IV\"\n").unwrap();
    let out = dir.path().join("out");
    let o = common::maamplan()
        .args(["plan", "--backend", "cpu", "--machine"])
        .arg(&bad)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(common::stderr(&o).contains("m.toml:1:"));
    assert!(!out.exists());
}

/// `plan --backend cpu -o <out>` with `MAAMPLAN_CACHE_DIR` set to `cache`
/// (and the user's cache folders moved into `dir`): the program without
/// its command line.
fn plan_with_cache(dir: &Path, out: &str, cache: &Path) -> Vec<String> {
    let out = dir.join(out);
    let o = common::maamplan()
        .args(["plan", "--backend", "cpu", "--no-plots", "-q", "-o"])
        .arg(&out)
        .env("MAAMPLAN_CACHE_DIR", cache)
        .env("XDG_CACHE_HOME", dir.join("xdg-cache"))
        .env("HOME", dir.join("home"))
        .output()
        .unwrap();
    assert_success(&o);
    program_lines(&out)
}

/// The G-code a `plan` run wrote into `out`, without its command line.
fn program_lines(out: &Path) -> Vec<String> {
    std::fs::read_to_string(out.join("toolpath.gcode"))
        .unwrap()
        .lines()
        .filter(|l| !l.starts_with("; command:"))
        .map(String::from)
        .collect()
}

/// Which file an entry of the cache folder is (inode) and when it was
/// last written.
fn entry_identity(path: &Path) -> (u64, std::time::SystemTime) {
    use std::os::unix::fs::MetadataExt;
    let meta = std::fs::metadata(path).unwrap();
    (meta.ino(), meta.modified().unwrap())
}

/// The head's data is cached between runs (`MAAMPLAN_CACHE_DIR`): the
/// first run writes one entry, the second reads it (the entry is the same
/// file, not rewritten: a rebuilt head is written to a new file renamed
/// over it) and writes the same program.
#[test]
fn second_plan_reads_the_head_from_the_cache() {
    let dir = tempfile::tempdir().unwrap();
    let cache = dir.path().join("cache");
    let first = plan_with_cache(dir.path(), "a", &cache);
    let entries: Vec<PathBuf> = std::fs::read_dir(&cache)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert_eq!(entries.len(), 1, "one entry for the one head");
    let written = entry_identity(&entries[0]);
    let second = plan_with_cache(dir.path(), "b", &cache);
    assert_eq!(first, second);
    assert_eq!(std::fs::read_dir(&cache).unwrap().count(), 1);
    assert_eq!(
        entry_identity(&entries[0]),
        written,
        "the second run rewrote the entry instead of reading it"
    );
}

/// An empty `MAAMPLAN_CACHE_DIR` turns the cache off: nothing is written
/// to the user's cache folders, and the program is the one planned with
/// the cache.
#[test]
fn an_empty_cache_dir_turns_the_cache_off() {
    let dir = tempfile::tempdir().unwrap();
    let off = plan_with_cache(dir.path(), "off", Path::new(""));
    for folder in ["xdg-cache", "home"] {
        assert!(
            !dir.path().join(folder).exists(),
            "{folder} written with the cache off"
        );
    }
    assert_eq!(off, program_lines(plan_command()));
}

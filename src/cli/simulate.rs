//! `maamplan simulate`: a G-code program (ours in any dialect, or anyone's
//! in the same vocabulary) read back, checked and measured as the machine
//! would run it; the wiring of [`maamplan::simulate`]'s stages.

use super::progress::Reporter;
use super::{check_output, machine_and_margin, RunArgs, SceneArgs, Talk};
use anyhow::{Context, Result};
use clap::Args;
use maamplan::default_job::default_head;
use maamplan::io::gcode_read::{load_program, Program};
use maamplan::io::mesh::load_mesh;
use maamplan::io::output::write_output_set;
use maamplan::kinematics::Machine;
use maamplan::plan::{PlanOptions, Progress};
use maamplan::report::html::{simulation_html, ReportContext, Seen};
use maamplan::report::json::{pretty_bytes, simulation_report, SimulationRun};
use maamplan::report::machine_bodies::machine_bodies;
use maamplan::report::moves_csv::write_moves_csv;
use maamplan::report::part_line;
use maamplan::report::playback::Playback;
use maamplan::report::plots::simulation_figures;
use maamplan::report::program_glb::ProgramScene;
use maamplan::report::watch::seen_side_by_side;
use maamplan::scene::Scene;
use maamplan::simulate::{self, ProblemKind, Simulation, Timeline};
use maamplan::toolpath::Toolpath;
use std::fmt::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `simulate`.
#[derive(Args, Debug)]
pub struct SimulateArgs {
    /// The program (G-code) to simulate: against the TOOLPATH's layers
    /// when given, else against the beads the program lays itself.
    gcode: PathBuf,
    #[command(flatten)]
    scene: SceneArgs,
    #[command(flatten)]
    run: RunArgs,
    /// Output folder: report.json, moves.csv, report.html and program.glb
    /// are replaced in it [default: print the summary only].
    #[arg(short, long)]
    out: Option<PathBuf>,
    /// Skip report.html and program.glb.
    #[arg(long)]
    no_plots: bool,
    #[command(flatten)]
    talk: Talk,
}

/// The toolpath, scene and timeline: the job's (the program printing its
/// layer surfaces in its own order), or without a TOOLPATH the beads the
/// program lays itself.
fn load_scene(
    a: &SimulateArgs,
    machine: &Machine,
    program: &Program,
) -> Result<(String, Toolpath, Scene, Timeline)> {
    if a.scene.toolpath.is_some() {
        let job = a.scene.load(machine)?;
        let s = simulate::against::job(job, machine, program);
        return Ok((s.source, s.toolpath, s.scene, s.timeline));
    }
    let ignored = a.scene.toolpath_options();
    if !ignored.is_empty() && !a.talk.quiet {
        eprintln!(
            "warning: {} ignored: without a TOOLPATH the program is checked in its own frame, the machine's",
            ignored.join(", ")
        );
    }
    let head = match &a.scene.head {
        Some(p) => load_mesh(p)?,
        None => default_head(),
    };
    let platform = match &a.scene.platform {
        Some(p) => Some(load_mesh(p)?),
        None => None,
    };
    let s = simulate::against::own(
        program,
        machine,
        &head,
        platform,
        a.scene.clearance,
        a.scene.part.model(),
    )?;
    Ok((s.source, s.toolpath, s.scene, s.timeline))
}

/// Run `simulate`.
pub fn run(a: SimulateArgs) -> Result<()> {
    let t0 = Instant::now();
    let (machine, margin) = machine_and_margin(a.run.machine.as_deref(), a.run.margin)?;
    if let Some(out) = &a.out {
        check_output(out)?;
    }
    let program = load_program(&a.gcode, &machine)?;
    let moves = &program.moves;
    let show = Reporter::new(a.talk.quiet, a.talk.verbose);
    show.begin("loading");
    let (source, toolpath, scene, timeline) = load_scene(&a, &machine, &program)?;
    show.stage_line("load", t0.elapsed().as_secs_f64(), None);
    show.note(&scene.head_cache.to_string());
    if let Some(w) = scene.part.warning() {
        eprintln!("warning: {w}");
    }

    show.begin("checking");
    let t2 = Instant::now();
    let backend = a.run.backend.build(&scene, !a.talk.quiet)?;
    let tick = |done: u64, total: u64| show.on(Progress::Queries { done, total });
    let (collides, queries) = simulate::check_moves(
        &machine,
        backend.as_ref(),
        &scene,
        margin,
        PlanOptions::default().edge_step,
        moves,
        &timeline.cutoffs,
        Some(&tick),
    )?;
    show.stage_line("check", t2.elapsed().as_secs_f64(), Some(queries));
    if let Some(line) = backend.summary() {
        show.note(&line);
    }

    let t3 = Instant::now();
    let sim = simulate::report(
        &machine,
        moves,
        &timeline,
        &collides,
        queries,
        margin,
        simulate::Deviation::Sampled,
    );
    show.stage_line("measure", t3.elapsed().as_secs_f64(), None);

    let written = match &a.out {
        Some(out) => {
            let layer_names: Vec<String> = toolpath.layers.iter().map(|l| l.name.clone()).collect();
            let run = SimulationRun {
                gcode: &a.gcode.display().to_string(),
                toolpath: &source,
                part: scene.part,
                layer_names: &layer_names,
                backend: backend.name(),
                seconds: t0.elapsed().as_secs_f64(),
                command: &std::env::args().collect::<Vec<_>>().join(" "),
            };
            let shown = Shown {
                scene: &scene,
                playback: &Playback::new(moves, &sim, &timeline),
                margin,
            };
            write_outputs(
                out,
                &machine,
                &sim,
                &run,
                (!a.no_plots).then_some(&shown),
                &show,
            )?
        }
        None => Vec::new(),
    };
    show.finish();
    if a.talk.quiet {
        return Ok(());
    }
    if let Some(w) = scene.part.warning() {
        eprintln!("warning: {w}");
    }
    print!("{}", summary_text(&sim, a.talk.verbose));
    println!("{}", part_line(scene.part));
    let s = &sim.summary;
    println!(
        "{}: {} moves ({} extruding) simulated against {} in {:.2} s (backend {}){}",
        a.gcode.display(),
        s.moves,
        s.extruding_moves,
        source,
        t0.elapsed().as_secs_f64(),
        backend.name(),
        match &a.out {
            Some(o) => format!("; wrote {}/{}", o.display(), written.join(", ")),
            None => String::new(),
        }
    );
    Ok(())
}

/// Everything `simulate` may write into its output folder: a run replaces
/// all of it, so no earlier run's page or scene stays beside a new report.
const SIMULATE_OUTPUTS: [&str; 4] = ["report.json", "moves.csv", "report.html", "program.glb"];

/// What the report's scene and pictures show: the part as the program
/// prints it (the scene re-stamped in print order) and the program's timing.
struct Shown<'a> {
    scene: &'a Scene,
    playback: &'a Playback<'a>,
    margin: f64,
}

/// Write report.json, moves.csv and (with `shown`) report.html and
/// program.glb into `out` at once; returns their names.
fn write_outputs(
    out: &Path,
    machine: &Machine,
    sim: &Simulation,
    run: &SimulationRun,
    shown: Option<&Shown>,
    show: &Reporter,
) -> Result<Vec<String>> {
    let mut files = vec![
        (
            PathBuf::from("report.json"),
            pretty_bytes(&simulation_report(machine, sim, run)),
        ),
        (
            PathBuf::from("moves.csv"),
            write_moves_csv(sim).into_bytes(),
        ),
    ];
    if let Some(shown) = shown {
        let program = ProgramScene {
            machine,
            scene: shown.scene,
            playback: shown.playback,
            stamp: &|s| s,
            bodies: &machine_bodies(machine)?,
        };
        let ((glb, pictures), figs) = rayon::join(
            || seen_side_by_side(&program, shown.margin, show),
            || simulation_figures(machine, sim),
        );
        let figs = figs.map_err(|e| anyhow::anyhow!("drawing the plots: {e}"))?;
        files.push((PathBuf::from("program.glb"), glb));
        let html = simulation_html(
            &ReportContext {
                source: &format!("{} ({})", run.gcode, run.toolpath),
                part: run.part,
                command: run.command,
                flipped_layers: &[],
            },
            machine,
            sim,
            &figs,
            Some(&Seen {
                playback: shown.playback,
                pictures: &pictures,
            }),
        );
        files.push((PathBuf::from("report.html"), html.into_bytes()));
    }
    write_output_set(out, &files, &SIMULATE_OUTPUTS)
        .with_context(|| format!("{}: cannot write the report", out.display()))?;
    Ok(files.iter().map(|f| f.0.display().to_string()).collect())
}

/// The terminal summary: the numbers, then the first problems of each kind
/// (all of them with `verbose`).
fn summary_text(sim: &Simulation, verbose: bool) -> String {
    let s = &sim.summary;
    let mut t = String::new();
    let _ = writeln!(
        t,
        "colliding moves           {:>8} of {} checked (margin {} mm)",
        s.colliding_moves, s.checked_moves, s.margin
    );
    let _ = writeln!(
        t,
        "tip deviation             {:>8.3} mm max, {} extruding moves over the tolerance",
        s.tip_deviation_max_mm, s.tip_deviation_over_tolerance
    );
    let _ = writeln!(
        t,
        "tip-speed violations      {:>8.3} % of extruding moves ({:.3} % of the length)",
        s.speed_violation_pct + 0.0,
        s.speed_violation_pct_length + 0.0
    );
    let _ = writeln!(
        t,
        "largest rotary step       {:>8.1}° while extruding, {} swings over {}°",
        s.rotary_step_max_deg,
        s.swings,
        simulate::measure::SWING_DEG
    );
    let _ = writeln!(
        t,
        "travels                   {:>8} (largest C turn {:.1}°, {} over 180°)",
        s.travels, s.travel_c_max_deg, s.long_travel_turns
    );
    let _ = writeln!(
        t,
        "extrusion per mm          {:>8.4} median, {:.4} max, {} blobs",
        s.e_per_mm_median, s.e_per_mm_max, s.blobs
    );
    let _ = writeln!(
        t,
        "printed waypoints         {:>8} of {}; program {:.0} s",
        s.printed_waypoints, s.waypoints, s.seconds
    );
    for kind in ProblemKind::ALL {
        let of: Vec<_> = sim.problems.iter().filter(|p| p.kind == kind).collect();
        if of.is_empty() {
            continue;
        }
        let shown = if verbose { of.len() } else { of.len().min(5) };
        let lines: Vec<String> = of[..shown].iter().map(|p| p.line.to_string()).collect();
        let _ = writeln!(
            t,
            "{:?} at line{} {}{}",
            kind,
            if of.len() > 1 { "s" } else { "" },
            lines.join(", "),
            if shown < of.len() {
                format!(" … ({} in all, report.json lists them)", of.len())
            } else {
                String::new()
            }
        );
    }
    t
}

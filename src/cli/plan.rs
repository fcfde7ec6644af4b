//! `maamplan plan`: waypoints → the machine's program (G-code), a CSV and a
//! report.

use super::progress::Reporter;
use super::{
    check_output, job_error, load_machine_or_default, RunArgs, SceneArgs, Talk, UsageError,
};
use anyhow::{Context, Result};
use clap::{Args, ValueEnum};
use maamplan::io::output::{write_atomic, FolderFile};
use maamplan::job::LoadedJob;
use maamplan::kinematics::Machine;
use maamplan::plan::candidates::Sampling;
use maamplan::plan::smooth::Smoothing;
use maamplan::plan::{plan_prepared, Plan, PlanOptions, Skip};
use maamplan::report::html::ReportContext;
use maamplan::report::json::{
    plan_report, pretty_bytes, skipped_waypoints, PlanRun, SkippedWaypoint,
};
use maamplan::report::plan_files::{write_output, Rendered};
use maamplan::report::{part_line, summary_rows, warnings};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Smoothing choices on the command line.
#[derive(ValueEnum, Clone, Copy, Debug)]
pub enum SmoothingKind {
    /// Average each orientation with its neighbours, a few passes (default).
    Laplacian,
    /// Moving average, kept within --cone of the input.
    MovingAverage,
    /// Moving median, kept within --cone of the input.
    Median,
    /// Use the orientations as given.
    None,
}

/// Arguments of `plan`.
#[derive(Args, Debug)]
pub struct PlanArgs {
    #[command(flatten)]
    scene: SceneArgs,
    /// Output folder: created if missing; toolpath.gcode, plan.csv,
    /// report.json and the report files are replaced in it.
    #[arg(short, long, required_unless_present = "write_machine")]
    out: Option<PathBuf>,
    #[command(flatten)]
    run: RunArgs,
    /// Fail (exit code 3, nothing written) instead of skipping waypoints
    /// that no reachable orientation can print safely.
    #[arg(long)]
    strict: bool,
    /// How to smooth the nozzle orientations before planning.
    #[arg(long, value_enum, default_value_t = SmoothingKind::Laplacian)]
    smoothing: SmoothingKind,
    /// Passes of the default smoothing (more: smoother rotary motion,
    /// orientations farther from the input).
    #[arg(long, default_value_t = 8)]
    passes: usize,
    /// Waypoints averaged by --smoothing moving-average / median.
    #[arg(long, default_value_t = 9)]
    window: usize,
    /// How far (degrees) moving-average / median smoothing may turn an
    /// orientation away from the input.
    #[arg(long, default_value_t = 15.0)]
    cone: f64,
    /// Orientations within this angle of vertical (degrees) count as
    /// singular: there the C axis is handled specially to avoid spins.
    #[arg(long, default_value_t = 4.5)]
    alpha: f64,
    /// Where an orientation collides, alternatives are first sought within
    /// this angle of it (degrees), widening until one is free.
    #[arg(long, default_value_t = 45.0)]
    beta: f64,
    /// Alternative orientations tried per round for a colliding waypoint.
    #[arg(long, default_value_t = 24)]
    variants: usize,
    /// Try alternatives ring by ring (10° apart) instead of at random.
    #[arg(long)]
    rings: bool,
    /// For very long toolpaths: plan every K-th waypoint first, then fill
    /// in between (faster, possibly less smooth; 1 = exact).
    #[arg(long, default_value_t = 1)]
    subsample: usize,
    /// Initial spacing of the collision checks along each move: the
    /// distance the nozzle tip moves between two (mm); checks are refined
    /// where material is near.
    #[arg(long, default_value_t = 0.3)]
    edge_step: f64,
    /// Skip the plots, the 3D scene and the HTML report (faster).
    #[arg(long)]
    no_plots: bool,
    #[command(flatten)]
    talk: Talk,
    /// Write the default machine file here and exit.
    #[arg(long)]
    write_machine: Option<PathBuf>,
}

/// `--strict` found waypoints it would have skipped (exit code 3).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct StrictError(pub String);

impl PlanArgs {
    /// The angles, steps and margin within the ranges the planner is
    /// meant for.
    fn check_ranges(&self) -> Result<()> {
        for (name, v, lo, hi) in [
            ("--alpha", self.alpha, 0.0, 45.0),
            ("--beta", self.beta, 1.0, 90.0),
            ("--cone", self.cone, 0.1, 90.0),
            ("--edge-step", self.edge_step, 0.01, 10.0),
            ("--margin", self.run.margin.unwrap_or(0.05), 0.0, 10.0),
        ] {
            if !(v >= lo && v <= hi) {
                return Err(UsageError(format!("{name} must be between {lo} and {hi}")).into());
            }
        }
        Ok(())
    }

    /// The planner's settings from the flags.
    fn plan_options(&self) -> PlanOptions {
        PlanOptions {
            smoothing: match self.smoothing {
                SmoothingKind::Laplacian => Smoothing::Laplacian {
                    passes: self.passes,
                },
                SmoothingKind::MovingAverage => Smoothing::MovingAverage {
                    window: self.window,
                    cone_deg: self.cone,
                },
                SmoothingKind::Median => Smoothing::Median {
                    window: self.window,
                    cone_deg: self.cone,
                },
                SmoothingKind::None => Smoothing::None,
            },
            alpha: self.alpha.to_radians(),
            beta: self.beta.to_radians(),
            sampling: if self.rings {
                Sampling::Rings
            } else {
                Sampling::Random {
                    k: self.variants.max(1),
                }
            },
            edge_step: self.edge_step,
            subsample: self.subsample.max(1),
            margin: self.run.margin,
            ..PlanOptions::default()
        }
    }
}

/// Run `plan`.
pub fn run(a: PlanArgs) -> Result<()> {
    if let Some(path) = &a.write_machine {
        return write_default_machine(path);
    }
    let out = a.out.clone().expect("clap requires -o");
    a.check_ranges()?;
    check_output(&out)?;
    let t0 = Instant::now();
    let show = Reporter::new(a.talk.quiet, a.talk.verbose);
    show.begin("loading");
    let machine = load_machine_or_default(a.run.machine.as_deref())?;
    let mut opts = a.plan_options();
    // Stages 1 and 2 need only the toolpath: they run while the scene is
    // built, and the GPU opens meanwhile.
    let opening = a.run.backend.open();
    let (mut job, prepared) =
        LoadedJob::load_prepared(&a.scene.spec(&machine)?, &machine, &mut opts)
            .map_err(job_error)?;
    let backend =
        a.run
            .backend
            .build_with(opening, &job.scene, !a.talk.quiet, Default::default())?;
    let mut stages = vec![("load".to_string(), t0.elapsed().as_secs_f64())];
    show.stage_line("load", stages[0].1, None);
    show.note(&job.scene.head_cache.to_string());
    let p = plan_prepared(
        prepared,
        &job.scene,
        &machine,
        backend.as_ref(),
        &opts,
        &mut |e| show.on(e),
    )?;
    if let Some(line) = backend.summary() {
        show.note(&line);
    }
    // Planned: the evaluator and the part's BVH are done with; the report
    // draws the part from its groups.
    let backend_name = backend.name();
    drop(backend);
    job.scene.release_bvh();
    let skipped = skipped_waypoints(&p, &job.toolpath);
    if a.strict {
        refuse_skips(&skipped)?;
    }
    // Planned: what is left is output.
    let seconds = t0.elapsed().as_secs_f64();
    show.begin("writing");
    stages.extend(p.stages.iter().map(|s| (s.name.clone(), s.seconds)));
    let command = std::env::args().collect::<Vec<_>>().join(" ");
    let flipped = job.flipped_names();
    let context = ReportContext {
        source: &job.source,
        part: job.scene.part,
        command: &command,
        flipped_layers: &flipped,
    };
    let report_margin = (!a.no_plots).then(|| a.run.margin.unwrap_or(machine.margin));
    let rendered = Rendered::new(&machine, &p, &job, &context, seconds, report_margin, &show)?;
    stages.extend(rendered.stages.iter().cloned());
    let report = plan_report(
        &machine,
        &p,
        &skipped,
        &PlanRun {
            source: &job.source,
            part: job.scene.part,
            backend: backend_name,
            flipped_layers: &flipped,
            stages: &stages,
            seconds: t0.elapsed().as_secs_f64(),
            command: &command,
        },
    );
    let files = rendered.into_files(pretty_bytes(&report));
    write_output(&out, &files).map_err(|e| UsageError(e.0))?;
    show.finish();
    if !a.talk.quiet {
        let written = Written {
            out: &out,
            names: top_level_names(&files),
        };
        print_summary(&job, &p, &flipped, (seconds, t0), backend_name, &written);
    }
    // The command ends the process: the OS takes back the scene and the
    // plan at once, faster than freeing them piece by piece.
    std::mem::forget(p);
    std::mem::forget(job);
    Ok(())
}

/// `--write-machine`: the built-in machine as a file to start from.
fn write_default_machine(path: &Path) -> Result<()> {
    write_atomic(path, Machine::default().to_toml().as_bytes())
        .with_context(|| format!("{}: cannot write the machine file", path.display()))?;
    println!("wrote the default machine to {}", path.display());
    Ok(())
}

/// `--strict`: fail, before anything is written, where the plan skips
/// waypoints.
fn refuse_skips(skipped: &[SkippedWaypoint]) -> Result<()> {
    let Some(first) = skipped.first() else {
        return Ok(());
    };
    let residual = skipped
        .iter()
        .filter(|s| s.reason == Skip::Residual)
        .count();
    Err(StrictError(format!(
        "--strict: {} waypoint(s) cannot be printed safely ({} with no safe orientation, {} out of the axis ranges; first: waypoint {}); nothing written",
        skipped.len(),
        residual,
        skipped.len() - residual,
        first.index
    ))
    .into())
}

/// The entries of the output folder `files` make (a file, or a folder
/// such as `plots`), in their order.
fn top_level_names(files: &[FolderFile]) -> Vec<String> {
    let mut names: Vec<String> = Vec::new();
    for (path, _) in files {
        if let Some(top) = path.components().next() {
            let top = top.as_os_str().to_string_lossy().into_owned();
            if !names.contains(&top) {
                names.push(top);
            }
        }
    }
    names
}

/// Where `plan` wrote: the folder and its entries.
struct Written<'a> {
    out: &'a Path,
    names: Vec<String>,
}

/// What `plan` prints when it is done: warnings (the part model's
/// first), flipped layers, the input and plan side by side, the part
/// model, and where it wrote.
fn print_summary(
    job: &LoadedJob,
    p: &Plan,
    flipped: &[String],
    (seconds, t0): (f64, Instant),
    backend: &str,
    written: &Written,
) {
    for w in warnings(job.scene.part, &p.warnings) {
        eprintln!("warning: {w}");
    }
    if !flipped.is_empty() {
        println!(
            "reversed the nozzle directions of {} layer(s) {} (--keep-normals to keep them): {}",
            flipped.len(),
            job.flip_reason(),
            flipped.join(", ")
        );
    }
    println!("{:<36} {:>12} {:>14}", "", "input", "plan");
    for (k, i, pl) in summary_rows(&p.input, &p.plan) {
        println!("{k:<36} {i:>12} {pl:>14}");
    }
    println!("{}", part_line(job.scene.part));
    println!(
        "{}: planned in {:.2} s, {:.2} s in all (backend {}); wrote {}/{}",
        job.source,
        seconds,
        t0.elapsed().as_secs_f64(),
        backend,
        written.out.display(),
        written.names.join(", ")
    );
}

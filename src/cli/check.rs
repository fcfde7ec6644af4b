//! `maamplan check`: every waypoint's head pose — as the machine poses it,
//! the same pose `plan` starts from — or a written plan's poses and
//! printing moves, one verdict each, counted per layer.

use super::{machine_and_margin, progress, write_json, BackendKind, SceneArgs, Talk, UsageError};
use anyhow::Result;
use clap::Args;
use maamplan::check::{self, CheckError, LayerCount, Verdicts};
use maamplan::collide::Backend;
use maamplan::io::plan_csv::read_plan;
use maamplan::job::LoadedJob;
use maamplan::kinematics::Machine;
use maamplan::plan::{head_reach, PlanOptions};
use maamplan::prove::Prover;
use maamplan::report::json::{check_report, CheckRun};
use maamplan::report::part_line;
use maamplan::scene::Scene;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `check`.
#[derive(Args, Debug)]
pub struct CheckArgs {
    #[command(flatten)]
    scene: SceneArgs,
    /// Collision evaluator.
    #[arg(long, value_enum, default_value_t = BackendKind::Auto)]
    backend: BackendKind,
    /// Machine file: how the machine poses the head [default: the built-in
    /// machine; `plan --write-machine` shows it].
    #[arg(long)]
    machine: Option<PathBuf>,
    /// Safety margin: a pose collides when anything comes closer than this
    /// to the head (mm) [default: the machine file's, 0.05; 0 = touching].
    #[arg(long)]
    margin: Option<f64>,
    /// Check a written plan instead: the poses of `plan.csv`'s machine axes
    /// and the printing moves between consecutive rows, as `plan` writes
    /// them.
    #[arg(long, value_name = "PLAN_CSV")]
    plan: Option<PathBuf>,
    /// Also write the results as JSON to this file.
    #[arg(long)]
    json: Option<PathBuf>,
    #[command(flatten)]
    talk: Talk,
}

/// Run `check`.
pub fn run(a: CheckArgs) -> Result<()> {
    let (machine, margin) = machine_and_margin(a.machine.as_deref(), a.margin)?;
    let opening = a.backend.open();
    let job = a.scene.load(&machine)?;
    let backend = a
        .backend
        .build_with(opening, &job.scene, !a.talk.quiet, Default::default())?;
    let prover = Prover::new(
        &machine,
        backend.as_ref(),
        head_reach(&job.scene),
        margin,
        PlanOptions::default().edge_step,
    );
    let t0 = Instant::now();
    let pb = progress(job.toolpath.waypoint_count() as u64, "checking");
    let verdicts = match &a.plan {
        Some(csv) => check_written_plan(&job, &machine, &prover, csv)?,
        None => check::input_poses(&job, &machine, &prover)?,
    };
    pb.finish_and_clear();
    let seconds = t0.elapsed().as_secs_f64();
    let flipped = job.flipped_names();
    let run = CheckRun {
        source: &job.source,
        part: job.scene.part,
        backend: backend.name(),
        margin,
        seconds,
        flipped_layers: &flipped,
    };
    let layers: Vec<(&str, LayerCount)> = job
        .toolpath
        .layers
        .iter()
        .map(|l| l.name.as_str())
        .zip(verdicts.per_layer(&job))
        .collect();
    if let Some(path) = &a.json {
        write_json(path, &check_report(&run, &layers, &verdicts))?;
    }
    if a.talk.quiet {
        return Ok(());
    }
    if let Some(w) = job.scene.part.warning() {
        eprintln!("warning: {w}");
    }
    if a.talk.verbose {
        print_scene(&job.scene, &prover, backend.as_ref());
    }
    if !flipped.is_empty() {
        println!(
            "reversed the nozzle directions of {} layer(s) {}: {}",
            flipped.len(),
            job.flip_reason(),
            flipped.join(", ")
        );
    }
    let with_moves = a.plan.is_some();
    print_layers(&layers, with_moves);
    println!("{}", part_line(job.scene.part));
    print_total(&run, &job, &verdicts, &layers, with_moves);
    Ok(())
}

/// `check --plan`: the written plan's rows read and checked.
fn check_written_plan(
    job: &LoadedJob,
    machine: &Machine,
    prover: &Prover,
    csv: &Path,
) -> Result<Verdicts> {
    let rows = read_plan(csv)?;
    check::written_plan(job, machine, prover, &rows).map_err(|e| match e {
        e @ CheckError::RowCount { .. } => UsageError(format!("{}: {e}", csv.display())).into(),
        CheckError::Collide(e) => e.into(),
    })
}

/// `-v`: the scene's size and the evaluator's own summary.
fn print_scene(scene: &Scene, prover: &Prover, backend: &dyn Backend) {
    println!(
        "scene: {} triangles ({} BVH nodes), head {} triangles, grid {:?} cells of {:.3} mm, tolerance {:.1e} mm; {} collision queries",
        scene.triangle_count(),
        scene.part_nodes.len(),
        scene.head.triangles.len(),
        scene.head.params.grid_dims,
        scene.head.params.cell,
        scene.tol,
        prover.queries()
    );
    if let Some(line) = backend.summary() {
        println!("{line}");
    }
}

/// The per-layer table (with a column of colliding moves when a plan's
/// moves were checked).
fn print_layers(layers: &[(&str, LayerCount)], with_moves: bool) {
    if with_moves {
        println!(
            "{:>8} {:>10} {:>10} {:>10}",
            "layer", "waypoints", "colliding", "moves"
        );
    } else {
        println!("{:>8} {:>10} {:>10}", "layer", "waypoints", "colliding");
    }
    for (name, count) in layers {
        if with_moves {
            println!(
                "{:>8} {:>10} {:>10} {:>10}",
                name, count.waypoints, count.colliding, count.colliding_moves
            );
        } else {
            println!(
                "{:>8} {:>10} {:>10}",
                name, count.waypoints, count.colliding
            );
        }
    }
}

/// The closing line: how many waypoints (and moves) come within the margin.
fn print_total(
    run: &CheckRun,
    job: &LoadedJob,
    verdicts: &Verdicts,
    layers: &[(&str, LayerCount)],
    with_moves: bool,
) {
    let total = LayerCount::total(layers.iter().map(|l| &l.1));
    let n = verdicts.poses.len();
    let moves_note = if with_moves {
        format!(
            ", {} of {} printing moves",
            total.colliding_moves,
            verdicts.moves_checked()
        )
    } else {
        String::new()
    };
    println!(
        "{}: {} of {} waypoints come within {} mm ({:.2} %){moves_note} — backend {}, {:.3} s, scene {} triangles built in {:.2} s",
        run.source,
        total.colliding,
        n,
        run.margin,
        100.0 * total.colliding as f64 / n.max(1) as f64,
        run.backend,
        run.seconds,
        job.scene.triangle_count(),
        job.seconds,
    );
}

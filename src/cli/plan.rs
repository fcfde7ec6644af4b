//! `maamplan plan`: waypoints → the machine's program (G-code), a CSV and a
//! report.

use super::progress::Reporter;
use super::{BackendKind, SceneArgs, UsageError};
use anyhow::{Context, Result};
use clap::{Args, ValueEnum};
use maamplan::io::gcode::{write_gcode, GcodeHeader};
use maamplan::io::output::write_atomic;
use maamplan::io::plan_csv::write_plan_csv;
use maamplan::kinematics::{load_machine, Machine};
use maamplan::plan::candidates::Sampling;
use maamplan::plan::smooth::Smoothing;
use maamplan::plan::{plan_prepared, PlanOptions, Prepared, Skip};
use serde_json::json;
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
    /// Machine file (TOML) [default: the data set's B/C rotary-table
    /// printer; `--write-machine` writes it out to start from].
    #[arg(long)]
    machine: Option<PathBuf>,
    /// Collision evaluator.
    #[arg(long, value_enum, default_value_t = BackendKind::Auto)]
    backend: BackendKind,
    /// Safety margin every pose and move keeps from the platform and the
    /// printed part (mm) [default: the machine file's, 0.05].
    #[arg(long)]
    margin: Option<f64>,
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
    /// Print only errors.
    #[arg(short, long)]
    quiet: bool,
    /// Print a line per stage (seconds, collision queries) as it ends.
    #[arg(short, long, conflicts_with = "quiet")]
    verbose: bool,
    /// Write the default machine file here and exit.
    #[arg(long)]
    write_machine: Option<PathBuf>,
}

/// `--strict` found waypoints it would have skipped (exit code 3).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct StrictError(pub String);

/// Check before any work that `out` can become the output folder: not a
/// file, and its nearest existing ancestor a writable folder.
pub(crate) fn check_output(out: &Path) -> Result<()> {
    if out.exists() && !out.is_dir() {
        return Err(UsageError(format!(
            "{}: is a file, not a folder: give -o a folder to write the plan into",
            out.display()
        ))
        .into());
    }
    let mut anc = out;
    while !anc.exists() {
        anc = match anc.parent() {
            Some(p) if !p.as_os_str().is_empty() => p,
            _ => Path::new("."),
        };
    }
    if !anc.is_dir() {
        return Err(UsageError(format!(
            "{}: cannot create the output folder {} inside a file",
            anc.display(),
            out.display()
        ))
        .into());
    }
    tempfile::Builder::new()
        .prefix(".maamplan-probe-")
        .tempdir_in(anc)
        .map_err(|e| {
            UsageError(format!(
                "{}: cannot write there ({e}): choose another -o folder",
                anc.display()
            ))
        })?;
    Ok(())
}

/// Run `plan`.
pub fn run(a: PlanArgs) -> Result<()> {
    if let Some(p) = &a.write_machine {
        write_atomic(p, Machine::default().to_toml().as_bytes())
            .with_context(|| format!("{}: cannot write the machine file", p.display()))?;
        println!("wrote the default machine to {}", p.display());
        return Ok(());
    }
    let out = a.out.clone().expect("clap requires -o");
    for (name, v, lo, hi) in [
        ("--alpha", a.alpha, 0.0, 45.0),
        ("--beta", a.beta, 1.0, 90.0),
        ("--cone", a.cone, 0.1, 90.0),
        ("--edge-step", a.edge_step, 0.01, 10.0),
        ("--margin", a.margin.unwrap_or(0.05), 0.0, 10.0),
    ] {
        if !(v >= lo && v <= hi) {
            return Err(UsageError(format!("{name} must be between {lo} and {hi}")).into());
        }
    }
    check_output(&out)?;
    let t0 = Instant::now();
    let show = Reporter::new(a.quiet, a.verbose);
    show.begin("loading");
    let machine = match &a.machine {
        Some(p) => load_machine(p)?,
        None => Machine::default(),
    };
    let opts = PlanOptions {
        smoothing: match a.smoothing {
            SmoothingKind::Laplacian => Smoothing::Laplacian { passes: a.passes },
            SmoothingKind::MovingAverage => Smoothing::MovingAverage {
                window: a.window,
                cone_deg: a.cone,
            },
            SmoothingKind::Median => Smoothing::Median {
                window: a.window,
                cone_deg: a.cone,
            },
            SmoothingKind::None => Smoothing::None,
        },
        alpha: a.alpha.to_radians(),
        beta: a.beta.to_radians(),
        sampling: if a.rings {
            Sampling::Rings
        } else {
            Sampling::Random {
                k: a.variants.max(1),
            }
        },
        edge_step: a.edge_step,
        subsample: a.subsample.max(1),
        margin: a.margin,
        ..PlanOptions::default()
    };
    // Stages 1 and 2 need only the toolpath: they run while the scene is
    // built, and the GPU opens meanwhile.
    let opening = a.backend.open();
    let (job, prepared) = a
        .scene
        .load_beside(|toolpath| Prepared::new(toolpath, &machine, &opts))?;
    let scene = &job.scene;
    let backend = a
        .backend
        .build_with(opening, scene, !a.quiet, Default::default())?;
    let load_s = t0.elapsed().as_secs_f64();
    show.stage_line("load", load_s, None);
    show.note(&scene.head_cache.to_string());

    let p = plan_prepared(
        prepared,
        scene,
        &machine,
        backend.as_ref(),
        &opts,
        &mut |e| show.on(e),
    )?;
    if let Some(line) = backend.summary() {
        show.note(&line);
    }

    let layer_name = |l: usize| job.toolpath.layers[l].name.clone();
    let skipped: Vec<serde_json::Value> = p
        .waypoints
        .iter()
        .enumerate()
        .filter_map(|(g, w)| {
            w.skipped.map(|why| {
                json!({"index": g, "layer": w.layer, "layer_name": layer_name(w.layer), "reason": why})
            })
        })
        .collect();
    if a.strict && !skipped.is_empty() {
        let n_res = p
            .waypoints
            .iter()
            .filter(|w| w.skipped == Some(Skip::Residual))
            .count();
        return Err(StrictError(format!(
            "--strict: {} waypoint(s) cannot be printed safely ({} with no safe orientation, {} out of the axis ranges; first: waypoint {}); nothing written",
            skipped.len(),
            n_res,
            skipped.len() - n_res,
            skipped[0]["index"]
        ))
        .into());
    }

    // Planned: what is left is output. The program and the report are
    // independent and written side by side.
    let seconds = t0.elapsed().as_secs_f64();
    show.begin("writing");
    let command = std::env::args().collect::<Vec<_>>().join(" ");
    let header = GcodeHeader {
        source: job.source.clone(),
        command: command.clone(),
    };
    // Everything goes into a scratch folder beside DIR first; only when all
    // of it exists is it moved into DIR, so a failed run leaves nothing.
    let parent = out
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    std::fs::create_dir_all(parent).map_err(|e| {
        UsageError(format!(
            "{}: cannot create the output folder ({e})",
            parent.display()
        ))
    })?;
    let scratch = tempfile::Builder::new()
        .prefix(".maamplan-")
        .tempdir_in(parent)
        .map_err(|e| UsageError(format!("{}: cannot write there ({e})", parent.display())))?;
    let put = |name: &str, bytes: &[u8]| -> Result<()> {
        std::fs::write(scratch.path().join(name), bytes).with_context(|| format!("writing {name}"))
    };
    let (written, drawn) = rayon::join(
        || -> Result<f64> {
            let t = Instant::now();
            let (gcode, csv) = rayon::join(
                || write_gcode(&machine, &p.program, &header),
                || write_plan_csv(&machine, &p.waypoints),
            );
            put("toolpath.gcode", gcode.as_bytes())?;
            put("plan.csv", csv.as_bytes())?;
            Ok(t.elapsed().as_secs_f64())
        },
        || {
            (!a.no_plots).then(|| {
                let t = Instant::now();
                // The figures and the scene file are independent too.
                let (figs, glb) = rayon::join(
                    || {
                        maamplan::report::plots::write_figures(
                            &machine,
                            &p,
                            &scratch.path().join("plots"),
                        )
                    },
                    || maamplan::report::scene_glb::scene_glb(scene, &p, &machine),
                );
                (figs, glb, t)
            })
        },
    );
    let write_s = written?;
    show.stage_line("write", write_s, None);
    let mut stages = serde_json::Map::new();
    stages.insert("load".into(), json!(load_s));
    for s in &p.stages {
        stages.insert(s.name.clone(), json!(s.seconds));
    }
    stages.insert("write".into(), json!(write_s));
    let mut files = vec![
        "toolpath.gcode".to_string(),
        "plan.csv".to_string(),
        "report.json".to_string(),
    ];
    let flipped = job.flipped_names();
    if let Some((figs, glb, t2)) = drawn {
        show.begin("report");
        let figs = figs.map_err(|e| anyhow::anyhow!("drawing the plots: {e}"))?;
        put("scene.glb", &glb)?;
        let html = maamplan::report::html::report_html(
            &maamplan::report::html::ReportContext {
                source: &job.source,
                command: &command,
                flipped_layers: &flipped,
            },
            &machine,
            &p,
            &figs,
            seconds,
        );
        put("report.html", html.as_bytes())?;
        let report_s = t2.elapsed().as_secs_f64();
        show.stage_line("report", report_s, None);
        stages.insert("report".into(), json!(report_s));
        files.extend([
            "scene.glb".to_string(),
            "report.html".to_string(),
            "plots".to_string(),
        ]);
    }
    let report = json!({
        "source": job.source,
        "backend": backend.name(),
        "machine": machine,
        "margin": p.margin,
        "flipped_layers": flipped,
        "input": p.input,
        "plan": p.plan,
        "skipped": skipped,
        "warnings": p.warnings,
        "collision_queries": p.queries,
        "seconds": t0.elapsed().as_secs_f64(),
        "stages": stages,
        "command": command,
    });
    let mut text = serde_json::to_string_pretty(&report)?;
    text.push('\n');
    put("report.json", text.as_bytes())?;
    std::fs::create_dir_all(&out).map_err(|e| {
        UsageError(format!(
            "{}: cannot create the output folder ({e})",
            out.display()
        ))
    })?;
    for f in &files {
        let dst = out.join(f);
        if dst.is_dir() {
            std::fs::remove_dir_all(&dst)
                .with_context(|| format!("replacing {}", dst.display()))?;
        }
        std::fs::rename(scratch.path().join(f), &dst)
            .map_err(|e| UsageError(format!("{}: cannot write ({e})", dst.display())))?;
    }
    show.finish();
    if !a.quiet {
        print_summary(
            &job,
            &p,
            &flipped,
            (seconds, t0),
            backend.name(),
            &out,
            &files,
        );
    }
    // The command ends the process: the OS takes back the scene and the
    // plan at once, where freeing them piece by piece took 0.13 s of
    // dome_cut's run.
    drop(backend);
    std::mem::forget(p);
    std::mem::forget(job);
    Ok(())
}

/// What `plan` prints when it is done: warnings, flipped layers, the
/// input and plan side by side, and where it wrote.
fn print_summary(
    job: &maamplan::job::LoadedJob,
    p: &maamplan::plan::Plan,
    flipped: &[String],
    (seconds, t0): (f64, Instant),
    backend: &str,
    out: &Path,
    files: &[String],
) {
    for w in &p.warnings {
        eprintln!("warning: {w}");
    }
    if !flipped.is_empty() {
        println!(
            "reversed the nozzle directions of {} layer(s) that mostly pointed down (--keep-normals to keep them): {}",
            flipped.len(),
            flipped.join(", ")
        );
    }
    println!("{:<36} {:>12} {:>14}", "", "input", "plan");
    for (k, i, pl) in maamplan::report::summary_rows(&p.input, &p.plan) {
        println!("{k:<36} {i:>12} {pl:>14}");
    }
    println!(
        "{}: planned in {:.2} s, {:.2} s in all (backend {}); wrote {}/{}",
        job.source,
        seconds,
        t0.elapsed().as_secs_f64(),
        backend,
        out.display(),
        files.join(", ")
    );
}

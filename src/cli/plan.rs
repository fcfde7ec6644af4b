//! `maamplan plan`: waypoints → machine axes, G-code, CSV and a report.

use super::{BackendKind, SceneArgs, UsageError};
use anyhow::{Context, Result};
use clap::{Args, ValueEnum};
use maamplan::io::gcode::write_gcode;
use maamplan::io::output::write_atomic;
use maamplan::io::plan_csv::write_plan_csv;
use maamplan::kinematics::{load_machine, Machine};
use maamplan::plan::candidates::Sampling;
use maamplan::plan::smooth::Smoothing;
use maamplan::plan::{plan, PlanOptions};
use serde_json::json;
use std::path::PathBuf;
use std::time::Instant;

/// Smoothing choices on the command line.
#[derive(ValueEnum, Clone, Copy, Debug)]
pub enum SmoothingKind {
    /// Paper 000's Laplacian pass.
    Laplacian,
    /// Paper 004's zero-phase moving average with cone correction.
    MovingAverage,
    /// Paper 004's zero-phase median with cone correction.
    Median,
    /// Orientations as given.
    None,
}

/// Arguments of `plan`.
#[derive(Args, Debug)]
pub struct PlanArgs {
    #[command(flatten)]
    scene: SceneArgs,
    /// Machine file (TOML) [default: the data set's B/C rotary-table printer; `--write-machine` shows it].
    #[arg(long)]
    machine: Option<PathBuf>,
    /// Collision evaluator.
    #[arg(long, value_enum, default_value_t = BackendKind::Auto)]
    backend: BackendKind,
    /// Output folder (created).
    #[arg(short, long)]
    out: Option<PathBuf>,
    /// Orientation smoothing before planning.
    #[arg(long, value_enum, default_value_t = SmoothingKind::Laplacian)]
    smoothing: SmoothingKind,
    /// Passes of the Laplacian smoothing (8: see BENCHMARKS.md for why).
    #[arg(long, default_value_t = 8)]
    passes: usize,
    /// Window (waypoints) of the moving-average / median smoothing.
    #[arg(long, default_value_t = 9)]
    window: usize,
    /// Tolerance cone half-angle of the moving-average / median smoothing (degrees).
    #[arg(long, default_value_t = 15.0)]
    cone: f64,
    /// Singular region half-angle α (degrees, Eq. 6).
    #[arg(long, default_value_t = 4.5)]
    alpha: f64,
    /// Variant cone half-angle β (degrees).
    #[arg(long, default_value_t = 45.0)]
    beta: f64,
    /// Variants per round of random sampling.
    #[arg(long, default_value_t = 24)]
    variants: usize,
    /// Grow variants ring by ring (paper 002, heuristic 1) instead of sampling.
    #[arg(long)]
    rings: bool,
    /// Paper 002's interval subsampling for very long paths: plan every
    /// K-th waypoint first, then the intervals (1 = exact).
    #[arg(long, default_value_t = 1)]
    subsample: usize,
    /// Largest move of any head point between two motion checks (mm).
    #[arg(long, default_value_t = 0.5)]
    edge_step: f64,
    /// Skip the plots, the 3D scene and the HTML report.
    #[arg(long)]
    no_plots: bool,
    /// Print only errors.
    #[arg(short, long)]
    quiet: bool,
    /// Print seconds per stage too.
    #[arg(short, long, conflicts_with = "quiet")]
    verbose: bool,
    /// Write the default machine file here and exit.
    #[arg(long)]
    write_machine: Option<PathBuf>,
}

/// Run `plan`.
pub fn run(a: PlanArgs) -> Result<()> {
    if let Some(p) = &a.write_machine {
        write_atomic(p, Machine::default().to_toml().as_bytes())
            .with_context(|| format!("{}: cannot write the machine file", p.display()))?;
        println!("wrote the default machine to {}", p.display());
        return Ok(());
    }
    let Some(out) = a.out.clone() else {
        return Err(UsageError("plan needs -o DIR (the output folder)".into()).into());
    };
    for (name, v, lo, hi) in [
        ("--alpha", a.alpha, 0.0, 45.0),
        ("--beta", a.beta, 1.0, 90.0),
        ("--cone", a.cone, 0.1, 90.0),
        ("--edge-step", a.edge_step, 0.01, 10.0),
    ] {
        if !(v >= lo && v <= hi) {
            return Err(UsageError(format!("{name} must be between {lo} and {hi}")).into());
        }
    }
    let t0 = Instant::now();
    let machine = match &a.machine {
        Some(p) => load_machine(p)?,
        None => Machine::default(),
    };
    let loaded = a.scene.load()?;
    let scene = &loaded.scene;
    let backend = a.backend.build(scene, !a.quiet)?;
    let load_s = t0.elapsed().as_secs_f64();

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
        jump: 5.0,
        subsample: a.subsample.max(1),
    };
    let pb = if a.quiet {
        indicatif::ProgressBar::hidden()
    } else {
        indicatif::ProgressBar::new_spinner()
    };
    pb.set_style(
        indicatif::ProgressStyle::with_template("{spinner} {msg} ({elapsed})")
            .expect("static template"),
    );
    pb.enable_steady_tick(std::time::Duration::from_millis(120));
    let p = plan(
        scene,
        &loaded.toolpath,
        &machine,
        backend.as_ref(),
        &opts,
        &mut |stage| pb.set_message(stage.to_string()),
    )?;
    pb.finish_and_clear();

    let t1 = Instant::now();
    let gcode = write_gcode(&machine, &p.waypoints);
    let csv = write_plan_csv(&machine, &p.waypoints);
    let write_s = t1.elapsed().as_secs_f64();
    let mut stages = serde_json::Map::new();
    stages.insert("load".into(), json!(load_s));
    for (k, v) in &p.stages {
        stages.insert(k.clone(), json!(v));
    }
    stages.insert("write".into(), json!(write_s));
    let seconds = t0.elapsed().as_secs_f64();
    let command = std::env::args().collect::<Vec<_>>().join(" ");
    // Everything goes into a scratch folder beside DIR first; only when all
    // of it exists is it moved into DIR, so a failed run leaves nothing.
    let parent = out
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(std::path::Path::new("."));
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
    put("toolpath.gcode", gcode.as_bytes())?;
    put("plan.csv", csv.as_bytes())?;
    let mut files = vec![
        "toolpath.gcode".to_string(),
        "plan.csv".to_string(),
        "report.json".to_string(),
    ];
    if !a.no_plots {
        let t2 = Instant::now();
        let figs =
            maamplan::report::plots::write_figures(&machine, &p, &scratch.path().join("plots"))
                .map_err(|e| anyhow::anyhow!("drawing the plots: {e}"))?;
        put(
            "scene.glb",
            &maamplan::report::scene_glb::scene_glb(scene, &p, &machine),
        )?;
        let html = maamplan::report::html::report_html(
            &loaded.source,
            &command,
            &machine,
            &p,
            &figs,
            seconds,
        );
        put("report.html", html.as_bytes())?;
        stages.insert("report".into(), json!(t2.elapsed().as_secs_f64()));
        files.extend([
            "scene.glb".to_string(),
            "report.html".to_string(),
            "plots".to_string(),
        ]);
    }
    let report = json!({
        "source": loaded.source,
        "backend": backend.name(),
        "machine": machine,
        "input": p.input,
        "plan": p.plan,
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
    if a.quiet {
        return Ok(());
    }
    if a.verbose {
        for (k, v) in &stages {
            println!("stage {k:<14} {:>8.3} s", v.as_f64().unwrap_or(0.0));
        }
    }

    println!("{:<32} {:>12} {:>14}", "", "input", "plan");
    for (k, i, pl) in maamplan::report::summary_rows(&p.input, &p.plan) {
        println!("{k:<32} {i:>12} {pl:>14}");
    }
    println!(
        "{}: planned in {:.2} s, {:.2} s in all (backend {}); wrote {}/{}",
        loaded.source,
        seconds,
        t0.elapsed().as_secs_f64(),
        backend.name(),
        out.display(),
        files.join(", ")
    );
    Ok(())
}

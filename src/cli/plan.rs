//! `maamplan plan`: waypoints → machine axes, G-code, CSV and a report.

use super::{write_json, BackendKind, SceneArgs, UsageError};
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
    /// Largest move of any head point between two motion checks (mm).
    #[arg(long, default_value_t = 0.5)]
    edge_step: f64,
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
    let backend = a.backend.build(scene)?;
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
    };
    let pb = indicatif::ProgressBar::new_spinner();
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
    let report = json!({
        "source": loaded.source,
        "backend": backend.name(),
        "machine": machine,
        "input": p.input,
        "plan": p.plan,
        "seconds": seconds,
        "stages": stages,
        "command": std::env::args().collect::<Vec<_>>().join(" "),
    });
    std::fs::create_dir_all(&out).map_err(|e| {
        UsageError(format!(
            "{}: cannot create the output folder ({e})",
            out.display()
        ))
    })?;
    let write = |name: &str, bytes: &[u8]| -> Result<()> {
        let path = out.join(name);
        write_atomic(&path, bytes)
            .map_err(|e| UsageError(format!("{}: cannot write ({e})", path.display())).into())
    };
    write("toolpath.gcode", gcode.as_bytes())?;
    write("plan.csv", csv.as_bytes())?;
    write_json(&out.join("report.json"), &report)?;

    println!("{:<22} {:>12} {:>12}", "", "input", "plan");
    let rows: [(&str, String, String); 10] = [
        (
            "waypoints",
            p.input.waypoints.to_string(),
            p.plan.waypoints.to_string(),
        ),
        (
            "residual collisions",
            p.input.residual_collisions.to_string(),
            p.plan.residual_collisions.to_string(),
        ),
        (
            "colliding edges",
            p.input.colliding_edges.to_string(),
            p.plan.colliding_edges.to_string(),
        ),
        (
            "speed violations %",
            format!("{:.2}", p.input.speed_violation_pct),
            format!("{:.2}", p.plan.speed_violation_pct),
        ),
        (
            "J (deg)",
            format!("{:.0}", p.input.j_deg),
            format!("{:.0}", p.plan.j_deg),
        ),
        (
            "max step (deg)",
            format!("{:.1}", p.input.max_step_deg),
            format!("{:.1}", p.plan.max_step_deg),
        ),
        (
            "singular waypoints",
            p.input.singular_waypoints.to_string(),
            p.plan.singular_waypoints.to_string(),
        ),
        (
            "breaks",
            p.input.breaks.to_string(),
            p.plan.breaks.to_string(),
        ),
        (
            "axis limit violations",
            p.input.axis_limit_violations.to_string(),
            p.plan.axis_limit_violations.to_string(),
        ),
        (
            "orientation change",
            "0".into(),
            format!(
                "mean {:.1}°, max {:.1}°",
                p.plan.mean_deviation_deg, p.plan.max_deviation_deg
            ),
        ),
    ];
    for (k, i, pl) in rows {
        println!("{k:<22} {i:>12} {pl:>12}");
    }
    println!(
        "{}: planned in {:.2} s (backend {}); wrote {}/toolpath.gcode, plan.csv, report.json",
        loaded.source,
        seconds,
        backend.name(),
        out.display()
    );
    Ok(())
}

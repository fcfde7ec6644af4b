//! `maamplan isoplanar`: a curved layer surface → deposition-rate-optimal
//! iso-planar waypoints (paper 001) → a toolpath folder and a summary with
//! the v_e(θ) curve and θ*.

use super::{write_generated, UsageError};
use anyhow::{Context, Result};
use clap::Args;
use maamplan::generate::{isoplanar, IsoplanarOptions};
use maamplan::io::mesh::load_mesh;
use maamplan::kinematics::{load_machine, Machine};
use serde_json::json;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `isoplanar`.
#[derive(Args, Debug)]
pub struct IsoplanarArgs {
    /// Layer surface (OBJ/STL/glTF, mm): a manifold triangle mesh whose
    /// winding makes its normals point to the nozzle side.
    surface: PathBuf,
    /// Machine file (TOML) whose axis speeds bound the feed rate [default: the built-in machine].
    #[arg(long)]
    machine: Option<PathBuf>,
    /// Bead width (mm) [default: the machine's extrusion width].
    #[arg(long)]
    nozzle: Option<f64>,
    /// Layer thickness (mm) [default: the machine's default layer height].
    #[arg(long)]
    height: Option<f64>,
    /// Largest distance between the straight path and the surface between
    /// two waypoints (mm).
    #[arg(long, default_value_t = 0.05)]
    chord_error: f64,
    /// Longest forward step (mm).
    #[arg(long, default_value_t = 2.0)]
    max_step: f64,
    /// Step between the print directions tried, over [0°, 180°] (degrees).
    #[arg(long, default_value_t = 2.0)]
    theta_step: f64,
    /// Output folder: waypoint/0.txt, layer/0.obj, summary.json.
    #[arg(short, long)]
    out: Option<PathBuf>,
}

/// Run `isoplanar`.
pub fn run(a: IsoplanarArgs) -> Result<()> {
    let Some(out) = a.out.clone() else {
        return Err(UsageError("isoplanar needs -o DIR (the output folder)".into()).into());
    };
    let t0 = Instant::now();
    let machine = match &a.machine {
        Some(p) => load_machine(p)?,
        None => Machine::default(),
    };
    let mesh = load_mesh(&a.surface)?;
    let opts = IsoplanarOptions {
        nozzle: a.nozzle.unwrap_or(machine.extrusion.width),
        height: a.height.unwrap_or(machine.extrusion.default_height),
        chord_error: a.chord_error,
        max_step: a.max_step,
        theta_step_deg: a.theta_step,
        machine,
        ..IsoplanarOptions::default()
    };
    let r = isoplanar(&mesh, &opts).with_context(|| a.surface.display().to_string())?;
    let n = r.toolpath.waypoint_count();
    let summary = json!({
        "command": "isoplanar",
        "surface": a.surface.display().to_string(),
        "nozzle_mm": opts.nozzle,
        "height_mm": opts.height,
        "chord_error_mm": opts.chord_error,
        "theta_star_deg": r.theta_star_deg,
        "drive_plane_normal": r.drive_plane_normal(),
        "curve": r.curve,
        "curves": r.side_steps.len() + 1,
        "side_steps_mm": r.side_steps,
        "waypoints": n,
        "print_mm": r.print_length,
        "travel_mm": r.travel_length,
        "seconds": t0.elapsed().as_secs_f64(),
    });
    write_generated(&out, &r.toolpath, &summary)?;
    println!(
        "θ* = {:.1}°, {} curves, {} waypoints, print {:.1} mm, travel {:.1} mm → {}",
        r.theta_star_deg,
        r.side_steps.len() + 1,
        n,
        r.print_length,
        r.travel_length,
        out.display()
    );
    Ok(())
}

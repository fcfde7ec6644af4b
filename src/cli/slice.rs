//! `maamplan slice`: a closed mesh → planar layers along a direction, each
//! filled with a zig-zag, one-way or MZZ raster → a toolpath folder and a
//! summary with per-layer printing and travel length.

use super::{parse_xyz, write_generated, UsageError};
use anyhow::{Context, Result};
use clap::{Args, ValueEnum};
use maamplan::generate::{slice, Fill, SliceOptions};
use maamplan::io::mesh::load_mesh;
use serde_json::json;
use std::path::PathBuf;
use std::time::Instant;

/// Rasters on the command line.
#[derive(ValueEnum, Clone, Copy, Debug)]
pub enum FillKind {
    /// Alternating rows.
    Zigzag,
    /// Every row the same way.
    Oneway,
    /// Each row continues with the nearest unprinted row; the shortest of
    /// all starts is kept (never longer than zig-zag).
    Mzz,
}

/// Arguments of `slice`.
#[derive(Args, Debug)]
pub struct SliceArgs {
    /// Closed, outward-facing mesh (OBJ/STL/glTF), mm.
    mesh: PathBuf,
    /// Slicing direction X,Y,Z (layers stack along it; the nozzle points along it).
    #[arg(long, value_parser = parse_xyz, allow_hyphen_values = true, default_value = "0,0,1")]
    dir: [f32; 3],
    /// Layer thickness (mm).
    #[arg(long, default_value_t = 0.5)]
    layer: f64,
    /// Raster fill.
    #[arg(long, value_enum, default_value_t = FillKind::Mzz)]
    fill: FillKind,
    /// Grid spacing (mm).
    #[arg(long, default_value_t = 0.5)]
    spacing: f64,
    /// Output folder: waypoint/<k>.txt, layer/<k>.obj, summary.json.
    #[arg(short, long)]
    out: Option<PathBuf>,
}

/// Run `slice`.
pub fn run(a: SliceArgs) -> Result<()> {
    let Some(out) = a.out.clone() else {
        return Err(UsageError("slice needs -o DIR (the output folder)".into()).into());
    };
    let t0 = Instant::now();
    let mesh = load_mesh(&a.mesh)?;
    let opts = SliceOptions {
        dir: a.dir.map(|x| x as f64),
        layer: a.layer,
        spacing: a.spacing,
        fill: match a.fill {
            FillKind::Zigzag => Fill::Zigzag,
            FillKind::Oneway => Fill::Oneway,
            FillKind::Mzz => Fill::Mzz,
        },
    };
    let r = slice(&mesh, &opts).with_context(|| a.mesh.display().to_string())?;
    let total = r.lengths();
    let waypoints = r.toolpath.waypoint_count();
    let summary = json!({
        "command": "slice",
        "mesh": a.mesh.display().to_string(),
        "dir": r.dir,
        "layer_mm": a.layer,
        "spacing_mm": a.spacing,
        "fill": opts.fill.name(),
        "layers": r.layers.iter().map(|l| json!({
            "name": l.name,
            "offset_mm": l.offset,
            "waypoints": l.waypoints,
            "runs": l.runs,
            "print_mm": l.print_length,
            "travel_mm": l.travel_length,
            "entry_mm": l.entry_length,
        })).collect::<Vec<_>>(),
        "total": {
            "layers": r.layers.len(),
            "waypoints": waypoints,
            "print_mm": total.print,
            "travel_mm": total.travel,
            "path_mm": total.total(),
            "between_layers_mm": r.layers.iter().map(|l| l.entry_length).sum::<f64>(),
        },
        "seconds": t0.elapsed().as_secs_f64(),
    });
    write_generated(&out, &r.toolpath, &summary)?;
    println!(
        "{} layers, {} waypoints, print {:.1} mm, travel {:.1} mm ({}) → {}",
        r.layers.len(),
        waypoints,
        total.print,
        total.travel,
        opts.fill.name(),
        out.display()
    );
    Ok(())
}

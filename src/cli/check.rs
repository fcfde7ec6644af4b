//! `maamplan check`: every waypoint in its own orientation, one verdict each,
//! counted per layer.

use super::{evaluate_with_progress, progress, write_json, BackendKind, SceneArgs, UsageError};
use anyhow::Result;
use clap::Args;
use maamplan::geometry::Pose;
use maamplan::io::plan_csv::read_plan_axes;
use maamplan::kinematics::{forward, head_pose, load_machine, Axes, Machine};
use maamplan::scene::Query;
use serde_json::json;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `check`.
#[derive(Args, Debug)]
pub struct CheckArgs {
    #[command(flatten)]
    scene: SceneArgs,
    /// Collision evaluator.
    #[arg(long, value_enum, default_value_t = BackendKind::Auto)]
    backend: BackendKind,
    /// Also write the results as JSON to this file.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Stress test: rotate every nozzle direction by DEG about the x axis
    /// before checking (as `shared/tools/fcl_check.py --tilt`).
    #[arg(
        long,
        value_name = "DEG",
        allow_hyphen_values = true,
        conflicts_with = "plan"
    )]
    tilt: Option<f32>,
    /// Check a written plan instead: the head poses that `plan.csv`'s machine
    /// axes give (forward kinematics of `--machine`), one row per waypoint.
    #[arg(long, value_name = "PLAN_CSV")]
    plan: Option<PathBuf>,
    /// Print only errors.
    #[arg(short, long)]
    quiet: bool,
    /// Print scene details too.
    #[arg(short, long, conflicts_with = "quiet")]
    verbose: bool,
    /// Machine file for `--plan` [default: the default machine].
    #[arg(long, requires = "plan")]
    machine: Option<PathBuf>,
}

/// Run `check`.
pub fn run(a: CheckArgs) -> Result<()> {
    let loaded = a.scene.load()?;
    let scene = &loaded.scene;
    let backend = a.backend.build(scene, !a.quiet)?;
    let tilted: Vec<Query>;
    let queries = match (a.tilt, &a.plan) {
        (_, Some(csv)) => {
            let machine = match &a.machine {
                Some(p) => load_machine(p)?,
                None => Machine::default(),
            };
            let rows = read_plan_axes(csv)?;
            if rows.len() != scene.waypoint_queries.len() {
                return Err(UsageError(format!(
                    "{}: {} rows but the toolpath has {} waypoints: check the plan of this toolpath",
                    csv.display(),
                    rows.len(),
                    scene.waypoint_queries.len()
                ))
                .into());
            }
            tilted = rows
                .iter()
                .zip(&scene.waypoint_queries)
                .map(|(r, q)| {
                    let axes = Axes {
                        xyz: [r[0], r[1], r[2]],
                        tilt: r[3].to_radians(),
                        c: r[4].to_radians(),
                    };
                    let (p, _) = forward(&machine, &axes);
                    Query {
                        pose: head_pose(machine.rotary, p, axes.tilt, axes.c),
                        cutoff: q.cutoff,
                        margin: q.margin,
                    }
                })
                .collect();
            &tilted
        }
        (None, None) => &scene.waypoint_queries,
        (Some(deg), None) => {
            let (s, c) = deg.to_radians().sin_cos();
            tilted = scene
                .waypoint_queries
                .iter()
                .map(|q| {
                    let n = q.pose.axis();
                    let r = [n[0], c * n[1] - s * n[2], s * n[1] + c * n[2]];
                    Query {
                        pose: Pose::from_axis(q.pose.tip, r),
                        cutoff: q.cutoff,
                        margin: q.margin,
                    }
                })
                .collect();
            &tilted
        }
    };
    let t0 = Instant::now();
    let pb = progress(queries.len() as u64, "checking");
    let verdicts = evaluate_with_progress(backend.as_ref(), queries, &pb)?;
    let seconds = t0.elapsed().as_secs_f64();

    let layers = &loaded.toolpath.layers;
    let mut per_layer = vec![(0usize, 0usize); layers.len()];
    for (i, &hit) in verdicts.iter().enumerate() {
        let l = scene.waypoint_layers[i] as usize;
        per_layer[l].0 += 1;
        per_layer[l].1 += hit as usize;
    }
    let colliding: usize = per_layer.iter().map(|p| p.1).sum();

    if let Some(path) = &a.json {
        write_report(
            path,
            &loaded,
            backend.name(),
            seconds,
            &verdicts,
            &per_layer,
        )?;
    }
    if a.quiet {
        return Ok(());
    }
    if a.verbose {
        println!(
            "scene: {} triangles ({} BVH nodes), head {} triangles, grid {:?} cells of {:.3} mm, tolerance {:.1e} mm",
            scene.triangle_count(),
            scene.part_nodes.len(),
            scene.head.triangles.len(),
            scene.head.params.grid_dims,
            scene.head.params.cell,
            scene.tol
        );
    }
    println!("{:>8} {:>10} {:>10}", "layer", "waypoints", "colliding");
    for (l, (n, c)) in layers.iter().zip(&per_layer) {
        println!("{:>8} {:>10} {:>10}", l.name, n, c);
    }
    println!(
        "{}: {} of {} waypoints collide ({:.2} %) — backend {}, {:.3} s ({:.0} poses/s), scene {} triangles built in {:.2} s",
        loaded.source,
        colliding,
        verdicts.len(),
        100.0 * colliding as f64 / verdicts.len().max(1) as f64,
        backend.name(),
        seconds,
        verdicts.len() as f64 / seconds.max(1e-9),
        scene.triangle_count(),
        loaded.seconds,
    );
    Ok(())
}

/// The `--json` document.
fn write_report(
    path: &std::path::Path,
    loaded: &super::Loaded,
    backend: &str,
    seconds: f64,
    verdicts: &[bool],
    per_layer: &[(usize, usize)],
) -> Result<()> {
    let layers = &loaded.toolpath.layers;
    let colliding: usize = per_layer.iter().map(|p| p.1).sum();
    let v = json!({
        "source": loaded.source,
        "waypoints": verdicts.len(),
        "colliding": colliding,
        "backend": backend,
        "seconds": seconds,
        "layers": layers.iter().zip(per_layer).enumerate().map(|(i, (l, (n, c)))| json!({
            "index": i, "name": l.name, "waypoints": n, "colliding": c,
        })).collect::<Vec<_>>(),
        "colliding_waypoints": verdicts.iter().enumerate().filter(|(_, &h)| h).map(|(i, _)| i).collect::<Vec<_>>(),
    });
    write_json(path, &v)
}

//! `maamplan check`: every waypoint's head pose — as the machine poses it,
//! the same pose `plan` starts from — or a written plan's poses and
//! printing moves, one verdict each, counted per layer.

use super::{machine_and_margin, progress, write_json, BackendKind, SceneArgs, UsageError};
use anyhow::Result;
use clap::Args;
use maamplan::io::plan_csv::read_plan;
use maamplan::job::LoadedJob;
use maamplan::kinematics::{Axes, Machine};
use maamplan::plan::layer_reading::NearestLayer;
use maamplan::plan::{head_reach, input_axes, runs, PlanOptions};
use maamplan::prove::Prover;
use maamplan::scene::cutoff;
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
    /// Print only errors.
    #[arg(short, long)]
    quiet: bool,
    /// Print scene details too.
    #[arg(short, long, conflicts_with = "quiet")]
    verbose: bool,
}

/// What was checked: per waypoint, its pose's verdict (`None`: skipped),
/// and the moves into it (`None`: none checked).
struct Verdicts {
    poses: Vec<Option<bool>>,
    moves: Vec<Option<bool>>,
}

/// Run `check`.
pub fn run(a: CheckArgs) -> Result<()> {
    let (machine, margin) = machine_and_margin(a.machine.as_deref(), a.margin)?;
    let opening = a.backend.open();
    let job = a.scene.load()?;
    let scene = &job.scene;
    let backend = a
        .backend
        .build_with(opening, scene, !a.quiet, Default::default())?;
    let prover = Prover::new(
        &machine,
        backend.as_ref(),
        head_reach(scene),
        margin,
        PlanOptions::default().edge_step,
    );
    let n = job.toolpath.waypoint_count();
    let t0 = Instant::now();
    let pb = progress(n as u64, "checking");
    let v = match &a.plan {
        Some(csv) => check_plan(&job, &machine, &prover, csv)?,
        None => {
            let pos: Vec<[f64; 3]> = job
                .toolpath
                .iter()
                .map(|(_, w)| w.pos.map(|x| x as f64))
                .collect();
            let dirs: Vec<[f64; 3]> = job
                .toolpath
                .iter()
                .map(|(_, w)| w.dir.map(|x| x as f64))
                .collect();
            let axes = input_axes(
                &machine,
                &pos,
                &dirs,
                &runs(&job.toolpath, PlanOptions::default().jump),
            );
            let items: Vec<(Axes, u32)> = axes
                .iter()
                .enumerate()
                .map(|(g, a)| (*a, cutoff(g)))
                .collect();
            let hits = prover.poses_at(&items, margin)?;
            Verdicts {
                poses: hits.into_iter().map(Some).collect(),
                moves: vec![None; n],
            }
        }
    };
    pb.finish_and_clear();
    let seconds = t0.elapsed().as_secs_f64();

    let layers = &job.toolpath.layers;
    // Per layer: waypoints, colliding poses, colliding moves.
    let mut per_layer = vec![(0usize, 0usize, 0usize); layers.len()];
    for (i, (p, m)) in v.poses.iter().zip(&v.moves).enumerate() {
        let l = scene.waypoint_layers[i] as usize;
        per_layer[l].0 += 1;
        per_layer[l].1 += (*p == Some(true)) as usize;
        per_layer[l].2 += (*m == Some(true)) as usize;
    }
    let colliding: usize = per_layer.iter().map(|p| p.1).sum();
    let colliding_moves: usize = per_layer.iter().map(|p| p.2).sum();
    let moves_checked = v.moves.iter().filter(|m| m.is_some()).count();

    if let Some(path) = &a.json {
        let doc = json!({
            "source": job.source,
            "waypoints": n,
            "colliding": colliding,
            "moves": moves_checked,
            "colliding_moves": colliding_moves,
            "margin": margin,
            "backend": backend.name(),
            "seconds": seconds,
            "flipped_layers": job.flipped_names(),
            "layers": layers.iter().zip(&per_layer).enumerate().map(|(i, (l, (w, c, cm)))| json!({
                "index": i, "name": l.name, "waypoints": w, "colliding": c, "colliding_moves": cm,
            })).collect::<Vec<_>>(),
            "colliding_waypoints": v.poses.iter().enumerate().filter(|(_, h)| **h == Some(true)).map(|(i, _)| i).collect::<Vec<_>>(),
            "colliding_moves_into": v.moves.iter().enumerate().filter(|(_, h)| **h == Some(true)).map(|(i, _)| i).collect::<Vec<_>>(),
        });
        write_json(path, &doc)?;
    }
    if a.quiet {
        return Ok(());
    }
    if a.verbose {
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
    if !job.flipped_layers.is_empty() {
        println!(
            "reversed the nozzle directions of {} layer(s) that mostly pointed down: {}",
            job.flipped_layers.len(),
            job.flipped_names().join(", ")
        );
    }
    let with_moves = a.plan.is_some();
    if with_moves {
        println!(
            "{:>8} {:>10} {:>10} {:>10}",
            "layer", "waypoints", "colliding", "moves"
        );
    } else {
        println!("{:>8} {:>10} {:>10}", "layer", "waypoints", "colliding");
    }
    for (l, (w, c, cm)) in layers.iter().zip(&per_layer) {
        if with_moves {
            println!("{:>8} {:>10} {:>10} {:>10}", l.name, w, c, cm);
        } else {
            println!("{:>8} {:>10} {:>10}", l.name, w, c);
        }
    }
    let moves_note = if with_moves {
        format!(", {colliding_moves} of {moves_checked} printing moves")
    } else {
        String::new()
    };
    println!(
        "{}: {} of {} waypoints come within {} mm ({:.2} %){moves_note} — backend {}, {:.3} s, scene {} triangles built in {:.2} s",
        job.source,
        colliding,
        n,
        margin,
        100.0 * colliding as f64 / n.max(1) as f64,
        backend.name(),
        seconds,
        scene.triangle_count(),
        job.seconds,
    );
    Ok(())
}

/// The poses of a written plan's rows and the printing moves between
/// consecutive visited rows (split for the tip tolerance exactly as `plan`
/// writes them).
fn check_plan(job: &LoadedJob, m: &Machine, prover: &Prover, csv: &std::path::Path) -> Result<Verdicts> {
    let rows = read_plan(csv)?;
    let n = job.toolpath.waypoint_count();
    if rows.len() != n {
        return Err(UsageError(format!(
            "{}: {} rows but the toolpath has {} waypoints: check the plan of this toolpath",
            csv.display(),
            rows.len(),
            n
        ))
        .into());
    }
    let axes: Vec<Option<Axes>> = rows
        .iter()
        .map(|r| {
            r.axes.map(|v| Axes {
                xyz: [v[0], v[1], v[2]],
                tilt: v[3].to_radians(),
                c: v[4].to_radians(),
            })
        })
        .collect();
    let items: Vec<(usize, Axes)> = axes
        .iter()
        .enumerate()
        .filter_map(|(g, a)| a.map(|a| (g, a)))
        .collect();
    let pose_hits = prover.poses_at(
        &items
            .iter()
            .map(|(g, a)| (*a, cutoff(*g)))
            .collect::<Vec<_>>(),
        prover.margin,
    )?;
    let mut poses = vec![None; n];
    for ((g, _), h) in items.iter().zip(pose_hits) {
        poses[*g] = Some(h);
    }
    let reader = NearestLayer::of(&job.toolpath);
    let mut specs = Vec::new();
    let mut owner = Vec::new();
    for g in 1..n {
        let (Some(a), Some(b)) = (axes[g - 1], axes[g]) else {
            continue;
        };
        if rows[g].travel_before {
            continue;
        }
        let layer = job.scene.waypoint_layers[g] as usize;
        for mv in reader.bead_moves(m, &a, &b, m.tip_tolerance, layer, g as u32) {
            specs.push(mv);
            owner.push(g);
        }
    }
    let hits = prover.moves(&specs)?;
    let mut moves = vec![None; n];
    for (&g, h) in owner.iter().zip(hits) {
        let e = moves[g].get_or_insert(false);
        *e |= h;
    }
    Ok(Verdicts { poses, moves })
}

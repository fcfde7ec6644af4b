//! `maamplan bench`: poses per second of several backends on the same
//! queries, in one run, with their colliding counts side by side.

use super::{
    evaluate_with_progress, progress, write_json, BackendKind, Opening, SceneArgs, UsageError,
};
use anyhow::Result;
use clap::Args;
use maamplan::collide::gpu::GpuOptions;
use maamplan::collide::sample::tilted_queries;
use maamplan::kinematics::Machine;
use maamplan::scene::{Query, Scene};
use serde_json::json;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `bench`.
#[derive(Args, Debug)]
pub struct BenchArgs {
    #[command(flatten)]
    scene: SceneArgs,
    /// Backends to compare, in order.
    #[arg(long, value_enum, value_delimiter = ',', default_values_t = [BackendKind::Cpu, BackendKind::Parry])]
    backends: Vec<BackendKind>,
    /// Number of poses (waypoints evenly strided, each with tilted variants).
    #[arg(long, default_value_t = 20_000)]
    queries: usize,
    /// Tilted variants per chosen waypoint (15°, 30°, 45°, 60°, ...).
    #[arg(long, default_value_t = 3)]
    tilts: usize,
    /// Safety margin of every query (mm): closer than this collides.
    #[arg(long, default_value_t = 0.0)]
    margin: f32,
    /// Also write the results as JSON to this file.
    #[arg(long)]
    json: Option<PathBuf>,
    /// Tuning, gpu backend: queries per batch [default: the adapter's, see
    /// ARCHITECTURE.md].
    #[arg(long, value_name = "QUERIES")]
    gpu_batch: Option<usize>,
    /// Tuning, gpu backend: the walk kernel [default: persistent where the
    /// adapter has subgroups].
    #[arg(long, value_enum)]
    gpu_walk: Option<GpuWalk>,
    /// Tuning, gpu backend with persistent lanes: how the walk reserves
    /// candidate slots [default: subgroup on hardware adapters].
    #[arg(long, value_enum)]
    gpu_appends: Option<GpuAppends>,
    /// Tuning, gpu backend: the most (query, triangle) pairs one query
    /// hands to the exact tests a pass [default: 16]; a query with more
    /// undecided pairs walks again.
    #[arg(long, value_name = "PAIRS")]
    gpu_share: Option<u32>,
    /// Tuning, gpu backend: walk each call's queries in coherent order
    /// (nozzle axis, then tip position) or as given [default: on software
    /// adapters only].
    #[arg(long, value_name = "ON|OFF", value_parser = clap::builder::BoolishValueParser::new())]
    gpu_order: Option<bool>,
}

/// How the persistent walk reserves candidate slots (`--gpu-appends`).
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
enum GpuAppends {
    /// One atomic per append (`shaders/shared/append_atomic.wgsl`).
    Atomic,
    /// One atomic per subgroup (`shaders/shared/append_subgroup.wgsl`).
    Subgroup,
}

/// The gpu backend's walk kernels (`--gpu-walk`).
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
enum GpuWalk {
    /// One query an invocation (`shaders/traverse_lane.wgsl`).
    Lane,
    /// Persistent lanes taking the batch's next query
    /// (`shaders/traverse_persistent.wgsl`; needs subgroups).
    Persistent,
}

impl BenchArgs {
    /// The gpu backend's tuning from the flags.
    fn gpu_options(&self) -> GpuOptions {
        GpuOptions {
            batch: self.gpu_batch,
            subgroups: self.gpu_walk.map(|w| w == GpuWalk::Persistent),
            subgroup_appends: self.gpu_appends.map(|w| w == GpuAppends::Subgroup),
            per_query: self.gpu_share,
            coherent: self.gpu_order,
            ..GpuOptions::default()
        }
    }
}

/// Run `bench`.
pub fn run(a: BenchArgs) -> Result<()> {
    if a.backends.is_empty() {
        return Err(UsageError("--backends needs at least one backend".into()).into());
    }
    let loaded = a.scene.load(&Machine::default())?;
    let scene = &loaded.scene;
    if !(a.margin.is_finite() && a.margin >= 0.0) {
        return Err(
            UsageError("--margin must be a finite, non-negative length (mm)".into()).into(),
        );
    }
    let mut queries = tilted_queries(&scene.waypoint_queries, a.queries, a.tilts);
    for q in &mut queries {
        q.margin = a.margin;
    }
    println!(
        "{}: {} queries ({} waypoints sampled, {} tilts each, margin {} mm), {} triangles, {} threads",
        loaded.source,
        queries.len(),
        queries.len() / (a.tilts + 1),
        a.tilts,
        a.margin,
        scene.triangle_count(),
        rayon::current_num_threads(),
    );
    let first = a.backends[0].name();
    let mut results: Vec<Measured> = Vec::new();
    for kind in &a.backends {
        let reference = results.first().map(|r| r.verdicts.as_slice());
        let measured = measure(*kind, scene, &queries, a.gpu_options(), reference)?;
        measured.print(first);
        results.push(measured);
    }
    for r in results.iter().skip(1) {
        println!(
            "{} / {}: {:.1}×",
            first,
            r.backend,
            results[0].poses_per_second / r.poses_per_second
        );
    }
    if let Some(path) = &a.json {
        write_json(
            path,
            &json!({
                "source": loaded.source,
                "queries": queries.len(),
                "margin_mm": a.margin,
                "threads": rayon::current_num_threads(),
                "results": results.iter().map(Measured::to_json).collect::<Vec<_>>(),
            }),
        )?;
    }
    Ok(())
}

/// One backend's throughput on the bench's queries.
struct Measured {
    backend: String,
    poses_per_second: f64,
    /// The median run's seconds.
    seconds: f64,
    setup_seconds: f64,
    runs: usize,
    colliding: usize,
    /// The queries whose verdict differs from the first backend's (`None`
    /// for the first).
    differing: Option<Vec<usize>>,
    summary: Option<String>,
    verdicts: Vec<bool>,
}

/// Build backend `kind` over `scene` and time it on `queries`: short runs
/// repeated (at least 2 s or 5 runs), the median kept; its verdicts
/// compared with `reference` (the first backend's).
fn measure(
    kind: BackendKind,
    scene: &Scene,
    queries: &[Query],
    gpu: GpuOptions,
    reference: Option<&[bool]>,
) -> Result<Measured> {
    let t0 = Instant::now();
    let backend = kind.build_with(Opening::none(), scene, true, gpu)?;
    let setup_seconds = t0.elapsed().as_secs_f64();
    let mut times = Vec::new();
    let mut verdicts = Vec::new();
    while times.len() < 5 && times.iter().sum::<f64>() < 2.0 {
        let pb = progress(queries.len() as u64, backend.name());
        let t1 = Instant::now();
        verdicts = evaluate_with_progress(backend.as_ref(), queries, &pb)?;
        times.push(t1.elapsed().as_secs_f64());
    }
    times.sort_by(f64::total_cmp);
    let seconds = times[times.len() / 2];
    let differing = reference.map(|r| {
        r.iter()
            .zip(&verdicts)
            .enumerate()
            .filter(|(_, (a, b))| a != b)
            .map(|(i, _)| i)
            .collect()
    });
    Ok(Measured {
        backend: backend.name().to_string(),
        poses_per_second: queries.len() as f64 / seconds.max(1e-9),
        seconds,
        setup_seconds,
        runs: times.len(),
        colliding: verdicts.iter().filter(|&&c| c).count(),
        differing,
        summary: backend.summary(),
        verdicts,
    })
}

impl Measured {
    /// Its line (and the backend's summary) on stdout.
    fn print(&self, first: &str) {
        println!(
            "{:>8}: {:>12.0} poses/s  {:>8.3} s (median of {})  colliding {:>7}  setup {:.3} s{}",
            self.backend,
            self.poses_per_second,
            self.seconds,
            self.runs,
            self.colliding,
            self.setup_seconds,
            self.differing.as_ref().map_or(String::new(), |d| format!(
                "  disagreements vs {first}: {}",
                d.len()
            )),
        );
        if let Some(line) = &self.summary {
            println!("          {line}");
        }
    }

    /// Its entry of `--json`'s results.
    fn to_json(&self) -> serde_json::Value {
        json!({
            "backend": self.backend,
            "poses_per_second": self.poses_per_second,
            "seconds": self.seconds,
            "setup_seconds": self.setup_seconds,
            "runs": self.runs,
            "colliding": self.colliding,
            "disagreements_with_first": self.differing.as_ref().map(|d| d.len()),
            "disagreeing_queries": self.differing.as_ref().map(|d| d.iter().take(100).collect::<Vec<_>>()),
            "summary": self.summary,
        })
    }
}

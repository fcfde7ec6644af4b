//! The command line: clap definitions and the wiring of library stages.
//! Only this module (and `main.rs`) uses `anyhow`.

mod bench;
mod check;
mod info;
mod isoplanar;
mod plan;
mod slice;

use anyhow::{Context, Result};
use clap::{Args, Parser, Subcommand, ValueEnum};
use maamplan::collide::cpu::CpuBackend;
use maamplan::collide::gpu::{GpuBackend, GpuContext, GpuOptions};
use maamplan::collide::parry::ParryBackend;
use maamplan::collide::Backend;
use maamplan::default_job;
use maamplan::geometry::{Aabb, Mesh};
use maamplan::io::mesh::load_mesh;
use maamplan::io::toolpath::load_toolpath;
use maamplan::io::Placement;
use maamplan::scene::{HeadConfig, Scene, SceneConfig};
use maamplan::toolpath::Toolpath;
use std::path::PathBuf;
use std::time::Instant;

/// Collision-free, singularity-aware motion planning for multi-axis 3D printing.
#[derive(Parser, Debug)]
#[command(name = "maamplan", version, about)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Check every waypoint's own head pose for collisions.
    Check(check::CheckArgs),
    /// Measure poses per second of several backends on the same queries.
    Bench(bench::BenchArgs),
    /// Plan machine motion: collision-free, singularity-aware, within the tip-speed range.
    Plan(plan::PlanArgs),
    /// List GPU adapters, their kind (hardware / software) and limits.
    Info,
    /// Slice a closed mesh into planar layers along a direction and fill them (zig-zag, one-way, MZZ).
    Slice(slice::SliceArgs),
    /// Deposition-rate-optimal iso-planar paths on a curved layer surface.
    Isoplanar(isoplanar::IsoplanarArgs),
}

/// Inputs shared by every command.
#[derive(Args, Debug, Clone)]
pub struct SceneArgs {
    /// Toolpath folder (waypoint/<k>.txt, layer/<k>.obj) or a waypoint
    /// file; omitted: the embedded default job.
    toolpath: Option<PathBuf>,
    /// Print head mesh (OBJ/STL/glTF), tip at the origin, axis +z
    /// [default: a 45° cone, 20 mm radius, 30 mm tall].
    #[arg(long)]
    head: Option<PathBuf>,
    /// Platform mesh (part frame) [default: a flat plate under the part].
    #[arg(long)]
    platform: Option<PathBuf>,
    /// Translate the toolpath and layers by X,Y,Z mm (after --y-up).
    #[arg(long, value_parser = parse_xyz, allow_hyphen_values = true)]
    place: Option<[f32; 3]>,
    /// The toolpath is Y-up: rotate it to Z-up first.
    #[arg(long)]
    y_up: bool,
    /// Contact within this distance of the nozzle tip is ignored (mm).
    #[arg(long, default_value_t = 0.3)]
    clearance: f32,
}

/// Backends selectable on the command line.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum BackendKind {
    /// A hardware GPU when present, the CPU otherwise.
    Auto,
    /// wgpu compute shaders on the best adapter (software ones included).
    Gpu,
    /// Exact BVH + distance-grid evaluator on all CPU cores.
    Cpu,
    /// The same semantics from parry3d's primitives (the reference).
    Parry,
}

impl BackendKind {
    /// The name used on the command line.
    pub fn name(self) -> &'static str {
        match self {
            BackendKind::Auto => "auto",
            BackendKind::Gpu => "gpu",
            BackendKind::Cpu => "cpu",
            BackendKind::Parry => "parry",
        }
    }

    /// Build the backend over `scene`; `announce` says on stderr what `auto` chose.
    pub fn build<'a>(self, scene: &'a Scene, announce: bool) -> Result<Box<dyn Backend + 'a>> {
        Ok(match self {
            BackendKind::Auto => match GpuContext::open(true) {
                Ok(Some(ctx)) => {
                    let name = format!("{} ({})", ctx.summary.name, ctx.summary.backend);
                    let b = GpuBackend::new(ctx, scene, GpuOptions::default())?;
                    if announce {
                        eprintln!("backend auto: gpu on {name}");
                    }
                    Box::new(b)
                }
                Ok(None) => {
                    if announce {
                        eprintln!(
                            "backend auto: no hardware GPU, using cpu ({} threads)",
                            rayon::current_num_threads()
                        );
                    }
                    Box::new(CpuBackend::new(scene))
                }
                Err(e) => {
                    eprintln!("backend auto: {e}; using cpu");
                    Box::new(CpuBackend::new(scene))
                }
            },
            BackendKind::Gpu => {
                let ctx = GpuContext::open(false)?.ok_or_else(|| {
                    UsageError(
                        "--backend gpu: no GPU adapter found: install a Vulkan driver (on Debian/Ubuntu, mesa-vulkan-drivers gives the lavapipe software adapter) or use --backend cpu".into(),
                    )
                })?;
                Box::new(GpuBackend::new(ctx, scene, GpuOptions::default())?)
            }
            BackendKind::Cpu => Box::new(CpuBackend::new(scene)),
            BackendKind::Parry => Box::new(ParryBackend::new(scene)?),
        })
    }
}

pub(crate) fn parse_xyz(s: &str) -> Result<[f32; 3], String> {
    let v: Vec<f32> = s
        .split(',')
        .map(|x| x.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("'{s}' is not X,Y,Z (three numbers separated by commas)"))?;
    match v[..] {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok([x, y, z]),
        _ => Err(format!(
            "'{s}' is not X,Y,Z (three finite numbers separated by commas)"
        )),
    }
}

/// A loaded job and its built scene.
pub struct Loaded {
    /// What the user named (for messages).
    pub source: String,
    /// The toolpath.
    pub toolpath: Toolpath,
    /// The scene.
    pub scene: Scene,
    /// Seconds spent loading and building.
    pub seconds: f64,
}

impl SceneArgs {
    /// Load inputs (or the embedded default) and build the scene.
    pub fn load(&self) -> Result<Loaded> {
        let t0 = Instant::now();
        if !(self.clearance >= 0.0 && self.clearance.is_finite()) {
            return Err(UsageError("--clearance must be a finite number ≥ 0 (mm)".into()).into());
        }
        let place = Placement {
            y_up: self.y_up,
            offset: self.place.unwrap_or([0.0; 3]),
        };
        let (source, toolpath, default_head, default_platform) = match &self.toolpath {
            Some(p) => {
                let tp = load_toolpath(p, &place)?;
                (p.display().to_string(), tp, None, None)
            }
            None => {
                let job = default_job::job();
                let tp = Toolpath {
                    layers: job
                        .toolpath
                        .layers
                        .into_iter()
                        .map(|mut l| {
                            for w in &mut l.waypoints {
                                w.pos = place.point(w.pos);
                                w.dir = place.direction(w.dir);
                            }
                            l.surface = l.surface.map(|s| s.map_vertices(|v| place.point(v)));
                            l
                        })
                        .collect(),
                };
                (
                    "embedded default".to_string(),
                    tp,
                    Some(job.head),
                    Some(job.platform),
                )
            }
        };
        let head = match &self.head {
            Some(p) => load_mesh(p)?,
            None => default_head.unwrap_or_else(|| default_job::cone_head(20.0, 20.0, 30.0, 64)),
        };
        let platform = match &self.platform {
            Some(p) => load_mesh(p)?,
            None => default_platform.unwrap_or_else(|| plate_under(&toolpath)),
        };
        let cfg = SceneConfig {
            head: HeadConfig {
                tip_clearance: self.clearance,
                ..HeadConfig::default()
            },
            max_edge: None,
        };
        let scene = Scene::build(&toolpath, &head, &platform, &cfg).with_context(|| {
            format!(
                "building the scene (head {})",
                self.head
                    .as_ref()
                    .map_or("default".into(), |p| p.display().to_string())
            )
        })?;
        Ok(Loaded {
            source,
            toolpath,
            scene,
            seconds: t0.elapsed().as_secs_f64(),
        })
    }
}

/// A flat plate whose top is at the toolpath's lowest point, 100 mm wider
/// than the part on every side.
fn plate_under(tp: &Toolpath) -> Mesh {
    let pts: Vec<[f32; 3]> = tp.iter().map(|(_, w)| w.pos).collect();
    let b = Aabb::from_points(&pts);
    default_job::box_mesh(
        [b.min[0] - 100.0, b.min[1] - 100.0, b.min[2] - 5.0],
        [b.max[0] + 100.0, b.max[1] + 100.0, b.min[2]],
    )
}

/// A command-line misuse (exit code 2).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct UsageError(pub String);

/// Run the parsed command line.
pub fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Check(a) => check::run(a),
        Command::Bench(a) => bench::run(a),
        Command::Plan(a) => plan::run(a),
        Command::Info => info::run(),
        Command::Slice(a) => slice::run(a),
        Command::Isoplanar(a) => isoplanar::run(a),
    }
}

/// A progress bar on stderr, drawn only on a terminal.
pub fn progress(len: u64, what: &str) -> indicatif::ProgressBar {
    let pb = indicatif::ProgressBar::new(len);
    pb.set_style(
        indicatif::ProgressStyle::with_template(
            "{msg:>10} [{bar:40}] {pos}/{len} ({per_sec}, eta {eta})",
        )
        .expect("static template")
        .progress_chars("=> "),
    );
    pb.set_message(what.to_string());
    pb
}

/// Evaluate in chunks so the progress bar moves.
pub fn evaluate_with_progress(
    backend: &dyn Backend,
    queries: &[maamplan::scene::Query],
    pb: &indicatif::ProgressBar,
) -> Result<Vec<bool>> {
    let mut out = Vec::with_capacity(queries.len());
    for chunk in queries.chunks(16384) {
        out.extend(backend.evaluate(chunk)?);
        pb.inc(chunk.len() as u64);
    }
    pb.finish_and_clear();
    Ok(out)
}

/// `value` as pretty JSON bytes with a final newline.
pub fn json_bytes(value: &serde_json::Value) -> Result<Vec<u8>> {
    let mut text = serde_json::to_string_pretty(value)?;
    text.push('\n');
    Ok(text.into_bytes())
}

/// Serialise `value` as pretty JSON to `path`, atomically.
pub fn write_json(path: &std::path::Path, value: &serde_json::Value) -> Result<()> {
    let mut text = serde_json::to_string_pretty(value)?;
    text.push('\n');
    maamplan::io::output::write_atomic(path, text.as_bytes()).map_err(|e| {
        UsageError(format!(
            "{}: cannot write ({e}): check the folder exists and is writable",
            path.display()
        ))
    })?;
    Ok(())
}

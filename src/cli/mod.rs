//! The command line: clap definitions and the wiring of library stages.
//! Only this module (and `main.rs`) uses `anyhow`.

mod bench;
mod check;
mod info;
mod isoplanar;
pub mod plan;
mod progress;
mod simulate;
mod slice;

use anyhow::Result;
use clap::{Args, Parser, Subcommand, ValueEnum};
use maamplan::collide::Backend;
use maamplan::io::output::write_folder_atomic;
use maamplan::io::toolpath_folder::toolpath_files;
use maamplan::io::Placement;
use maamplan::job::{JobError, JobSpec, LoadedJob};
use maamplan::kinematics::{load_machine, Machine};
use maamplan::report::json::pretty_bytes;
use maamplan::scene::{BeadSettings, PartModel};
use maamplan::toolpath::Toolpath;
use std::path::{Path, PathBuf};

pub use maamplan::collide::choice::{BackendKind, Opening};

/// Collision-free, singularity-aware motion planning for multi-axis 3D printing.
#[derive(Parser, Debug)]
#[command(name = "maamplan", version, about)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Check whether the head, posed as the machine poses it at each
    /// waypoint (or as a written plan poses it), comes too close to the
    /// platform or the part printed so far.
    Check(check::CheckArgs),
    /// Measure poses per second of several backends on the same queries.
    Bench(bench::BenchArgs),
    /// Turn a toolpath (or an existing program) into G-code the machine can
    /// run: every move clear of the part, smooth through the vertical,
    /// within the extruder's speed range.
    Plan(plan::PlanArgs),
    /// List GPU adapters, their kind (hardware / software) and limits.
    Info,
    /// Slice a closed mesh into flat layers along a direction and fill them
    /// with rows (zig-zag, one-way or nearest-row order).
    Slice(slice::SliceArgs),
    /// Parallel print paths on one curved layer surface, in the direction
    /// that deposits material fastest.
    Isoplanar(isoplanar::IsoplanarArgs),
    /// Vet any 5-axis G-code before it runs: rebuild the machine's motion,
    /// check every move against the part printed so far, measure tip
    /// deviation, tip speed, rotary steps and extrusion, and list each
    /// problem at its line.
    Simulate(simulate::SimulateArgs),
}

/// The machine a run is for, how it checks and how close counts
/// (`plan`, `simulate`).
#[derive(Args, Debug, Clone)]
pub struct RunArgs {
    /// Machine file (TOML): kinematics, speeds, tip-speed range and the
    /// `[post]` dialect [default: the built-in machine, the data set's B/C
    /// rotary-table printer; `plan --write-machine` writes it out to start
    /// from].
    #[arg(long)]
    pub machine: Option<PathBuf>,
    /// Collision evaluator.
    #[arg(long, value_enum, default_value_t = BackendKind::Auto)]
    pub backend: BackendKind,
    /// Safety margin every pose and move keeps from the platform and the
    /// printed part (mm) [default: the machine file's, 0.05; 0 = touching].
    #[arg(long)]
    pub margin: Option<f64>,
}

/// How much a run prints.
#[derive(Args, Debug, Clone)]
pub struct Talk {
    /// Print only errors.
    #[arg(short, long)]
    pub quiet: bool,
    /// Print more: a line per stage (seconds, collision queries) as it
    /// ends; `check` the scene's details, `simulate` the first problems of
    /// each kind.
    #[arg(short, long, conflicts_with = "quiet")]
    pub verbose: bool,
}

/// Inputs shared by every command.
#[derive(Args, Debug, Clone)]
pub struct SceneArgs {
    /// Toolpath folder (waypoint/<k>.txt, layer/<k>.obj), a single
    /// waypoint file, or a G-code program (the tip path it prints, read
    /// with --machine); omitted: the built-in example job (`simulate`: the
    /// part the program lays itself).
    toolpath: Option<PathBuf>,
    /// Print head mesh (OBJ/STL/glTF): nozzle tip at the origin, nozzle
    /// pointing down along -z (the head extends up +z), closed
    /// [default: a 45° cone, 20 mm radius, 30 mm tall].
    #[arg(long)]
    head: Option<PathBuf>,
    /// Platform (build plate) mesh, in the toolpath's frame after --place
    /// [default: a flat plate under the part].
    #[arg(long)]
    platform: Option<PathBuf>,
    /// Move the toolpath and its layers by X,Y,Z mm (applied after --y-up),
    /// e.g. to put the part on the platform.
    #[arg(long, value_parser = parse_xyz, allow_hyphen_values = true)]
    place: Option<[f32; 3]>,
    /// The toolpath's files are Y-up: rotate them to Z-up first.
    #[arg(long)]
    y_up: bool,
    /// Contact closer than this to the nozzle tip, along the nozzle, is
    /// ignored: the nozzle rests on the bead it lays (mm).
    #[arg(long, default_value_t = 0.3)]
    clearance: f32,
    /// Keep layers whose nozzle directions mostly point down as they are
    /// stored (by default a layer with more than 20 % of them pointing down
    /// is reversed, as the data set's original software does).
    #[arg(long)]
    keep_normals: bool,
    /// Stress test: rotate every nozzle direction by DEG about the x axis
    /// before anything else (as `shared/tools/fcl_check.py --tilt`).
    #[arg(long, value_name = "DEG", allow_hyphen_values = true)]
    tilt: Option<f64>,
    /// What the part printed so far is modelled from: each layer's surface
    /// where the toolpath has one and the beads it deposits elsewhere
    /// (auto), the surfaces alone, or the beads alone.
    #[arg(long, value_enum, default_value_t = PartArg::Auto)]
    part: PartArg,
}

/// `--part`: what the printed-so-far part is modelled from.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum PartArg {
    /// Layer surfaces where given, deposited beads elsewhere.
    Auto,
    /// Layer surfaces only.
    Surfaces,
    /// Deposited beads only.
    Beads,
}

impl PartArg {
    fn model(self) -> PartModel {
        match self {
            PartArg::Auto => PartModel::Auto,
            PartArg::Surfaces => PartModel::Surfaces,
            PartArg::Beads => PartModel::Beads,
        }
    }
}

impl SceneArgs {
    /// The options given that move or turn a toolpath (`--place`,
    /// `--y-up`, `--tilt`, `--keep-normals`), as the command line spells
    /// them: without a toolpath they have nothing to act on.
    pub fn toolpath_options(&self) -> Vec<&'static str> {
        let given = [
            (self.place.is_some(), "--place"),
            (self.y_up, "--y-up"),
            (self.tilt.is_some(), "--tilt"),
            (self.keep_normals, "--keep-normals"),
        ];
        given.iter().filter(|g| g.0).map(|g| g.1).collect()
    }

    /// Load the inputs (or the built-in example) and build the scene,
    /// beads (where the part is modelled from them) as `machine` lays them.
    pub fn load(&self, machine: &Machine) -> Result<LoadedJob> {
        LoadedJob::load(&self.spec(machine)?).map_err(job_error)
    }

    /// The job these arguments name, for `machine`.
    pub fn spec(&self, machine: &Machine) -> Result<JobSpec> {
        if let Some(t) = self.tilt {
            if !t.is_finite() {
                return Err(UsageError("--tilt must be a finite angle (degrees)".into()).into());
            }
        }
        Ok(JobSpec {
            toolpath: self.toolpath.clone(),
            head: self.head.clone(),
            platform: self.platform.clone(),
            placement: Placement {
                y_up: self.y_up,
                offset: self.place.unwrap_or([0.0; 3]),
            },
            clearance: self.clearance,
            keep_normals: self.keep_normals,
            tilt_deg: self.tilt,
            part: self.part.model(),
            beads: BeadSettings::of_machine(machine),
            reach: Some(machine.reach()),
            machine: machine.clone(),
        })
    }
}

/// A job that failed to load, as the command line reports it: a setting
/// out of range is a misuse (exit 2).
pub fn job_error(e: JobError) -> anyhow::Error {
    match e {
        JobError::Setting(m) => UsageError(m).into(),
        e => anyhow::Error::from(e),
    }
}

/// The machine of `--machine`, or the built-in one.
pub fn load_machine_or_default(path: Option<&Path>) -> Result<Machine> {
    Ok(match path {
        Some(p) => load_machine(p)?,
        None => Machine::default(),
    })
}

/// The machine of `--machine` (or the built-in one) and the margin to
/// check at: `--margin`, else the machine file's.
pub fn machine_and_margin(path: Option<&Path>, margin: Option<f64>) -> Result<(Machine, f64)> {
    let machine = load_machine_or_default(path)?;
    let margin = margin.unwrap_or(machine.margin);
    if !(margin.is_finite() && (0.0..10.0).contains(&margin)) {
        return Err(UsageError("--margin must be between 0 and 10 mm".into()).into());
    }
    Ok((machine, margin))
}

/// Check before any work that `out` can become the output folder: not a
/// file, and its nearest existing ancestor a writable folder.
pub fn check_output(out: &Path) -> Result<()> {
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
        Command::Simulate(a) => simulate::run(a),
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

/// Evaluate in chunks so the progress bar moves, each as large as the
/// backend works best with ([`Backend::batch_hint`]: whole batches for the
/// gpu).
pub fn evaluate_with_progress(
    backend: &dyn Backend,
    queries: &[maamplan::scene::Query],
    pb: &indicatif::ProgressBar,
) -> Result<Vec<bool>> {
    let mut out = Vec::with_capacity(queries.len());
    for chunk in queries.chunks(backend.batch_hint()) {
        out.extend(backend.evaluate(chunk)?);
        pb.inc(chunk.len() as u64);
    }
    pb.finish_and_clear();
    Ok(out)
}

/// Write a generated toolpath (the folder layout `plan` reads) and its
/// `summary` as summary.json into `out`, at once.
pub fn write_generated(out: &Path, toolpath: &Toolpath, summary: &serde_json::Value) -> Result<()> {
    let mut files = toolpath_files(toolpath);
    files.push(("summary.json".into(), pretty_bytes(summary)));
    write_folder_atomic(out, &files).map_err(|e| {
        UsageError(format!(
            "{}: cannot write ({e}): check the parent folder exists and is writable",
            out.display()
        ))
    })?;
    Ok(())
}

/// Serialise `value` as pretty JSON to `path`, atomically.
pub fn write_json(path: &Path, value: &serde_json::Value) -> Result<()> {
    maamplan::io::output::write_atomic(path, &pretty_bytes(value)).map_err(|e| {
        UsageError(format!(
            "{}: cannot write ({e}): check the folder exists and is writable",
            path.display()
        ))
    })?;
    Ok(())
}

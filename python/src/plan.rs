//! `plan()` and `Plan`: what `maamplan plan` does, the plan's axes and
//! flags as arrays, its report as a dict, its files written on request.

use crate::inputs::{self, JobInputs};
use crate::progress::Callback;
use crate::scene::{job_inputs, matrix};
use crate::{raise, usage};
use maamplan::io::plan_csv::write_plan_csv;
use maamplan::job::LoadedJob;
use maamplan::kinematics::{Axes, Machine};
use maamplan::plan::candidates::Sampling;
use maamplan::plan::smooth::Smoothing;
use maamplan::plan::{plan_prepared, Plan as Planned, PlanOptions, Skip};
use maamplan::report::html::ReportContext;
use maamplan::report::json::{plan_report, pretty_bytes, skipped_waypoints, PlanRun};
use maamplan::report::plan_files::{write_output, Rendered};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::prelude::*;
use std::path::PathBuf;
use std::time::Instant;

/// The planner's settings from `plan`'s keyword arguments, as the
/// command line's flags make them, within the same ranges.
#[allow(clippy::too_many_arguments)]
fn plan_options(
    smoothing: &str,
    passes: usize,
    window: usize,
    cone: f64,
    alpha: f64,
    beta: f64,
    variants: usize,
    rings: bool,
    subsample: usize,
    edge_step: f64,
    margin: Option<f64>,
) -> PyResult<PlanOptions> {
    for (name, v, lo, hi) in [
        ("alpha", alpha, 0.0, 45.0),
        ("beta", beta, 1.0, 90.0),
        ("cone", cone, 0.1, 90.0),
        ("edge_step", edge_step, 0.01, 10.0),
        ("margin", margin.unwrap_or(0.05), 0.0, 10.0),
    ] {
        if !(v >= lo && v <= hi) {
            return Err(usage(format!("{name} must be between {lo} and {hi}")));
        }
    }
    let smoothing = match smoothing {
        "laplacian" => Smoothing::Laplacian { passes },
        "moving-average" | "moving_average" => Smoothing::MovingAverage {
            window,
            cone_deg: cone,
        },
        "median" => Smoothing::Median {
            window,
            cone_deg: cone,
        },
        "none" => Smoothing::None,
        s => {
            return Err(usage(format!(
                "smoothing must be laplacian, moving-average, median or none, not {s:?}"
            )))
        }
    };
    Ok(PlanOptions {
        smoothing,
        alpha: alpha.to_radians(),
        beta: beta.to_radians(),
        sampling: if rings {
            Sampling::Rings
        } else {
            Sampling::Random { k: variants.max(1) }
        },
        edge_step,
        subsample: subsample.max(1),
        margin,
        ..PlanOptions::default()
    })
}

/// Plan `toolpath` as `maamplan plan` does, with its defaults: the
/// scene's arguments as `Scene` takes them, `machine` a machine file
/// (None: the built-in machine), `backend` "auto", "gpu" or "cpu",
/// `margin` mm (None: the machine's), and the planner's options
/// (`smoothing`, `passes`, `window`, `cone`, `alpha`, `beta`,
/// `variants`, `rings`, `subsample`, `edge_step`; angles in degrees).
/// `progress(stage, done, total)` hears each stage and batch of
/// queries. Runs without the GIL.
#[pyfunction]
#[pyo3(signature = (toolpath=None, *, head=None, platform=None, place=None, y_up=false, tilt=None, keep_normals=false, clearance=0.3, part="auto", machine=None, backend="auto", margin=None, smoothing="laplacian", passes=8, window=9, cone=15.0, alpha=4.5, beta=45.0, variants=24, rings=false, subsample=1, edge_step=0.3, progress=None))]
#[allow(clippy::too_many_arguments)]
pub fn plan(
    py: Python<'_>,
    toolpath: Option<&Bound<'_, PyAny>>,
    head: Option<&Bound<'_, PyAny>>,
    platform: Option<&Bound<'_, PyAny>>,
    place: Option<[f32; 3]>,
    y_up: bool,
    tilt: Option<f64>,
    keep_normals: bool,
    clearance: f32,
    part: &str,
    machine: Option<PathBuf>,
    backend: &str,
    margin: Option<f64>,
    smoothing: &str,
    passes: usize,
    window: usize,
    cone: f64,
    alpha: f64,
    beta: f64,
    variants: usize,
    rings: bool,
    subsample: usize,
    edge_step: f64,
    progress: Option<Py<PyAny>>,
) -> PyResult<Plan> {
    let mut opts = plan_options(
        smoothing, passes, window, cone, alpha, beta, variants, rings, subsample, edge_step, margin,
    )?;
    let kind = inputs::backend(backend)?;
    let inputs = job_inputs(
        toolpath,
        head,
        platform,
        place,
        y_up,
        tilt,
        keep_normals,
        clearance,
        part,
    )?;
    let machine = inputs::machine(machine)?;
    let spec = inputs.spec(&machine)?;
    let tell = Callback::new(progress);
    let t0 = Instant::now();
    let planned = py.detach(|| -> Result<_, Box<dyn std::error::Error + Send + Sync>> {
        tell.stage("loading");
        let opening = kind.open();
        let (mut job, prepared) = LoadedJob::load_prepared(&spec, &machine, &mut opts)?;
        if let Some(label) = &inputs.label {
            job.source = label.clone();
        }
        let backend = kind.build_with(opening, &job.scene, false, Default::default())?;
        let load = t0.elapsed().as_secs_f64();
        let p = plan_prepared(
            prepared,
            &job.scene,
            &machine,
            backend.as_ref(),
            &opts,
            &mut |e| tell.on(e),
        )?;
        let name = backend.name();
        drop(backend);
        Ok((job, p, name, load))
    });
    tell.finish()?;
    let (job, p, backend, load) = planned.map_err(|e| raise(e.as_ref()))?;
    let mut stages = vec![("load".to_string(), load)];
    stages.extend(p.stages.iter().map(|s| (s.name.clone(), s.seconds)));
    Ok(Plan {
        seconds: t0.elapsed().as_secs_f64(),
        margin: margin.unwrap_or(machine.margin),
        job,
        plan: p,
        machine,
        backend,
        stages,
        _inputs: inputs,
    })
}

/// A plan: every waypoint's machine axes and flags (`plan.csv`'s
/// columns) as arrays, the report (`report.json`) as a dict, and the
/// command line's files on `write(dir)`.
#[pyclass(frozen, module = "maamplan")]
pub struct Plan {
    /// The safety margin planned at (the report's pictures check at it).
    margin: f64,
    job: LoadedJob,
    plan: Planned,
    machine: Machine,
    backend: &'static str,
    stages: Vec<(String, f64)>,
    seconds: f64,
    _inputs: JobInputs,
}

impl Plan {
    /// report.json's content, with `stages` and `seconds` of the run.
    fn report_value(&self, stages: &[(String, f64)], seconds: f64) -> serde_json::Value {
        let skipped = skipped_waypoints(&self.plan, &self.job.toolpath);
        let flipped = self.job.flipped_names();
        plan_report(
            &self.machine,
            &self.plan,
            &skipped,
            &PlanRun {
                source: &self.job.source,
                part: self.job.scene.part,
                backend: self.backend,
                flipped_layers: &flipped,
                stages,
                seconds,
                command: COMMAND,
            },
        )
    }

    /// One value per waypoint as an array.
    fn each<'py, T: numpy::Element>(
        &self,
        py: Python<'py>,
        f: impl Fn(&maamplan::plan::PlannedWaypoint) -> T,
    ) -> Bound<'py, PyArray1<T>> {
        self.plan
            .waypoints
            .iter()
            .map(f)
            .collect::<Vec<T>>()
            .into_pyarray(py)
    }
}

/// What the reports name as the command.
const COMMAND: &str = "maamplan.plan() (Python)";

/// X, Y, Z (mm), B or A, C (degrees) as plan.csv writes them.
fn axes_row(a: &Axes) -> [f64; 5] {
    [
        a.xyz[0],
        a.xyz[1],
        a.xyz[2],
        a.tilt.to_degrees(),
        a.c.to_degrees(),
    ]
}

fn axes_array<'py>(py: Python<'py>, rows: Vec<[f64; 5]>) -> Bound<'py, PyArray2<f64>> {
    let n = rows.len();
    Array2::from_shape_vec((n, 5), rows.into_iter().flatten().collect())
        .expect("N×5")
        .into_pyarray(py)
}

#[pymethods]
impl Plan {
    /// The machine axes of each waypoint (N, 5): X, Y, Z (mm), B (or A)
    /// and C (degrees, C unwound), as plan.csv gives them; NaN for a
    /// skipped waypoint.
    #[getter]
    fn axes<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let rows = self.plan.waypoints.iter().map(|w| match w.skipped {
            None => axes_row(&w.axes),
            Some(_) => [f64::NAN; 5],
        });
        axes_array(py, rows.collect())
    }

    /// The input's axes (N, 5): direct IK, C unwound, as `check` poses them.
    #[getter]
    fn input_axes<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        axes_array(py, self.plan.input_axes.iter().map(axes_row).collect())
    }

    /// Nozzle tips (N, 3), mm.
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let v: Vec<[f64; 3]> = self.plan.waypoints.iter().map(|w| w.p).collect();
        matrix(py, &v)
    }

    /// Planned nozzle axes (N, 3) (the input's where skipped).
    #[getter]
    fn directions<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        let v: Vec<[f64; 3]> = self.plan.waypoints.iter().map(|w| w.n).collect();
        matrix(py, &v)
    }

    /// Layer index of each waypoint (N,).
    #[getter]
    fn layer<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        self.each(py, |w| w.layer as i64)
    }

    /// The layers' names, by index.
    #[getter]
    fn layer_names(&self) -> Vec<String> {
        self.job
            .toolpath
            .layers
            .iter()
            .map(|l| l.name.clone())
            .collect()
    }

    /// Extruder position (N,), mm of filament, absolute within the layer.
    #[getter]
    fn e<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.each(py, |w| w.e)
    }

    /// Layer height used for each waypoint's extrusion (N,), mm.
    #[getter]
    fn height<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.each(py, |w| w.height)
    }

    /// The first visited waypoint of each section (a travel before it).
    #[getter]
    fn section_start<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<bool>> {
        self.each(py, |w| w.section_start)
    }

    /// Entered through a break (retract, lift, travel, approach).
    #[getter]
    fn break_before<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<bool>> {
        self.each(py, |w| w.break_before)
    }

    /// The input orientation comes within the margin.
    #[getter]
    fn was_colliding<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<bool>> {
        self.each(py, |w| w.was_colliding)
    }

    /// The input orientation lies within alpha of vertical.
    #[getter]
    fn was_singular<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<bool>> {
        self.each(py, |w| w.was_singular)
    }

    /// The planned orientation lies within alpha of vertical.
    #[getter]
    fn singular<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<bool>> {
        self.each(py, |w| w.singular)
    }

    /// Not visited.
    #[getter]
    fn skipped<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<bool>> {
        self.each(py, |w| w.skipped.is_some())
    }

    /// Why each waypoint is skipped ("residual", "unreachable",
    /// "isolated"), None where it is visited.
    #[getter]
    fn skip_reasons(&self) -> Vec<Option<&'static str>> {
        let reason = |s: Skip| match s {
            Skip::Residual => "residual",
            Skip::Unreachable => "unreachable",
            Skip::Isolated => "isolated",
        };
        self.plan
            .waypoints
            .iter()
            .map(|w| w.skipped.map(reason))
            .collect()
    }

    /// Things to know about the plan, one line each.
    #[getter]
    fn warnings(&self) -> Vec<String> {
        maamplan::report::warnings(self.job.scene.part, &self.plan.warnings)
    }

    /// The backend that answered ("gpu" or "cpu").
    #[getter]
    fn backend(&self) -> &'static str {
        self.backend
    }

    /// report.json's content as a dict.
    #[getter]
    fn report(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        json(py, &self.report_value(&self.stages, self.seconds))
    }

    /// plan.csv's text, as `maamplan plan` writes it.
    fn csv(&self) -> String {
        write_plan_csv(&self.machine, &self.plan.waypoints)
    }

    /// Write the command line's outputs into folder `dir` at once:
    /// toolpath.gcode, plan.csv, report.json and, with `plots`,
    /// scene.glb, program.glb, report.html and plots/ (an earlier run's are replaced).
    /// Returns `dir`.
    #[pyo3(signature = (dir, plots=true))]
    fn write(&self, py: Python<'_>, dir: PathBuf, plots: bool) -> PyResult<PathBuf> {
        let flipped = self.job.flipped_names();
        let written = py.detach(|| -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
            let context = ReportContext {
                source: &self.job.source,
                part: self.job.scene.part,
                command: COMMAND,
                flipped_layers: &flipped,
            };
            let t = Instant::now();
            let rendered = Rendered::new(
                &self.machine,
                &self.plan,
                &self.job,
                &context,
                self.seconds,
                plots.then_some(self.margin),
                &(),
            )?;
            let mut stages = self.stages.clone();
            stages.extend(rendered.stages.iter().cloned());
            let seconds = self.seconds + t.elapsed().as_secs_f64();
            let report = self.report_value(&stages, seconds);
            let files = rendered.into_files(pretty_bytes(&report));
            write_output(&dir, &files)?;
            Ok(())
        });
        written.map_err(|e| raise(e.as_ref()))?;
        Ok(dir)
    }

    fn __repr__(&self) -> String {
        format!(
            "Plan({}, {} waypoints, {} skipped, backend {})",
            self.job.source,
            self.plan.waypoints.len(),
            self.plan
                .waypoints
                .iter()
                .filter(|w| w.skipped.is_some())
                .count(),
            self.backend
        )
    }
}

/// A JSON value as Python objects (dicts, lists, numbers, strings).
pub fn json(py: Python<'_>, v: &serde_json::Value) -> PyResult<Py<PyAny>> {
    let text = serde_json::to_string(v).expect("a Value serialises");
    Ok(py.import("json")?.call_method1("loads", (text,))?.unbind())
}

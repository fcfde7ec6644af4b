//! `simulate()` and `Simulation`: what `maamplan simulate` does, each
//! line's measures as arrays, the problems as a list of dicts.

use crate::inputs::{self, JobInputs};
use crate::plan::json;
use crate::progress::Callback;
use crate::raise;
use crate::scene::{job_inputs, load};
use maamplan::default_job::default_head;
use maamplan::io::gcode_read::{load_program, Program};
use maamplan::io::mesh::load_mesh;
use maamplan::kinematics::Machine;
use maamplan::plan::PlanOptions;
use maamplan::report::json::{simulation_report, SimulationRun};
use maamplan::scene::PartSource;
use maamplan::simulate::{self as sim, against, MoveReport, Simulation as Simulated};
use numpy::{IntoPyArray, PyArray1};
use pyo3::exceptions::PyUserWarning;
use pyo3::prelude::*;
use std::ffi::CString;
use std::path::PathBuf;
use std::time::Instant;

type AnyError = Box<dyn std::error::Error + Send + Sync>;

/// Simulate the G-code `program` as `maamplan simulate` does: against
/// `toolpath`'s layers (a Toolpath or a path) printed in the program's
/// order, or with None against the beads the program lays itself (then
/// `place`, `y_up`, `tilt` and `keep_normals` are ignored, with a
/// warning). The other arguments as `Scene` and `plan` take them.
/// `progress(stage, done, total)` hears each batch of queries. Runs
/// without the GIL.
#[pyfunction]
#[pyo3(signature = (program, toolpath=None, *, head=None, platform=None, place=None, y_up=false, tilt=None, keep_normals=false, clearance=0.3, part="auto", machine=None, backend="auto", margin=None, progress=None))]
#[allow(clippy::too_many_arguments)]
pub fn simulate(
    py: Python<'_>,
    program: PathBuf,
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
    progress: Option<Py<PyAny>>,
) -> PyResult<Simulation> {
    let t0 = Instant::now();
    let kind = inputs::backend(backend)?;
    let machine = inputs::machine(machine)?;
    let margin = inputs::margin(&machine, margin)?;
    let own = toolpath.is_none_or(|t| t.is_none());
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
    if own && (place.is_some() || y_up || tilt.is_some() || keep_normals) {
        let message = CString::new(
            "place, y_up, tilt and keep_normals are ignored: without a toolpath the program is checked in its own frame, the machine's",
        )
        .expect("no NUL");
        PyErr::warn(py, &py.get_type::<PyUserWarning>(), &message, 1)?;
    }
    let program_text = py
        .detach(|| load_program(&program, &machine))
        .map_err(|e| raise(&e))?;
    let against = part_against(py, &inputs, own, &machine, &program_text)?;
    let tell = Callback::new(progress);
    let run = py.detach(|| -> Result<_, AnyError> {
        tell.stage("checking");
        let backend = kind.build(&against.scene, false)?;
        let tick = |done: u64, total: u64| tell.queries(done, total);
        let (collides, queries) = sim::check_moves(
            &machine,
            backend.as_ref(),
            &against.scene,
            margin,
            PlanOptions::default().edge_step,
            &program_text.moves,
            &against.timeline.cutoffs,
            Some(&tick),
        )?;
        let simulated = sim::report(
            &machine,
            &program_text.moves,
            &against.timeline,
            &collides,
            queries,
            margin,
            sim::Deviation::Sampled,
        );
        Ok((simulated, backend.name()))
    });
    tell.finish()?;
    let (simulated, backend) = run.map_err(|e| raise(e.as_ref()))?;
    Ok(Simulation {
        layer_names: against
            .toolpath
            .layers
            .iter()
            .map(|l| l.name.clone())
            .collect(),
        source: against.source,
        part: against.scene.part,
        gcode: program.display().to_string(),
        sim: simulated,
        machine,
        backend,
        seconds: t0.elapsed().as_secs_f64(),
        _inputs: inputs,
    })
}

/// What `program` is checked against, as `simulate` sets it up: the
/// job's toolpath (`own` false) or the beads the program lays itself.
fn part_against(
    py: Python<'_>,
    inputs: &JobInputs,
    own: bool,
    machine: &Machine,
    program: &Program,
) -> PyResult<against::Against> {
    if !own {
        let job = load(py, inputs, machine)?;
        return Ok(py.detach(|| against::job(job, machine, program)));
    }
    let head = match &inputs.head {
        Some(p) => load_mesh(p).map_err(|e| raise(&e))?,
        None => default_head(),
    };
    let platform = match &inputs.platform {
        Some(p) => Some(load_mesh(p).map_err(|e| raise(&e))?),
        None => None,
    };
    py.detach(|| {
        against::own(
            program,
            machine,
            &head,
            platform,
            inputs.clearance,
            inputs.part,
        )
    })
    .map_err(|e| raise(&e))
}

/// A simulated program: each line that moves measured (arrays, one
/// entry per such line), the problems at their lines, the summary and
/// report.json's content.
#[pyclass(frozen, module = "maamplan")]
pub struct Simulation {
    sim: Simulated,
    machine: Machine,
    layer_names: Vec<String>,
    source: String,
    part: PartSource,
    gcode: String,
    backend: &'static str,
    seconds: f64,
    _inputs: JobInputs,
}

impl Simulation {
    fn each<'py, T: numpy::Element>(
        &self,
        py: Python<'py>,
        f: impl Fn(&MoveReport) -> T,
    ) -> Bound<'py, PyArray1<T>> {
        self.sim
            .moves
            .iter()
            .map(f)
            .collect::<Vec<T>>()
            .into_pyarray(py)
    }
}

#[pymethods]
impl Simulation {
    /// The program's line of each move (1-based).
    #[getter]
    fn line<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        self.each(py, |m| m.line as i64)
    }

    /// Does the move extrude?
    #[getter]
    fn extrudes<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<bool>> {
        self.each(py, |m| m.extrudes)
    }

    /// Under tool-centre-point control?
    #[getter]
    fn tcp<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<bool>> {
        self.each(py, |m| m.tcp)
    }

    /// The layer the move reads as (-1: none).
    #[getter]
    fn layer<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        self.each(py, |m| m.layer.map_or(-1, |l| l as i64))
    }

    /// Seconds the move takes.
    #[getter]
    fn seconds<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.each(py, |m| m.seconds)
    }

    /// The tip's path length (mm).
    #[getter]
    fn length_mm<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.each(py, |m| m.length_mm)
    }

    /// Tip speed (mm/s).
    #[getter]
    fn tip_speed<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.each(py, |m| m.tip_speed)
    }

    /// The tip's largest deviation from the straight bead (mm).
    #[getter]
    fn deviation_mm<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.each(py, |m| m.deviation_mm)
    }

    /// Rotary step (degrees).
    #[getter]
    fn rotary_step_deg<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.each(py, |m| m.rotary_step_deg)
    }

    /// The tilt axis at the move's end (degrees).
    #[getter]
    fn tilt_deg<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.each(py, |m| m.tilt_deg)
    }

    /// C at the move's end (degrees).
    #[getter]
    fn c_deg<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.each(py, |m| m.c_deg)
    }

    /// Filament per millimetre of the tip's path.
    #[getter]
    fn e_per_mm<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.each(py, |m| m.e_per_mm)
    }

    /// Does the move come within the margin of the material present?
    #[getter]
    fn collides<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<bool>> {
        self.each(py, |m| m.collides)
    }

    /// The lines of the colliding moves, in order.
    #[getter]
    fn colliding_lines<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        let lines: Vec<i64> = self
            .sim
            .moves
            .iter()
            .filter(|m| m.collides)
            .map(|m| m.line as i64)
            .collect();
        lines.into_pyarray(py)
    }

    /// Every problem: dicts with `line`, `kind` ("collision",
    /// "tip_deviation", "tip_speed", "swing", "blob",
    /// "long_travel_turn"), `value`, `layer` and `time_s` (when its line
    /// ends, the time `program.glb` shows it at).
    #[getter]
    fn problems(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let mut all = serde_json::to_value(&self.sim.problems).expect("serialises");
        if let Some(list) = all.as_array_mut() {
            for (p, t) in list.iter_mut().zip(self.sim.problem_times()) {
                p["time_s"] = serde_json::json!(t);
            }
        }
        json(py, &all)
    }

    /// The summary's figures as a dict.
    #[getter]
    fn summary(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        json(
            py,
            &serde_json::to_value(&self.sim.summary).expect("serialises"),
        )
    }

    /// report.json's content as a dict, as `simulate -o` writes it.
    #[getter]
    fn report(&self, py: Python<'_>) -> PyResult<Py<PyAny>> {
        let run = SimulationRun {
            gcode: &self.gcode,
            toolpath: &self.source,
            part: self.part,
            layer_names: &self.layer_names,
            backend: self.backend,
            seconds: self.seconds,
            command: "maamplan.simulate() (Python)",
        };
        json(py, &simulation_report(&self.machine, &self.sim, &run))
    }

    /// What the program was checked against.
    #[getter]
    fn against(&self) -> String {
        self.source.clone()
    }

    fn __repr__(&self) -> String {
        format!(
            "Simulation({}, {} moves, {} colliding, against {})",
            self.gcode, self.sim.summary.moves, self.sim.summary.colliding_moves, self.source
        )
    }
}

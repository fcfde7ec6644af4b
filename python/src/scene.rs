//! `Toolpath`, `Scene` and `Evaluator`: what `check` loads and asks,
//! with poses and verdicts as numpy arrays.

use crate::inputs::{self, rows, JobInputs, Scratch};
use crate::progress::Callback;
use crate::{raise, usage};
use maamplan::collide::sample::tilted_queries;
use maamplan::collide::Backend;
use maamplan::geometry::Pose;
use maamplan::io::toolpath_folder::toolpath_files;
use maamplan::io::Placement;
use maamplan::job::LoadedJob;
use maamplan::kinematics::Machine;
use maamplan::plan::{input_axes, runs, PlanOptions};
use maamplan::scene::{cutoff, Query};
use maamplan::toolpath::{Layer, Toolpath as Layers, Waypoint};
use numpy::ndarray::{Array2, Array3};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArray3};
use pyo3::prelude::*;
use std::fmt::Write;
use std::path::PathBuf;
use std::sync::Arc;

/// A toolpath: a folder (`waypoint/<k>.txt`, `layer/<k>.obj`), a single
/// waypoint file, a G-code program (the tip path it prints, read for the
/// machine it is planned or checked for), arrays
/// (`Toolpath.from_arrays`), or the built-in example (`Toolpath.default()`).
#[pyclass(frozen, module = "maamplan")]
#[derive(Clone)]
pub struct Toolpath {
    path: Option<PathBuf>,
    label: Option<String>,
    scratch: Option<Scratch>,
}

#[pymethods]
impl Toolpath {
    /// The toolpath at `path` (a folder, a waypoint file or a program).
    #[new]
    fn new(path: PathBuf) -> Self {
        Toolpath {
            path: Some(path),
            label: None,
            scratch: None,
        }
    }

    /// The built-in example job (a dome printed as four hemispherical
    /// shells), the command line's default toolpath.
    #[staticmethod]
    fn default() -> Self {
        Toolpath {
            path: None,
            label: None,
            scratch: None,
        }
    }

    /// A toolpath from arrays: `positions` (N, 3) nozzle tips and
    /// `directions` (N, 3) nozzle axes (pointing from the tip into the
    /// head) in print order, mm; `layer` (N,) integers, consecutive equal
    /// values one layer (None: one layer, the layers then found from how
    /// the beads stack); `surfaces`, one mesh per layer in order
    /// ((vertices, faces) or a trimesh.Trimesh), or None: the part is
    /// modelled from the beads. Read as the same data in a file would be.
    #[staticmethod]
    #[pyo3(signature = (positions, directions, layer=None, surfaces=None))]
    fn from_arrays(
        positions: &Bound<'_, PyAny>,
        directions: &Bound<'_, PyAny>,
        layer: Option<&Bound<'_, PyAny>>,
        surfaces: Option<Vec<Bound<'_, PyAny>>>,
    ) -> PyResult<Self> {
        let pos = rows::<3>(positions, "positions")?;
        let dir = rows::<3>(directions, "directions")?;
        if pos.len() != dir.len() {
            return Err(usage(format!(
                "positions has {} rows, directions {}: give one direction per position",
                pos.len(),
                dir.len()
            )));
        }
        let layer = match layer.filter(|l| !l.is_none()) {
            Some(l) => Some(layer_values(l, pos.len())?),
            None => None,
        };
        let scratch = inputs::scratch()?;
        let path = match surfaces {
            None => write_waypoint_csv(&scratch, &pos, &dir, layer.as_deref())?,
            Some(s) => write_folder(&scratch, &pos, &dir, layer.as_deref(), &s)?,
        };
        Ok(Toolpath {
            path: Some(path),
            label: Some(format!("arrays ({} waypoints)", pos.len())),
            scratch: Some(scratch),
        })
    }

    /// Where the toolpath is read from (None: the built-in example).
    #[getter]
    fn path(&self) -> Option<PathBuf> {
        self.path.clone()
    }

    fn __repr__(&self) -> String {
        match (&self.label, &self.path) {
            (Some(l), _) => format!("Toolpath({l})"),
            (None, Some(p)) => format!("Toolpath({:?})", p.display().to_string()),
            (None, None) => "Toolpath.default()".into(),
        }
    }
}

/// `layer` as one integer per waypoint.
fn layer_values(layer: &Bound<'_, PyAny>, n: usize) -> PyResult<Vec<i64>> {
    let (shape, values) = inputs::floats(layer, "layer")?;
    if shape != [n] || values.iter().any(|v| v.fract() != 0.0) {
        return Err(usage(format!(
            "layer: expected ({n},) integers, one per position"
        )));
    }
    Ok(values.iter().map(|&v| v as i64).collect())
}

/// The waypoints as a single CSV file (`layer` column when given).
fn write_waypoint_csv(
    scratch: &Scratch,
    pos: &[[f64; 3]],
    dir: &[[f64; 3]],
    layer: Option<&[i64]>,
) -> PyResult<PathBuf> {
    let mut text = String::with_capacity(pos.len() * 64);
    text.push_str(if layer.is_some() {
        "layer,x,y,z,nx,ny,nz\n"
    } else {
        "x,y,z,nx,ny,nz\n"
    });
    for (i, (p, d)) in pos.iter().zip(dir).enumerate() {
        if let Some(l) = layer {
            let _ = write!(text, "{},", l[i]);
        }
        let [x, y, z] = p.map(|c| c as f32);
        let [a, b, c] = d.map(|c| c as f32);
        let _ = writeln!(text, "{x},{y},{z},{a},{b},{c}");
    }
    let path = scratch.path().join("toolpath.csv");
    std::fs::write(&path, text).map_err(|e| usage(format!("cannot write the toolpath: {e}")))?;
    Ok(path)
}

/// The waypoints and their layers' surfaces as a toolpath folder, layers
/// named by their order (0, 1, …).
fn write_folder(
    scratch: &Scratch,
    pos: &[[f64; 3]],
    dir: &[[f64; 3]],
    layer: Option<&[i64]>,
    surfaces: &[Bound<'_, PyAny>],
) -> PyResult<PathBuf> {
    let mut layers: Vec<Layer> = Vec::new();
    for (i, (p, d)) in pos.iter().zip(dir).enumerate() {
        let starts = i == 0 || layer.is_some_and(|l| l[i] != l[i - 1]);
        if starts {
            layers.push(Layer {
                name: layers.len().to_string(),
                waypoints: Vec::new(),
                surface: None,
            });
        }
        layers
            .last_mut()
            .expect("a layer")
            .waypoints
            .push(Waypoint {
                pos: p.map(|c| c as f32),
                dir: d.map(|c| c as f32),
            });
    }
    if surfaces.len() != layers.len() {
        return Err(usage(format!(
            "surfaces: {} given for {} layers: give one per layer",
            surfaces.len(),
            layers.len()
        )));
    }
    let meshes = scratch.path().join("surfaces");
    std::fs::create_dir_all(&meshes).map_err(|e| usage(e.to_string()))?;
    let meshes = Arc::new(tempfile::TempDir::new_in(&meshes).map_err(|e| usage(e.to_string()))?);
    for (l, s) in layers.iter_mut().zip(surfaces) {
        let path = inputs::mesh_path(Some(s), &format!("surface {}", l.name), &meshes)?
            .expect("a surface");
        l.surface = Some(maamplan::io::mesh::load_mesh(&path).map_err(|e| raise(&e))?);
    }
    let folder = scratch.path().join("toolpath");
    for (rel, bytes) in toolpath_files(&Layers { layers }) {
        let path = folder.join(rel);
        let written = std::fs::create_dir_all(path.parent().expect("in the folder"))
            .and_then(|_| std::fs::write(&path, bytes));
        written.map_err(|e| usage(format!("cannot write the toolpath: {e}")))?;
    }
    Ok(folder)
}

/// The common arguments as the library takes them.
#[allow(clippy::too_many_arguments)]
pub fn job_inputs(
    toolpath: Option<&Bound<'_, PyAny>>,
    head: Option<&Bound<'_, PyAny>>,
    platform: Option<&Bound<'_, PyAny>>,
    place: Option<[f32; 3]>,
    y_up: bool,
    tilt: Option<f64>,
    keep_normals: bool,
    clearance: f32,
    part: &str,
) -> PyResult<JobInputs> {
    let tp = match toolpath.filter(|t| !t.is_none()) {
        None => Toolpath::default(),
        Some(t) => match t.cast::<Toolpath>() {
            Ok(t) => t.get().clone(),
            Err(_) => Toolpath::new(t.extract::<PathBuf>().map_err(|_| {
                usage("toolpath: give a Toolpath, a path or None (the built-in example)")
            })?),
        },
    };
    let scratch = inputs::scratch()?;
    Ok(JobInputs {
        toolpath: tp.path.clone(),
        label: tp.label.clone(),
        head: inputs::mesh_path(head, "head", &scratch)?,
        platform: inputs::mesh_path(platform, "platform", &scratch)?,
        placement: Placement {
            y_up,
            offset: place.unwrap_or([0.0; 3]),
        },
        clearance,
        keep_normals,
        tilt,
        part: inputs::part(part)?,
        _scratch: [Some(scratch), tp.scratch].into_iter().flatten().collect(),
    })
}

/// A loaded job as a Python object holds it: shared with the evaluators
/// and plans made from it.
pub fn load(py: Python<'_>, inputs: &JobInputs, machine: &Machine) -> PyResult<LoadedJob> {
    let spec = inputs.spec(machine)?;
    let mut job = py
        .detach(|| LoadedJob::load(&spec))
        .map_err(|e| raise(&e))?;
    if let Some(label) = &inputs.label {
        job.source = label.clone();
    }
    Ok(job)
}

/// A scene: the toolpath (the command line's conventions applied), the
/// head, the platform and the part printed so far, as `check` loads them.
#[pyclass(frozen, module = "maamplan")]
pub struct Scene {
    pub(crate) job: Arc<LoadedJob>,
    pub(crate) machine: Machine,
    _inputs: JobInputs,
}

#[pymethods]
impl Scene {
    /// Load `toolpath` (a Toolpath, a path, or None: the built-in
    /// example) with `head` and `platform` (mesh files, (vertices, faces)
    /// arrays or trimesh.Trimesh objects; None: the defaults), moved by
    /// `place` (x, y, z mm) after `y_up`, nozzle axes tilted by `tilt`
    /// degrees about x, layers that mostly point down reversed unless
    /// `keep_normals`; contact within `clearance` mm of the tip along the
    /// nozzle ignored; the part modelled from `part` ("auto", "surfaces",
    /// "beads"); `machine`: a machine file (None: the built-in machine).
    #[new]
    #[pyo3(signature = (toolpath=None, head=None, platform=None, *, place=None, y_up=false, tilt=None, keep_normals=false, clearance=0.3, part="auto", machine=None))]
    #[allow(clippy::too_many_arguments)]
    fn new(
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
    ) -> PyResult<Self> {
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
        let job = load(py, &inputs, &machine)?;
        Ok(Scene {
            job: Arc::new(job),
            machine,
            _inputs: inputs,
        })
    }

    /// The toolpath as named (for messages and reports).
    #[getter]
    fn source(&self) -> String {
        self.job.source.clone()
    }

    /// What the part printed so far is modelled from.
    #[getter]
    fn part(&self) -> &'static str {
        self.job.scene.part.name()
    }

    /// Platform and part triangles.
    #[getter]
    fn triangle_count(&self) -> usize {
        self.job.scene.triangle_count()
    }

    /// The machine's safety margin (mm): `Evaluator.collides`' default.
    #[getter]
    fn margin(&self) -> f64 {
        self.machine.margin
    }

    /// Nozzle tips (N, 3), mm, in print order, as loaded.
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        matrix(py, &self.job.toolpath.positions())
    }

    /// Nozzle axes (N, 3), unit, as loaded (reversed layers reversed).
    #[getter]
    fn directions<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        matrix(py, &self.job.toolpath.directions())
    }

    /// Layer index of each waypoint (N,).
    #[getter]
    fn layer<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<i64>> {
        let v: Vec<i64> = self.job.toolpath.iter().map(|(k, _)| k as i64).collect();
        v.into_pyarray(py)
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

    /// Names of the layers whose nozzle axes were reversed on loading.
    #[getter]
    fn flipped_layers(&self) -> Vec<String> {
        self.job.flipped_names()
    }

    /// Each waypoint's cutoff (N,): a pose at waypoint i is checked
    /// against what was printed before it.
    #[getter]
    fn cutoffs<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<u32>> {
        let n = self.job.toolpath.waypoint_count();
        (0..n).map(cutoff).collect::<Vec<u32>>().into_pyarray(py)
    }

    /// Every waypoint's head pose (N, 4, 4) as `check` poses it: the
    /// machine's kinematics, direct IK, C unwound along each run (the
    /// pose `plan` reports as its input). A pose maps head coordinates
    /// to the part frame: `x_part = R @ x_head + tip`.
    fn poses<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray3<f64>> {
        let tp = &self.job.toolpath;
        let axes = input_axes(
            &self.machine,
            &tp.positions(),
            &tp.directions(),
            &runs(tp, PlanOptions::default().jump),
        );
        let poses: Vec<Pose> = axes.iter().map(|a| self.machine.pose(a)).collect();
        pose_array(py, &poses)
    }

    /// `bench`'s queries: about `count` poses (waypoints evenly strided,
    /// each in its own orientation and `tilts` variants tilted 15°, 30°,
    /// 45°, 60° at fixed pseudo-random azimuths) and their cutoffs, as
    /// `(poses (N, 4, 4), cutoffs (N,))`.
    #[pyo3(signature = (count=20_000, tilts=3))]
    fn sample_poses<'py>(
        &self,
        py: Python<'py>,
        count: usize,
        tilts: usize,
    ) -> (Bound<'py, PyArray3<f64>>, Bound<'py, PyArray1<u32>>) {
        let q = tilted_queries(&self.job.scene.waypoint_queries, count, tilts);
        let poses: Vec<Pose> = q.iter().map(|q| q.pose).collect();
        let cutoffs: Vec<u32> = q.iter().map(|q| q.cutoff).collect();
        (pose_array(py, &poses), cutoffs.into_pyarray(py))
    }

    fn __repr__(&self) -> String {
        format!(
            "Scene({}, {} waypoints, {} triangles, part: {})",
            self.job.source,
            self.job.toolpath.waypoint_count(),
            self.job.scene.triangle_count(),
            self.job.scene.part.name()
        )
    }
}

/// Rows as an (N, 3) array.
pub fn matrix<'py>(py: Python<'py>, v: &[[f64; 3]]) -> Bound<'py, PyArray2<f64>> {
    let flat: Vec<f64> = v.iter().flatten().copied().collect();
    Array2::from_shape_vec((v.len(), 3), flat)
        .expect("N×3")
        .into_pyarray(py)
}

/// Poses as (N, 4, 4) homogeneous transforms.
fn pose_array<'py>(py: Python<'py>, poses: &[Pose]) -> Bound<'py, PyArray3<f64>> {
    let mut flat = Vec::with_capacity(poses.len() * 16);
    for p in poses {
        for i in 0..3 {
            flat.extend((0..3).map(|j| p.cols[j][i] as f64));
            flat.push(p.tip[i] as f64);
        }
        flat.extend([0.0, 0.0, 0.0, 1.0]);
    }
    Array3::from_shape_vec((poses.len(), 4, 4), flat)
        .expect("N×4×4")
        .into_pyarray(py)
}

/// `poses` as the evaluator takes them: (N, 4, 4) transforms, or a pair
/// (tips (N, 3), nozzle axes (N, 3)), each axis posed by the minimal
/// rotation from +z.
fn parse_poses(poses: &Bound<'_, PyAny>) -> PyResult<Vec<Pose>> {
    if let Ok((tips, axes)) = poses.extract::<(Bound<'_, PyAny>, Bound<'_, PyAny>)>() {
        let tips = rows::<3>(&tips, "tips")?;
        let axes = rows::<3>(&axes, "directions")?;
        if tips.len() != axes.len() {
            return Err(usage("poses: give as many directions as tips"));
        }
        return Ok(tips
            .iter()
            .zip(&axes)
            .map(|(t, a)| Pose::from_axis(t.map(|c| c as f32), a.map(|c| c as f32)))
            .collect());
    }
    let (shape, v) = inputs::floats(poses, "poses")?;
    if shape.len() != 3 || shape[1] != 4 || shape[2] != 4 {
        return Err(usage(format!(
            "poses: expected (N, 4, 4) transforms or (tips, directions), got shape {shape:?}"
        )));
    }
    Ok(v.chunks_exact(16)
        .map(|m| Pose {
            cols: std::array::from_fn(|j| std::array::from_fn(|i| m[i * 4 + j] as f32)),
            tip: std::array::from_fn(|i| m[i * 4 + 3] as f32),
        })
        .collect())
}

/// A collision evaluator over a scene: `collides` answers, for each pose
/// of the head, whether it comes within the margin of the platform or of
/// the part printed before its cutoff.
#[pyclass(frozen, module = "maamplan")]
pub struct Evaluator {
    // Declared first, dropped first: it borrows `job`'s scene.
    backend: Box<dyn Backend + Send + 'static>,
    job: Arc<LoadedJob>,
    margin: f64,
}

#[pymethods]
impl Evaluator {
    /// The evaluator `backend` ("auto": a hardware GPU when present,
    /// else the CPU; "gpu", any adapter, software ones included; "cpu";
    /// "parry", the reference) over `scene`, built once.
    #[new]
    #[pyo3(signature = (scene, backend="auto"))]
    fn new(py: Python<'_>, scene: &Bound<'_, Scene>, backend: &str) -> PyResult<Self> {
        let kind = inputs::backend(backend)?;
        let scene = scene.get();
        let job = scene.job.clone();
        let built = py
            .detach(|| kind.build(&job.scene, false))
            .map_err(|e| raise(&e))?;
        // SAFETY: the backend borrows `job.scene`, which lives on the heap
        // behind the `Arc` this evaluator holds, is never changed, and is
        // dropped only after the backend (fields drop in order).
        let backend: Box<dyn Backend + Send + 'static> = unsafe { std::mem::transmute(built) };
        Ok(Evaluator {
            backend,
            job,
            margin: scene.machine.margin,
        })
    }

    /// The backend's name ("gpu", "cpu" or "parry").
    #[getter]
    fn backend(&self) -> &'static str {
        self.backend.name()
    }

    /// One line on the backend's work so far (the gpu's: batches, exact
    /// tests), or None.
    fn summary(&self) -> Option<String> {
        self.backend.summary()
    }

    /// For each pose, does the head come closer than `margin` mm (None:
    /// the machine's, 0.05) to the platform or to the part printed
    /// before its cutoff? `poses`: (N, 4, 4) transforms (`Scene.poses()`)
    /// or a pair (tips (N, 3), nozzle axes (N, 3)); `cutoffs` (N,)
    /// (`Scene.cutoffs`; None: the whole part). `progress(stage, done,
    /// total)` hears each batch. Returns a bool array (N,).
    #[pyo3(signature = (poses, cutoffs=None, margin=None, progress=None))]
    fn collides<'py>(
        &self,
        py: Python<'py>,
        poses: &Bound<'py, PyAny>,
        cutoffs: Option<&Bound<'py, PyAny>>,
        margin: Option<f64>,
        progress: Option<Py<PyAny>>,
    ) -> PyResult<Bound<'py, PyArray1<bool>>> {
        let poses = parse_poses(poses)?;
        let cut = match cutoffs.filter(|c| !c.is_none()) {
            None => vec![u32::MAX; poses.len()],
            Some(c) => {
                let (shape, v) = inputs::floats(c, "cutoffs")?;
                if shape != [poses.len()] || v.iter().any(|x| !(*x >= 0.0 && x.fract() == 0.0)) {
                    return Err(usage(
                        "cutoffs: expected (N,) non-negative integers, one per pose",
                    ));
                }
                v.iter().map(|&x| x.min(u32::MAX as f64) as u32).collect()
            }
        };
        let margin = margin.unwrap_or(self.margin);
        if !(margin.is_finite() && margin >= 0.0) {
            return Err(usage("margin must be a finite, non-negative length (mm)"));
        }
        let queries: Vec<Query> = poses
            .iter()
            .zip(&cut)
            .map(|(p, &c)| Query {
                pose: *p,
                cutoff: c,
                margin: margin as f32,
                slope: 0.0,
            })
            .collect();
        let tell = Callback::new(progress);
        tell.stage("collides");
        let backend = self.backend.as_ref();
        let verdicts = py.detach(|| {
            let mut out = Vec::with_capacity(queries.len());
            for chunk in queries.chunks(backend.batch_hint()) {
                out.extend(backend.evaluate(chunk)?);
                tell.queries(out.len() as u64, queries.len() as u64);
            }
            Ok::<_, maamplan::collide::CollideError>(out)
        });
        tell.finish()?;
        let verdicts = verdicts.map_err(|e| raise(&e))?;
        let _ = &self.job;
        Ok(verdicts.into_pyarray(py))
    }

    fn __repr__(&self) -> String {
        format!("Evaluator(backend={:?})", self.backend.name())
    }
}

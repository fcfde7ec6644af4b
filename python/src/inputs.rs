//! Python arguments as the library takes them: paths, or meshes and
//! toolpaths given as arrays written to files the library then reads
//! exactly as it reads a user's (the same conventions, the same errors),
//! the machine, the backend, the part model.

use crate::{raise, usage};
use maamplan::collide::choice::BackendKind;
use maamplan::geometry::Mesh;
use maamplan::io::toolpath_folder::mesh_obj;
use maamplan::io::Placement;
use maamplan::job::JobSpec;
use maamplan::kinematics::{load_machine, Machine};
use maamplan::scene::{BeadSettings, PartModel};
use numpy::{PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;
use std::path::PathBuf;
use std::sync::Arc;
use tempfile::TempDir;

/// Files written for arrays, kept while anything made from them lives.
pub type Scratch = Arc<TempDir>;

/// A new scratch folder.
pub fn scratch() -> PyResult<Scratch> {
    tempfile::Builder::new()
        .prefix("maamplan-py-")
        .tempdir()
        .map(Arc::new)
        .map_err(|e| usage(format!("cannot create a scratch folder: {e}")))
}

/// `obj` as an `(N, K)` array of float64 rows.
pub fn rows<const K: usize>(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<[f64; K]>> {
    let flat = floats(obj, what)?;
    let (shape, values) = flat;
    if shape.len() != 2 || shape[1] != K {
        return Err(usage(format!(
            "{what}: expected an (N, {K}) array, got shape {shape:?}"
        )));
    }
    Ok(values
        .chunks_exact(K)
        .map(|c| std::array::from_fn(|i| c[i]))
        .collect())
}

/// `obj` (any array-like) as float64: its shape and values in C order.
pub fn floats(obj: &Bound<'_, PyAny>, what: &str) -> PyResult<(Vec<usize>, Vec<f64>)> {
    let np = obj.py().import("numpy")?;
    let a = np
        .call_method1("ascontiguousarray", (obj, "float64"))
        .map_err(|e| usage(format!("{what}: not an array of numbers ({e})")))?;
    let a: PyReadonlyArrayDyn<'_, f64> = a.extract()?;
    let shape = a.shape().to_vec();
    let values = a.as_slice()?.to_vec();
    Ok((shape, values))
}

/// A mesh argument: a path, `(vertices, faces)` or an object with
/// `vertices` and `faces` (a trimesh.Trimesh), as a path the library
/// reads; arrays are written as OBJ into `scratch`.
pub fn mesh_path(
    obj: Option<&Bound<'_, PyAny>>,
    what: &str,
    scratch: &Scratch,
) -> PyResult<Option<PathBuf>> {
    let Some(obj) = obj.filter(|o| !o.is_none()) else {
        return Ok(None);
    };
    if let Ok(p) = obj.extract::<PathBuf>() {
        return Ok(Some(p));
    }
    let (v, f) = if obj.hasattr("vertices")? && obj.hasattr("faces")? {
        (obj.getattr("vertices")?, obj.getattr("faces")?)
    } else {
        obj.extract::<(Bound<'_, PyAny>, Bound<'_, PyAny>)>()
            .map_err(|_| {
                usage(format!(
                    "{what}: give a mesh file, (vertices, faces) arrays or a trimesh.Trimesh"
                ))
            })?
    };
    let vertices = rows::<3>(&v, &format!("{what} vertices"))?;
    let faces = rows::<3>(&f, &format!("{what} faces"))?;
    let n = vertices.len() as f64;
    if faces
        .iter()
        .flatten()
        .any(|&i| !(i >= 0.0 && i < n && i.fract() == 0.0))
    {
        return Err(usage(format!(
            "{what} faces: every index must name one of its {n} vertices"
        )));
    }
    let mesh = Mesh {
        vertices: vertices.iter().map(|p| p.map(|c| c as f32)).collect(),
        triangles: faces.iter().map(|t| t.map(|i| i as u32)).collect(),
    };
    let path = scratch.path().join(format!("{what}.obj"));
    std::fs::write(&path, mesh_obj(&mesh))
        .map_err(|e| usage(format!("{}: cannot write ({e})", path.display())))?;
    Ok(Some(path))
}

/// `machine`: a machine file, or None for the built-in machine.
pub fn machine(path: Option<PathBuf>) -> PyResult<Machine> {
    match path {
        Some(p) => load_machine(&p).map_err(|e| raise(&e)),
        None => Ok(Machine::default()),
    }
}

/// The margin to check at: `margin`, else the machine file's; within the
/// command line's range.
pub fn margin(machine: &Machine, margin: Option<f64>) -> PyResult<f64> {
    let m = margin.unwrap_or(machine.margin);
    if !(m.is_finite() && (0.0..10.0).contains(&m)) {
        return Err(usage("margin must be between 0 and 10 mm"));
    }
    Ok(m)
}

/// `backend="auto"|"gpu"|"cpu"|"parry"`.
pub fn backend(name: &str) -> PyResult<BackendKind> {
    Ok(match name {
        "auto" => BackendKind::Auto,
        "gpu" => BackendKind::Gpu,
        "cpu" => BackendKind::Cpu,
        "parry" => BackendKind::Parry,
        _ => {
            return Err(usage(format!(
                "backend must be auto, gpu, cpu or parry, not {name:?}"
            )))
        }
    })
}

/// `part="auto"|"surfaces"|"beads"`.
pub fn part(name: &str) -> PyResult<PartModel> {
    Ok(match name {
        "auto" => PartModel::Auto,
        "surfaces" => PartModel::Surfaces,
        "beads" => PartModel::Beads,
        _ => {
            return Err(usage(format!(
                "part must be auto, surfaces or beads, not {name:?}"
            )))
        }
    })
}

/// What every command takes (the command line's common options): the
/// toolpath, head and platform as paths, how the toolpath is placed, the
/// clearance and the part model.
#[derive(Clone)]
pub struct JobInputs {
    /// Toolpath folder, waypoint file or program (None: the built-in job).
    pub toolpath: Option<PathBuf>,
    /// What reports call the toolpath when it was given as arrays.
    pub label: Option<String>,
    /// Head mesh.
    pub head: Option<PathBuf>,
    /// Platform mesh.
    pub platform: Option<PathBuf>,
    /// `place` and `y_up`.
    pub placement: Placement,
    /// `clearance` (mm).
    pub clearance: f32,
    /// `keep_normals`.
    pub keep_normals: bool,
    /// `tilt` (degrees).
    pub tilt: Option<f64>,
    /// `part`.
    pub part: PartModel,
    /// Files written for arrays.
    pub _scratch: Vec<Scratch>,
}

impl JobInputs {
    /// The job for `machine`, as the command line's `SceneArgs::spec`
    /// makes it.
    pub fn spec(&self, machine: &Machine) -> PyResult<JobSpec> {
        if let Some(t) = self.tilt {
            if !t.is_finite() {
                return Err(usage("tilt must be a finite angle (degrees)"));
            }
        }
        Ok(JobSpec {
            toolpath: self.toolpath.clone(),
            head: self.head.clone(),
            platform: self.platform.clone(),
            placement: self.placement,
            clearance: self.clearance,
            keep_normals: self.keep_normals,
            tilt_deg: self.tilt,
            part: self.part,
            beads: BeadSettings::of_machine(machine),
            reach: Some(machine.reach()),
            machine: machine.clone(),
        })
    }
}

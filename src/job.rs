//! A loaded job: the toolpath (with the data set's input conventions
//! applied), the head, the platform and the scene built from them. Every
//! command and the tests load inputs through [`LoadedJob::load`], so they
//! all see the same poses.
//!
//! Conventions applied on loading (README, "Input formats"):
//! - `--y-up` rotation and `--place` translation ([`Placement`]);
//! - optional `--tilt` of every nozzle direction about x (a stress test);
//! - the per-layer flip: a layer in which more than 20 % of the nozzle
//!   directions point down is reversed as a whole, as the data set's
//!   original software does ([`Toolpath::flip_downward_layers`]), unless
//!   [`JobSpec::keep_normals`] is set.

use crate::default_job;
use crate::geometry::{Aabb, Mesh};
use crate::io::mesh::load_mesh;
use crate::io::toolpath_folder::load_toolpath;
use crate::io::{InputError, Placement};
use crate::kinematics::Machine;
use crate::plan::{PlanOptions, Prepared};
use crate::program_toolpath::{looks_like_program, ProgramToolpath};
use crate::scene::{
    beads, BeadSettings, HeadConfig, PartGroup, PartModel, Scene, SceneConfig, SceneError,
};
use crate::toolpath::Toolpath;
use std::path::PathBuf;
use std::time::Instant;

/// What can go wrong loading a job.
#[derive(Debug, thiserror::Error)]
pub enum JobError {
    /// An input file is missing or malformed.
    #[error(transparent)]
    Input(#[from] InputError),
    /// The scene cannot be built from the inputs (e.g. an open head).
    #[error("building the scene (head {head}): {source}")]
    Scene {
        /// The head's file, or `default`.
        head: String,
        /// Why.
        source: SceneError,
    },
    /// A setting is out of range.
    #[error("{0}")]
    Setting(String),
}

/// Where a job's inputs come from and how to place them.
#[derive(Clone, Debug, Default)]
pub struct JobSpec {
    /// Toolpath folder or waypoint file; `None`: the embedded default job.
    pub toolpath: Option<PathBuf>,
    /// Head mesh; `None`: the default job's head (or a 45° cone).
    pub head: Option<PathBuf>,
    /// Platform mesh; `None`: the default job's plate (or a plate under the part).
    pub platform: Option<PathBuf>,
    /// Y-up rotation and translation of the toolpath and its layers.
    pub placement: Placement,
    /// Contact within this distance of the tip, along the nozzle axis, is
    /// ignored (mm).
    pub clearance: f32,
    /// Keep layers whose normals point down as stored (no per-layer flip).
    pub keep_normals: bool,
    /// Rotate every nozzle direction by this many degrees about x first.
    pub tilt_deg: Option<f64>,
    /// What the part is modelled from.
    pub part: PartModel,
    /// How beads are made where the part is modelled from them (the
    /// machine's extrusion).
    pub beads: BeadSettings,
    /// The machine's reach ([`crate::kinematics::Machine::reach`]):
    /// waypoints farther from the origin are out of range in every
    /// orientation, so they size nothing (the default plate, the
    /// contact tolerance); a typo far away costs nothing. `None`: no
    /// bound.
    pub reach: Option<f64>,
    /// The machine a G-code program given as the toolpath is read for.
    pub machine: Machine,
}

/// A job loaded from its [`JobSpec`]: the toolpath with the conventions
/// applied and the scene built from it, head and platform.
#[derive(Clone, Debug)]
pub struct LoadedJob {
    /// What the user named (for messages and reports).
    pub source: String,
    /// The toolpath, conventions applied.
    pub toolpath: Toolpath,
    /// The scene.
    pub scene: Scene,
    /// Layers whose nozzle directions were reversed by the flip convention.
    pub flipped_layers: Vec<usize>,
    /// Were the layers found from how the beads stack ([`stacked`]), the
    /// axes reversed one by one where they point into the material?
    pub layers_found: bool,
    /// Seconds spent loading and building.
    pub seconds: f64,
    /// A program given as the toolpath: the distance that separates its
    /// sections ([`ProgramToolpath::sections`]).
    pub jump: Option<f64>,
}

impl LoadedJob {
    /// Load the inputs of `spec`, apply the conventions and build the scene.
    pub fn load(spec: &JobSpec) -> Result<LoadedJob, JobError> {
        Ok(LoadedJob::load_beside(spec, |_, _| ())?.0)
    }

    /// [`LoadedJob::load`], running `beside` on the toolpath (conventions
    /// applied) and a program's section distance ([`LoadedJob::jump`])
    /// while the scene is built: work that needs only the toolpath fills
    /// the cores the scene's build leaves idle.
    pub fn load_beside<T: Send>(
        spec: &JobSpec,
        beside: impl FnOnce(&Toolpath, Option<f64>) -> T + Send,
    ) -> Result<(LoadedJob, T), JobError> {
        let t0 = Instant::now();
        if !(spec.clearance >= 0.0 && spec.clearance.is_finite()) {
            return Err(JobError::Setting(
                "--clearance must be a finite number ≥ 0 (mm)".into(),
            ));
        }
        let place = &spec.placement;
        let mut program = None;
        let (source, mut toolpath, default_head, default_platform) = match &spec.toolpath {
            Some(p) if p.is_file() && looks_like_program(p) => {
                let pt = ProgramToolpath::load(p, &spec.machine)?.placed(place);
                let tp = pt.toolpath.clone();
                program = Some(pt);
                (p.display().to_string(), tp, None, None)
            }
            Some(p) => (
                p.display().to_string(),
                load_toolpath(p, place)?,
                None,
                None,
            ),
            None => {
                let (tp, head, platform) = placed_default_job(place);
                (
                    "embedded default".to_string(),
                    tp,
                    Some(head),
                    Some(platform),
                )
            }
        };
        if let Some(deg) = spec.tilt_deg {
            toolpath.tilt_directions(deg);
            if let Some(pt) = &mut program {
                pt.toolpath.tilt_directions(deg);
            }
        }
        let platform = match &spec.platform {
            Some(p) => load_mesh(p)?,
            None => default_platform.unwrap_or_else(|| plate_under(&toolpath, spec.reach)),
        };
        let layers_unknown = toolpath.layers.len() == 1 && toolpath.layers[0].surface.is_none();
        let mut deposited = None;
        let mut jump = None;
        // A program's nozzle directions are the machine's: none is flipped.
        let flipped_layers = if let Some(pt) = &program {
            let d = pt.deposit(&platform, &spec.beads, &spec.machine);
            jump = Some(pt.sections(&d.toolpath).jump);
            (toolpath, deposited) = (d.toolpath, Some(d.groups));
            Vec::new()
        } else if layers_unknown && spec.part != PartModel::Surfaces {
            let (stacked, flipped, beads) =
                stacked(&toolpath, &platform, &spec.beads, !spec.keep_normals);
            (toolpath, deposited) = (stacked, Some(beads));
            flipped
        } else if spec.keep_normals {
            Vec::new()
        } else {
            toolpath.flip_downward_layers()
        };
        let head = match &spec.head {
            Some(p) => load_mesh(p)?,
            None => default_head.unwrap_or_else(default_job::default_head),
        };
        let cfg = SceneConfig {
            reach: spec.reach.map(|r| r as f32),
            ..scene_config(spec.clearance, spec.part, spec.beads)
        };
        let (scene, beside_result) = rayon::join(
            || Scene::build_deposited(&toolpath, &head, &platform, &cfg, deposited),
            || beside(&toolpath, jump),
        );
        let deposited_found = layers_unknown && spec.part != PartModel::Surfaces;
        let scene = scene.map_err(|source| JobError::Scene {
            head: spec
                .head
                .as_ref()
                .map_or("default".into(), |p| p.display().to_string()),
            source,
        })?;
        let job = LoadedJob {
            source,
            toolpath,
            scene,
            flipped_layers,
            layers_found: deposited_found,
            seconds: t0.elapsed().as_secs_f64(),
            jump,
        };
        Ok((job, beside_result))
    }

    /// Load `spec` to be planned for `machine` with `opts`: the planner's
    /// first stages ([`Prepared::new`]) run on the toolpath while the
    /// scene is built, and a program given as the toolpath has its
    /// sections as far apart as its travels (`opts.jump` becomes that
    /// distance, as the planner must then use it).
    pub fn load_prepared(
        spec: &JobSpec,
        machine: &Machine,
        opts: &mut PlanOptions,
    ) -> Result<(LoadedJob, Prepared), JobError> {
        let (job, prepared) = LoadedJob::load_beside(spec, |toolpath, jump| {
            let opts = PlanOptions {
                jump: jump.unwrap_or(opts.jump),
                ..*opts
            };
            Prepared::new(toolpath, machine, &opts)
        })?;
        if let Some(jump) = job.jump {
            opts.jump = jump;
        }
        Ok((job, prepared))
    }

    /// Why [`LoadedJob::flipped_layers`] were reversed, as messages say it.
    pub fn flip_reason(&self) -> &'static str {
        if self.layers_found {
            "holding nozzle axes that pointed into the material below"
        } else {
            "that mostly pointed down"
        }
    }

    /// Names of the flipped layers.
    pub fn flipped_names(&self) -> Vec<String> {
        self.flipped_layers
            .iter()
            .map(|&k| self.toolpath.layers[k].name.clone())
            .collect()
    }
}

/// The embedded default job's toolpath (its layers' surfaces too) moved
/// by `place`, its head and its platform.
fn placed_default_job(place: &Placement) -> (Toolpath, Mesh, Mesh) {
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
    (tp, job.head, job.platform)
}

/// A toolpath given without its layers (one layer, no surface: a single
/// file of waypoints in print order) with the layers its beads stack in
/// ([`beads::stacked_layers`]), and — with `flip` — every nozzle axis
/// that points into the material below reversed (the data set's
/// convention reverses whole layers stored upside down; without layers,
/// the material says which way is up). Returns the layers holding a
/// reversed axis too, and the beads laid along it, a group per layer.
pub fn stacked(
    toolpath: &Toolpath,
    platform: &Mesh,
    settings: &BeadSettings,
    flip: bool,
) -> (Toolpath, Vec<usize>, Vec<PartGroup>) {
    let held = beads::HeldPath::of(toolpath);
    let stacking = beads::stacked_layers(held.path(), platform, settings);
    let mut out = toolpath.relayered(&stacking.layer_of);
    let mut flipped = Vec::new();
    if flip {
        let mut g = 0;
        for (k, l) in out.layers.iter_mut().enumerate() {
            for w in &mut l.waypoints {
                if stacking.against[g] {
                    w.dir = w.dir.map(|c| -c);
                    if flipped.last() != Some(&k) {
                        flipped.push(k);
                    }
                }
                g += 1;
            }
        }
    }
    (out, flipped, stacking.deposit.groups)
}

/// The scene settings of a loaded job: contact within `clearance` of the
/// tip, along the nozzle, ignored; the head's data cached between runs;
/// the part modelled as `part` says, beads made as `beads` says; every
/// waypoint sizes the scene (a job's spec bounds that by the machine's
/// reach).
pub fn scene_config(clearance: f32, part: PartModel, beads: BeadSettings) -> SceneConfig {
    SceneConfig {
        head: HeadConfig {
            tip_clearance: clearance,
            ..HeadConfig::default()
        },
        max_edge: None,
        head_cache: true,
        part,
        beads,
        reach: None,
    }
}

/// A flat plate whose top is at the toolpath's lowest point, 100 mm wider
/// than the part on every side: the part of the waypoints within `reach`
/// of the origin (mm; `None`: all), or all where none is.
pub fn plate_under(tp: &Toolpath, reach: Option<f64>) -> Mesh {
    let within = |p: &[f32; 3]| {
        reach.is_none_or(|r| f64::from(p[0]).hypot(p[1].into()).hypot(p[2].into()) <= r)
    };
    let mut pts: Vec<[f32; 3]> = tp.iter().map(|(_, w)| w.pos).filter(within).collect();
    if pts.is_empty() {
        pts = tp.iter().map(|(_, w)| w.pos).collect();
    }
    let b = Aabb::from_points(&pts);
    default_job::box_mesh(
        [b.min[0] - 100.0, b.min[1] - 100.0, b.min[2] - 5.0],
        [b.max[0] + 100.0, b.max[1] + 100.0, b.min[2]],
    )
}

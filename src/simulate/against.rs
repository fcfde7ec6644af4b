//! What a program is simulated against, with the timeline that says which
//! of it exists during each line: a job's layer surfaces printed in the
//! program's own order, or without a toolpath the beads the program lays
//! itself. The command line and the Python binding both set a simulation
//! up through these.

use super::{own_part, platform_under, timeline, Timeline};
use crate::geometry::Mesh;
use crate::io::gcode_read::Program;
use crate::job::{scene_config, LoadedJob};
use crate::kinematics::Machine;
use crate::scene::{BeadSettings, PartModel, Scene, SceneError};
use crate::toolpath::Toolpath;

/// The part a program is checked against.
pub struct Against {
    /// What it is, as messages and reports name it.
    pub source: String,
    /// Its toolpath (the job's, or the program's own in its layers).
    pub toolpath: Toolpath,
    /// The scene, stamped in the program's order.
    pub scene: Scene,
    /// Which material exists during each line.
    pub timeline: Timeline,
}

/// The job's toolpath and layer surfaces, printed in `program`'s order
/// ([`timeline()`]): the scene restamped so.
pub fn job(job: LoadedJob, machine: &Machine, program: &Program) -> Against {
    let mut scene = job.scene;
    let timeline = timeline(machine, &job.toolpath, &program.moves);
    scene.restamp(|s| timeline.stamp(s));
    Against {
        source: job.source,
        toolpath: job.toolpath,
        scene,
        timeline,
    }
}

/// Without a toolpath: the beads `program` lays itself ([`own_part()`]) on
/// `platform` (`None`: a plate under its lowest tip, [`platform_under`]),
/// `head` posed with `clearance` (mm) at its tip, the part modelled as
/// `part` says.
pub fn own(
    program: &Program,
    machine: &Machine,
    head: &Mesh,
    platform: Option<Mesh>,
    clearance: f32,
    part: PartModel,
) -> Result<Against, SceneError> {
    let settings = BeadSettings::of_machine(machine);
    // A plate under the part: its toolpath says where that is.
    let platform = platform.unwrap_or_else(|| platform_under(program, machine));
    let part_laid = own_part(program, machine, &platform, &settings);
    let scene = Scene::build_deposited(
        &part_laid.toolpath,
        head,
        &platform,
        &scene_config(clearance, part, settings),
        Some(part_laid.groups),
    )?;
    Ok(Against {
        source: format!("the part it deposits ({})", scene.part.name()),
        toolpath: part_laid.toolpath,
        scene,
        timeline: part_laid.timeline,
    })
}

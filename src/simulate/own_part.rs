//! The part a program lays by itself: without a toolpath, a program's own
//! extrusions are the part it is checked against. Its toolpath is
//! recovered through the machine's kinematics ([`ProgramToolpath`]), its
//! layers from the layer-change comments or from how its beads stack, and
//! a bead is laid along every segment it extrudes along — not along those
//! it crosses without filament — stamped in the order it prints them.

use super::Timeline;
use crate::geometry::Mesh;
use crate::io::gcode_read::{axes_of, Program};
use crate::job::plate_under;
use crate::kinematics::Machine;
use crate::program_toolpath::ProgramToolpath;
use crate::scene::{BeadSettings, PartGroup};
use crate::toolpath::{Layer, Toolpath, Waypoint};

/// What a program deposits, and when.
#[derive(Clone, Debug)]
pub struct OwnPart {
    /// The program's toolpath in its layers.
    pub toolpath: Toolpath,
    /// Its beads, a group per layer, stamped by the waypoint each ends at
    /// ([`crate::scene::Scene::build_deposited`] takes them as they are).
    pub groups: Vec<PartGroup>,
    /// Which beads exist during each line of the program.
    pub timeline: Timeline,
}

/// The part `program` lays on `platform` on machine `m`, beads made as
/// `s` says (their gap widened to every segment the program prints).
pub fn own_part(program: &Program, m: &Machine, platform: &Mesh, s: &BeadSettings) -> OwnPart {
    let pt = ProgramToolpath::of(program, m);
    let deposited = pt.deposit(platform, s, m);
    let layer_of: Vec<usize> = deposited.toolpath.iter().map(|(k, _)| k).collect();
    OwnPart {
        timeline: Timeline::of_program(&pt, &layer_of, &program.moves),
        groups: pt.printed_only(deposited.groups),
        toolpath: deposited.toolpath,
    }
}

/// A plate under the part `program` prints on machine `m` (its lowest
/// printed tip), or under its lowest tip when it prints nothing.
pub fn platform_under(program: &Program, m: &Machine) -> Mesh {
    let tp = ProgramToolpath::of(program, m).toolpath;
    if tp.waypoint_count() > 0 {
        return plate_under(&tp, Some(m.reach()));
    }
    let waypoints = program
        .moves
        .iter()
        .map(|mv| Waypoint {
            pos: m.tip(&axes_of(&mv.to)).map(|x| x as f32),
            dir: [0.0, 0.0, 1.0],
        })
        .collect();
    plate_under(
        &Toolpath {
            layers: vec![Layer {
                waypoints,
                ..Layer::default()
            }],
        },
        Some(m.reach()),
    )
}

//! The part a program lays by itself: without a toolpath, a program's own
//! extrusions are the part it is checked against. Its toolpath is
//! recovered through the machine's kinematics ([`ProgramToolpath`]), its
//! layers from the layer-change comments or from how its beads stack, and
//! a bead is laid along every segment it extrudes along — not along those
//! it crosses without filament — stamped in the order it prints them.

use super::Timeline;
use crate::geometry::Mesh;
use crate::io::gcode_read::Program;
use crate::kinematics::Machine;
use crate::program_toolpath::ProgramToolpath;
use crate::scene::{BeadSettings, PartGroup};
use crate::toolpath::Toolpath;

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

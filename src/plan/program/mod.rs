//! Stage 6, the machine program: every move the machine makes, in order,
//! with the material present during it — so that the program can be
//! checked move by move exactly as it is written, and then written.
//!
//! A program is a list of [`Step`]s. Printing a section is a run of
//! [`MoveKind::Print`] moves (each bead segment split by
//! [`NearestLayer::bead_moves`] where joint-linear interpolation would
//! bow the tip off the bead); getting from one section to the next (or
//! across a break, or at the start and end) is a [`Travel`]: retract, lift
//! to a safe height, tool change if the next layer needs the other
//! extruder, travel (C the shorter way round unless the machine limits C),
//! lower, prime, approach along the nozzle. A travel whose moves cannot be
//! proven free is re-planned higher, or with the rotation done before the
//! horizontal move, before it is given up (and counted). The [`Assembly`]
//! builds it (`assembly`).
//!
//! [`NearestLayer::bead_moves`]: crate::plan::layer_reading::NearestLayer::bead_moves

mod assembly;

pub use assembly::{failing_steps, Assembly};

use super::graph::Route;
use super::setup::{distance, Setup};
use super::PlanError;
use crate::kinematics::{round_written, Axes, Machine, ToolSettings};
use crate::prove::{MoveSpec, Prover};
use crate::scene::Scene;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// What a move is for (the G-code writer and the reports use it).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum MoveKind {
    /// Extruding along the bead.
    Print,
    /// Filament pulled back (no motion).
    Retract,
    /// Filament pushed back before printing resumes (no motion).
    Prime,
    /// Straight up off the part.
    Lift,
    /// At the safe height to above the next waypoint (rotary axes included).
    Travel,
    /// Down to the approach height above the next waypoint.
    Lower,
    /// Along the nozzle onto the next waypoint.
    Approach,
}

impl MoveKind {
    /// Does the machine extrude while making this move?
    pub fn extrudes(self) -> bool {
        self == MoveKind::Print
    }
}

/// One line of motion (or of extruder motion).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Move {
    /// What it is for.
    pub kind: MoveKind,
    /// Machine axes at the end (as written; tool offset not applied).
    pub to: Axes,
    /// Extruder position at the end (mm of filament, absolute within the layer).
    pub e: f64,
    /// Feed (mm/s): of the tip for printing, of the axes for travel, of the
    /// filament for retract and prime.
    pub feed: f64,
    /// Material with `stamp < cutoff` exists during the move.
    pub cutoff: u32,
    /// The waypoint this move ends at, for print moves that end on one and
    /// approaches.
    pub waypoint: Option<usize>,
    /// X/Y offset of the active nozzle, subtracted when written (mm).
    pub offset: [f64; 2],
}

impl Move {
    /// The motion from `from` to this move's end, as the prover proves it.
    pub fn spec_from(&self, from: Axes) -> MoveSpec {
        MoveSpec {
            from,
            to: self.to,
            cutoff: self.cutoff,
        }
    }
}

/// Getting from one printed point to the next section (or across a break).
#[derive(Clone, Debug, PartialEq)]
pub struct Travel {
    /// Where the head is.
    pub from: Axes,
    /// The next waypoint's axes.
    pub to: Axes,
    /// The next waypoint (`None` for the final park).
    pub waypoint: Option<usize>,
    /// Extruder position at `from`.
    pub e_from: f64,
    /// Extruder position to resume printing at (after a layer's reset: 0).
    pub e_to: f64,
    /// Pull the filament back first (not at the program's start).
    pub retract: bool,
    /// A new layer starts: reset E and prime the layer's extra filament.
    pub new_layer: bool,
    /// Switch to this extruder at the safe height.
    pub tool_change: Option<ToolSettings>,
    /// Machine Z of the travel (mm).
    pub height: f64,
    /// Turn the rotary axes before moving horizontally, instead of together.
    pub rotate_first: bool,
    /// Material present while leaving `from`.
    pub lift_cutoff: u32,
    /// Material present for the rest of the travel.
    pub cutoff: u32,
    /// Nozzle offset before and after the tool change.
    pub offsets: [[f64; 2]; 2],
}

/// One step of the program.
#[derive(Clone, Debug, PartialEq)]
pub enum Step {
    /// A move.
    Move(Move),
    /// A travel (expands to several moves, see [`Travel::items`]); boxed,
    /// as travels are few and a `Travel` is more than twice a `Move`: a
    /// program is mostly print moves, and unboxed every step would take a
    /// travel's size.
    Travel(Box<Travel>),
}

/// The whole program.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Program {
    /// Machine axes at the start (home).
    pub home: Axes,
    /// Tool and temperature selected at the start.
    pub first_tool: Option<ToolSettings>,
    /// Steps in order.
    pub steps: Vec<Step>,
}

/// What one travel expands to, in order: moves, and where the tool change
/// and the extruder reset fall between them.
#[derive(Clone, Debug, PartialEq)]
pub enum TravelItem {
    /// A move.
    Move(Move),
    /// Select this tool and wait for its temperature.
    ToolChange(ToolSettings),
    /// Reset the extruder position to 0 (a new layer's E starts there).
    ResetE,
}

impl Travel {
    /// The moves of this travel on machine `m`.
    pub fn items(&self, m: &Machine) -> Vec<TravelItem> {
        let t = &m.travel;
        let mut out = Vec::new();
        let mv = |kind, to: Axes, e, feed, cutoff, offset| {
            TravelItem::Move(Move {
                kind,
                to,
                e,
                feed,
                cutoff,
                waypoint: None,
                offset,
            })
        };
        let [off0, off1] = self.offsets;
        let mut e = self.e_from;
        if self.retract {
            e -= t.retract;
            out.push(mv(
                MoveKind::Retract,
                self.from,
                e,
                t.retract_speed,
                self.lift_cutoff,
                off0,
            ));
        }
        let up = Axes {
            xyz: [self.from.xyz[0], self.from.xyz[1], self.height],
            ..self.from
        };
        out.push(mv(MoveKind::Lift, up, e, t.z_speed, self.lift_cutoff, off0));
        if let Some(tool) = self.tool_change {
            out.push(TravelItem::ToolChange(tool));
        }
        let over = Axes {
            xyz: [self.to.xyz[0], self.to.xyz[1], self.height],
            ..self.to
        };
        if self.rotate_first {
            let turned = Axes {
                tilt: self.to.tilt,
                c: self.to.c,
                ..up
            };
            out.push(mv(MoveKind::Travel, turned, e, t.speed, self.cutoff, off1));
        }
        out.push(mv(MoveKind::Travel, over, e, t.speed, self.cutoff, off1));
        let Some(w) = self.waypoint else {
            return out;
        };
        let near = approach_point(m, &self.to);
        out.push(mv(MoveKind::Lower, near, e, t.z_speed, self.cutoff, off1));
        if self.new_layer {
            // As the reference G-code: reset, then prime retract + extra.
            out.push(TravelItem::ResetE);
            out.push(mv(
                MoveKind::Prime,
                near,
                if self.retract { t.retract } else { 0.0 } + t.prime,
                t.retract_speed,
                self.cutoff,
                off1,
            ));
            out.push(TravelItem::ResetE);
            e = self.e_to;
        } else if self.retract {
            e = self.e_to;
            out.push(mv(
                MoveKind::Prime,
                near,
                e,
                t.retract_speed,
                self.cutoff,
                off1,
            ));
        }
        out.push(TravelItem::Move(Move {
            kind: MoveKind::Approach,
            to: self.to,
            e,
            feed: t.z_speed,
            cutoff: self.cutoff,
            waypoint: Some(w),
            offset: off1,
        }));
        out
    }
}

/// Seconds the written move `from → to` takes on machine `m` — its
/// planned duration, what a `G93` program's inverse-time feeds encode:
/// the slowest of `feed` over the part-frame tip path and every axis at
/// its top speed (C by the written difference); a line that moves only the
/// extruder takes its `|de|` of filament at `feed`. Under tool-centre-point
/// control the tip path is measured between the tips as written (rounded
/// to [`crate::kinematics::DECIMALS`]), so the tip speed the controller
/// makes is the feed exactly.
pub fn move_seconds(m: &Machine, from: &Axes, to: &Axes, feed: f64, de: f64) -> f64 {
    if from == to {
        return de.abs() / feed;
    }
    let (mut pa, mut pb) = (m.tip(from), m.tip(to));
    if m.post.interpolation() == crate::kinematics::Interpolation::TipLinear {
        pa = pa.map(round_written);
        pb = pb.map(round_written);
    }
    let len = distance(pb, pa);
    [
        len / feed,
        (to.xyz[0] - from.xyz[0]).abs() / m.x.speed,
        (to.xyz[1] - from.xyz[1]).abs() / m.y.speed,
        (to.xyz[2] - from.xyz[2]).abs() / m.z.speed,
        (to.tilt - from.tilt).abs().to_degrees() / m.tilt.speed,
        (to.c - from.c).abs().to_degrees() / m.c.speed,
    ]
    .into_iter()
    .fold(0.0, f64::max)
}

/// The point `approach` mm back along the nozzle from the waypoint at `a`.
pub fn approach_point(m: &Machine, a: &Axes) -> Axes {
    let p = DVec3::from(m.tip(a));
    let n = DVec3::from(crate::kinematics::orientation(m.rotary, a.tilt, a.c));
    let q = (p + m.travel.approach * n).to_array();
    let lin = crate::kinematics::linear_axes(m, q, a.tilt, a.c);
    Axes {
        xyz: lin.map(round_written),
        ..*a
    }
}

impl Program {
    /// Every motion of the program as `(from, move)`, travels expanded,
    /// extruder-only moves included (their `from` equals `to`).
    pub fn moves(&self, m: &Machine) -> Vec<(Axes, Move)> {
        let mut out = Vec::new();
        let mut at = self.home;
        for s in &self.steps {
            match s {
                Step::Move(mv) => {
                    out.push((at, *mv));
                    at = mv.to;
                }
                Step::Travel(t) => {
                    for item in t.items(m) {
                        if let TravelItem::Move(mv) = item {
                            out.push((at, mv));
                            at = mv.to;
                        }
                    }
                }
            }
        }
        out
    }
}

/// One visited waypoint of a section, as the program prints it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stop {
    /// Global waypoint index.
    pub waypoint: usize,
    /// Axes (C as the graph chose it: wrapped, or absolute under a C range).
    pub axes: Axes,
    /// Extruder position (absolute within the layer).
    pub e: f64,
    /// Entered through a break instead of printing from the previous stop.
    pub break_before: bool,
}

/// A section to print: its layer, extruder and stops.
#[derive(Clone, Debug, PartialEq)]
pub struct SectionPlan {
    /// Layer index.
    pub layer: usize,
    /// The extruder printing it.
    pub tool: ToolSettings,
    /// Visited waypoints in order.
    pub stops: Vec<Stop>,
}

/// Stage 6: the program that prints `route` with E `e`, every move proven
/// free by `prover` or its travel re-planned; the waypoints the route does
/// not visit are left out. Also a warning when travels stay unproven.
pub(super) fn assemble(
    setup: &Setup,
    route: &Route,
    e: &[f64],
    prover: &Prover,
) -> Result<(Program, Option<String>), PlanError> {
    let (m, toolpath) = (setup.machine, setup.toolpath);
    let sections: Vec<SectionPlan> = route
        .sections
        .iter()
        .map(|sec| {
            let layer = toolpath.layer_of[sec.waypoints.start];
            SectionPlan {
                layer,
                tool: m.tool_for(toolpath.layer_is_support[layer]),
                stops: sec
                    .waypoints
                    .clone()
                    .enumerate()
                    .filter(|&(_, g)| route.skip[g].is_none())
                    .map(|(k, g)| Stop {
                        waypoint: g,
                        axes: sec.axes[k],
                        e: e[g],
                        break_before: sec.breaks[k],
                    })
                    .collect(),
            }
        })
        .collect();
    let assembly = Assembly {
        machine: m,
        tip_tolerance: m.tip_tolerance,
        sphere_z: sphere_z(setup.scene, prover.margin),
        reader: &toolpath.layer_reader,
    };
    let (program, stuck) = assembly.build(&sections, prover)?;
    let warning = (!stuck.is_empty()).then(|| {
        format!(
            "{} move group(s) of the program could not be proven free even at the highest travel: see colliding_edges",
            stuck.len()
        )
    });
    Ok((program, warning))
}

/// Machine Z above which no rotation of the part can reach the head
/// (configuration III: the part turns about the origin; the head hangs
/// above its tip), with `margin` to spare.
fn sphere_z(scene: &Scene, margin: f64) -> f64 {
    // The farthest vertex from the origin, by its squared distance (exact
    // for f32 coordinates but for the sum's rounding; no `hypot`, which is
    // slow in libm, over every vertex of the part).
    let r2 = scene
        .part_tris
        .par_iter()
        .map(|t| {
            [t.v0, t.v1, t.v2]
                .iter()
                .map(|&v| Vec3::from(v).as_dvec3().length_squared())
                .fold(0.0, f64::max)
        })
        .reduce(|| 0.0, f64::max);
    let r = r2.sqrt();
    let below = -(scene.head.params.aabb_min[2] as f64).min(0.0);
    r + margin + below + 1.0
}

/// The moves of a program (as [`Program::moves`] lists them) that move
/// the axes, as the prover proves them: a line that moves only the
/// extruder has nothing to prove.
pub fn motion_specs(moves: &[(Axes, Move)]) -> Vec<MoveSpec> {
    moves
        .iter()
        .filter(|(from, mv)| *from != mv.to)
        .map(|(from, mv)| mv.spec_from(*from))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A program is mostly print moves: a step must cost no more than a
    /// move (travels are boxed), or every step of a long program takes a
    /// travel's size.
    #[test]
    fn a_step_is_no_larger_than_a_move() {
        assert_eq!(std::mem::size_of::<Step>(), std::mem::size_of::<Move>());
    }
}

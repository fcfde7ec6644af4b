//! The machine program: every move the machine makes, in order, with the
//! material present during it — so that the program can be checked move by
//! move exactly as it is written, and then written.
//!
//! A program is a list of [`Step`]s. Printing a section is a run of
//! [`MoveKind::Print`] moves (each bead segment split by
//! [`NearestLayer::bead_moves`] where joint-linear interpolation would bow the tip
//! off the bead); getting from one section to the next (or across a break,
//! or at the start and end) is a [`Travel`]: retract, lift to a safe
//! height, tool change if the next layer needs the other extruder, travel
//! (C the shorter way round unless the machine limits C), lower, prime,
//! approach along the nozzle. A travel whose moves cannot be proven free is
//! re-planned higher, or with the rotation done before the horizontal
//! move, before it is given up (and counted).

use super::layer_reading::NearestLayer;
use crate::collide::CollideError;
use crate::kinematics::{round_angle, round_written, Axes, Machine, ToolSettings};
use crate::prove::{MoveSpec, Prover};
use crate::scene::cutoff;
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
    /// as travels are few and a `Travel` is 2.4 times a `Move`: a program
    /// is mostly print moves, and a million steps of the larger size held
    /// ~0.13 GB more (and more again while the list grew).
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
    let len = (pb[0] - pa[0]).hypot(pb[1] - pa[1]).hypot(pb[2] - pa[2]);
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
    let p = m.tip(a);
    let n = crate::kinematics::orientation(m.rotary, a.tilt, a.c);
    let d = m.travel.approach;
    let q = [p[0] + d * n[0], p[1] + d * n[1], p[2] + d * n[2]];
    let lin =
        crate::kinematics::linear_axes(m.configuration, m.rotary, m.offsets(), q, a.tilt, a.c);
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
    pub g: usize,
    /// Axes (C as the graph chose it: wrapped, or absolute under a C range).
    pub axes: Axes,
    /// Extruder position (absolute within the layer).
    pub e: f64,
    /// Entered through a break instead of printing from the previous stop.
    pub brk: bool,
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

/// Unwind `c` next to `prev` (the shorter way round) unless the machine
/// limits C, where configurations already carry their absolute C.
fn unwind(m: &Machine, prev: f64, c: f64) -> f64 {
    if m.c.range.is_some() {
        c
    } else {
        round_angle(prev + crate::kinematics::wrap(c - prev))
    }
}

/// Heights a travel tries, lowest first: the reference's rule (above the
/// highest Z printed so far), a height from which no rotation can reach
/// the part (`sphere_z`), the machine's top.
fn heights(m: &Machine, from: &Axes, to: &Axes, z_run: f64, sphere_z: f64) -> Vec<f64> {
    let t = &m.travel;
    let base = (z_run + t.lift)
        .max(from.xyz[2])
        .max(to.xyz[2] + t.approach)
        .min(m.z.max);
    let mut v = vec![round_written(base)];
    for h in [sphere_z, m.z.max] {
        let h = round_written(h.min(m.z.max));
        if h > *v.last().expect("non-empty") + 1e-9 {
            v.push(h);
        }
    }
    v
}

/// Everything the assembly needs besides the sections.
pub struct Assembly<'a> {
    /// The machine.
    pub machine: &'a Machine,
    /// Largest bead deviation of the tip (mm).
    pub tip_tolerance: f64,
    /// Machine Z above which no rotation can bring material to the head.
    pub sphere_z: f64,
    /// Which layer a tip reads as: beads are split where the split tips
    /// read as the bead's own layer (as the planner proved them).
    pub reader: &'a NearestLayer,
}

/// A travel of the program and the alternatives left to try.
struct Pending {
    step: usize,
    alternatives: Vec<(f64, bool)>,
}

impl Assembly<'_> {
    /// Build the program for `sections` (print order), proving every move
    /// with `prover` and re-planning travels that cannot be proven. Returns
    /// the program and the travels that stayed unproven (step indices).
    pub fn build(
        &self,
        sections: &[SectionPlan],
        prover: &Prover,
    ) -> Result<(Program, Vec<usize>), CollideError> {
        let m = self.machine;
        let home = Axes {
            xyz: [0.0, 0.0, round_written(m.travel.home_z)],
            tilt: 0.0,
            c: 0.0,
        };
        let mut prog = Program {
            home,
            first_tool: sections.first().map(|s| s.tool),
            steps: Vec::new(),
        };
        let mut pending = Vec::new();
        let written = self.written(sections, &home);
        let mut pieces = self.bead_pieces(sections, &written).into_iter();
        let mut at = home;
        let mut e = 0.0;
        let mut z_run = f64::NEG_INFINITY;
        let mut tool = sections.first().map(|s| s.tool);
        let mut last_g: Option<usize> = None;
        let mut prev_layer: Option<usize> = None;
        for (sec, written) in sections.iter().zip(&written) {
            let Some(first) = sec.stops.first() else {
                continue;
            };
            let new_layer = prev_layer != Some(sec.layer);
            let target = written[0];
            let change = (tool != Some(sec.tool)).then_some(sec.tool);
            let t = self.travel(
                &at,
                &target,
                first.g,
                (e, first.e),
                (last_g.is_some(), new_layer),
                change,
                last_g,
                z_run,
                [tool.map_or([0.0; 2], |x| x.offset), sec.tool.offset],
            );
            pending.push(self.pending(prog.steps.len(), &t, z_run));
            prog.steps.push(Step::Travel(Box::new(t)));
            tool = Some(sec.tool);
            at = target;
            e = first.e;
            z_run = z_run.max(at.xyz[2]);
            let mut prev = *first;
            for (s, &b) in sec.stops.iter().zip(written).skip(1) {
                if s.brk {
                    let t = self.travel(
                        &at,
                        &b,
                        s.g,
                        (e, s.e),
                        (true, false),
                        None,
                        Some(prev.g),
                        z_run,
                        [sec.tool.offset; 2],
                    );
                    pending.push(self.pending(prog.steps.len(), &t, z_run));
                    prog.steps.push(Step::Travel(Box::new(t)));
                } else {
                    let pts = pieces.next().expect("a bead's pieces");
                    let n = pts.len();
                    for (k, mv) in pts.into_iter().enumerate() {
                        let f = (k + 1) as f64 / n as f64;
                        prog.steps.push(Step::Move(Move {
                            kind: MoveKind::Print,
                            to: mv.to,
                            e: round_written(e + f * (s.e - e)),
                            feed: sec.tool.feed,
                            cutoff: mv.cutoff,
                            waypoint: (k + 1 == n).then_some(s.g),
                            offset: sec.tool.offset,
                        }));
                    }
                }
                at = b;
                e = s.e;
                z_run = z_run.max(at.xyz[2]);
                prev = *s;
            }
            last_g = Some(prev.g);
            prev_layer = Some(sec.layer);
        }
        // Park: retract, lift to the home height, back to X0 Y0 and zero angles.
        if let Some(g) = last_g {
            let park = Axes {
                xyz: [0.0, 0.0, home.xyz[2]],
                tilt: 0.0,
                c: unwind(m, at.c, 0.0),
            };
            let t = Travel {
                from: at,
                to: park,
                waypoint: None,
                e_from: e,
                e_to: e,
                retract: true,
                new_layer: false,
                tool_change: None,
                height: home.xyz[2].max(at.xyz[2]),
                rotate_first: false,
                lift_cutoff: cutoff(g),
                cutoff: g as u32 + 2,
                offsets: [tool.map_or([0.0; 2], |x| x.offset); 2],
            };
            pending.push(Pending {
                step: prog.steps.len(),
                alternatives: vec![(home.xyz[2], true)],
            });
            prog.steps.push(Step::Travel(Box::new(t)));
        }
        let failed = self.prove_travels(&mut prog, pending, prover)?;
        Ok((prog, failed))
    }

    /// Every stop's axes as written: C unwound next to the stop before
    /// (from `home` on), the way the machine will turn.
    fn written(&self, sections: &[SectionPlan], home: &Axes) -> Vec<Vec<Axes>> {
        let mut c = home.c;
        sections
            .iter()
            .map(|sec| {
                sec.stops
                    .iter()
                    .map(|s| {
                        c = unwind(self.machine, c, s.axes.c);
                        Axes { c, ..s.axes }
                    })
                    .collect()
            })
            .collect()
    }

    /// The pieces of every bead of `sections` in print order
    /// ([`NearestLayer::bead_moves`]) between the stops as `written`.
    /// The split is most of the assembly's work and each bead's is its
    /// own: they are split side by side (dome_cut's 176 k beads: 0.24 s
    /// alone).
    fn bead_pieces(&self, sections: &[SectionPlan], written: &[Vec<Axes>]) -> Vec<Vec<MoveSpec>> {
        let beads: Vec<(&Axes, &Axes, usize, u32)> = sections
            .iter()
            .zip(written)
            .flat_map(|(sec, w)| {
                (1..sec.stops.len())
                    .filter(|&k| !sec.stops[k].brk)
                    .map(move |k| (&w[k - 1], &w[k], sec.layer, cutoff(sec.stops[k - 1].g)))
            })
            .collect();
        beads
            .par_iter()
            .map(|&(a, b, layer, cutoff)| {
                self.reader
                    .bead_moves(self.machine, a, b, self.tip_tolerance, layer, cutoff)
            })
            .collect()
    }

    #[allow(clippy::too_many_arguments)]
    fn travel(
        &self,
        from: &Axes,
        to: &Axes,
        g: usize,
        (e_from, e_to): (f64, f64),
        (retract, new_layer): (bool, bool),
        tool_change: Option<ToolSettings>,
        last_g: Option<usize>,
        z_run: f64,
        offsets: [[f64; 2]; 2],
    ) -> Travel {
        let m = self.machine;
        let height = match last_g {
            // The start: from home, at the home height.
            None => from.xyz[2].max(to.xyz[2] + m.travel.approach),
            Some(_) => heights(m, from, to, z_run, self.sphere_z)[0],
        };
        Travel {
            from: *from,
            to: *to,
            waypoint: Some(g),
            e_from,
            e_to,
            retract,
            new_layer,
            tool_change,
            height: round_written(height),
            rotate_first: false,
            lift_cutoff: cutoff(last_g.unwrap_or(g)),
            cutoff: cutoff(g),
            offsets,
        }
    }

    fn pending(&self, step: usize, t: &Travel, z_run: f64) -> Pending {
        let mut alternatives = Vec::new();
        for h in heights(self.machine, &t.from, &t.to, z_run, self.sphere_z) {
            let h = h.max(t.height);
            for rotate_first in [false, true] {
                if (h, rotate_first) != (t.height, t.rotate_first)
                    && !alternatives.contains(&(h, rotate_first))
                {
                    alternatives.push((h, rotate_first));
                }
            }
        }
        Pending { step, alternatives }
    }

    /// Prove every move; re-plan the travels that fail with their next
    /// alternative until they pass or none is left. Returns the steps of
    /// the travels left unproven.
    fn prove_travels(
        &self,
        prog: &mut Program,
        mut pending: Vec<Pending>,
        prover: &Prover,
    ) -> Result<Vec<usize>, CollideError> {
        let m = self.machine;
        loop {
            let failing = failing_steps(prog, m, prover)?;
            let mut changed = false;
            let mut stuck = Vec::new();
            for step in failing {
                let Some(p) = pending.iter_mut().find(|p| p.step == step) else {
                    stuck.push(step);
                    continue;
                };
                if p.alternatives.is_empty() {
                    stuck.push(step);
                    continue;
                }
                let (h, rf) = p.alternatives.remove(0);
                if let Step::Travel(t) = &mut prog.steps[step] {
                    t.height = h;
                    t.rotate_first = rf;
                    changed = true;
                }
            }
            if !changed {
                return Ok(stuck);
            }
        }
    }
}

/// Steps of `prog` with a move that cannot be proven free.
pub fn failing_steps(
    prog: &Program,
    m: &Machine,
    prover: &Prover,
) -> Result<Vec<usize>, CollideError> {
    let mut specs = Vec::new();
    let mut owner = Vec::new();
    let mut at = prog.home;
    for (i, s) in prog.steps.iter().enumerate() {
        let moves: Vec<Move> = match s {
            Step::Move(mv) => vec![*mv],
            Step::Travel(t) => t
                .items(m)
                .into_iter()
                .filter_map(|it| match it {
                    TravelItem::Move(mv) => Some(mv),
                    _ => None,
                })
                .collect(),
        };
        for mv in moves {
            if mv.to != at {
                specs.push(MoveSpec {
                    from: at,
                    to: mv.to,
                    cutoff: mv.cutoff,
                });
                owner.push(i);
            }
            at = mv.to;
        }
    }
    let hits = prover.moves(&specs)?;
    let mut out: Vec<usize> = owner
        .iter()
        .zip(hits)
        .filter(|(_, h)| *h)
        .map(|(&i, _)| i)
        .collect();
    out.dedup();
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A program is mostly print moves: a step must cost no more than a
    /// move (travels are boxed), or a million-step program holds ~0.13 GB
    /// more.
    #[test]
    fn a_step_is_no_larger_than_a_move() {
        assert_eq!(std::mem::size_of::<Step>(), std::mem::size_of::<Move>());
    }
}

//! Building the program (stage 6, [`super::assemble`]): the sections'
//! stops in print order, a travel to each section and across each break,
//! each bead split into the pieces the planner proved, a park at the end;
//! then every move proven, and the travels that fail re-planned higher or
//! with the rotation first.

use super::{Move, MoveKind, Program, SectionPlan, Step, Travel, TravelItem};
use crate::collide::CollideError;
use crate::kinematics::{round_angle, round_written, Axes, Machine, ToolSettings};
use crate::plan::layer_reading::NearestLayer;
use crate::prove::{MoveSpec, Prover};
use crate::scene::cutoff;
use rayon::prelude::*;

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

/// How a travel goes over: its height and whether the rotary axes turn
/// before the horizontal move.
#[derive(Clone, Copy, Debug, PartialEq)]
struct TravelShape {
    height: f64,
    rotate_first: bool,
}

/// A travel of the program and the shapes left to try should it fail.
struct Pending {
    step: usize,
    alternatives: Vec<TravelShape>,
}

/// Where the head is as the program is written, and what it has done.
struct Head {
    /// Its axes, as written.
    at: Axes,
    /// Extruder position.
    e: f64,
    /// Highest machine Z printed at so far.
    z_run: f64,
    /// The extruder in use.
    tool: Option<ToolSettings>,
    /// The waypoint printed last (`None` before the first).
    last_waypoint: Option<usize>,
}

/// A travel the program asks for, from where the head is to a waypoint.
struct TravelRequest {
    /// The waypoint to go to.
    waypoint: usize,
    /// Its axes, as written.
    to: Axes,
    /// Extruder position to resume printing at.
    e_to: f64,
    /// A new layer starts there.
    new_layer: bool,
    /// The extruder that prints from there.
    tool: ToolSettings,
}

/// The program as it is written: its steps so far, the travels to prove,
/// and where the head is.
struct Draft {
    program: Program,
    pending: Vec<Pending>,
    head: Head,
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
        let home = Axes {
            xyz: [0.0, 0.0, round_written(self.machine.travel.home_z)],
            tilt: 0.0,
            c: 0.0,
        };
        let first_tool = sections.first().map(|s| s.tool);
        let mut draft = Draft {
            program: Program {
                home,
                first_tool,
                steps: Vec::new(),
            },
            pending: Vec::new(),
            head: Head {
                at: home,
                e: 0.0,
                z_run: f64::NEG_INFINITY,
                tool: first_tool,
                last_waypoint: None,
            },
        };
        let written = self.written(sections, &home);
        let mut pieces = self.bead_pieces(sections, &written).into_iter();
        let mut prev_layer: Option<usize> = None;
        for (sec, written) in sections.iter().zip(&written) {
            if sec.stops.is_empty() {
                continue;
            }
            let new_layer = prev_layer != Some(sec.layer);
            self.print_section(&mut draft, sec, written, new_layer, &mut pieces);
            prev_layer = Some(sec.layer);
        }
        self.park(&mut draft, &home);
        let Draft {
            mut program,
            pending,
            ..
        } = draft;
        let failed = self.prove_travels(&mut program, pending, prover)?;
        Ok((program, failed))
    }

    /// Print section `sec`, its stops' axes as `written`: a travel to its
    /// first stop (and across each break), its beads' pieces (the next of
    /// `pieces`) between the others.
    fn print_section(
        &self,
        draft: &mut Draft,
        sec: &SectionPlan,
        written: &[Axes],
        new_layer: bool,
        pieces: &mut impl Iterator<Item = Vec<MoveSpec>>,
    ) {
        for (k, (stop, &to)) in sec.stops.iter().zip(written).enumerate() {
            if k == 0 || stop.break_before {
                let request = TravelRequest {
                    waypoint: stop.waypoint,
                    to,
                    e_to: stop.e,
                    new_layer: k == 0 && new_layer,
                    tool: sec.tool,
                };
                self.push_travel(draft, request);
            } else {
                let e = draft.head.e;
                let pts = pieces.next().expect("a bead's pieces");
                let n = pts.len();
                for (k, mv) in pts.into_iter().enumerate() {
                    let f = (k + 1) as f64 / n as f64;
                    draft.program.steps.push(Step::Move(Move {
                        kind: MoveKind::Print,
                        to: mv.to,
                        e: round_written(e + f * (stop.e - e)),
                        feed: sec.tool.feed,
                        cutoff: mv.cutoff,
                        waypoint: (k + 1 == n).then_some(stop.waypoint),
                        offset: sec.tool.offset,
                    }));
                }
            }
            let head = &mut draft.head;
            head.at = to;
            head.e = stop.e;
            head.z_run = head.z_run.max(to.xyz[2]);
            head.last_waypoint = Some(stop.waypoint);
        }
    }

    /// The travel `request` asks for from where the head is, with the
    /// shapes to try should it fail: retracting unless it is the program's
    /// first, changing extruder when the next section needs the other.
    fn push_travel(&self, draft: &mut Draft, request: TravelRequest) {
        let m = self.machine;
        let head = &draft.head;
        let (from, to, g) = (head.at, request.to, request.waypoint);
        let height = match head.last_waypoint {
            // The start: from home, at the home height.
            None => from.xyz[2].max(to.xyz[2] + m.travel.approach),
            Some(_) => heights(m, &from, &to, head.z_run, self.sphere_z)[0],
        };
        let travel = Travel {
            from,
            to,
            waypoint: Some(g),
            e_from: head.e,
            e_to: request.e_to,
            retract: head.last_waypoint.is_some(),
            new_layer: request.new_layer,
            tool_change: (head.tool != Some(request.tool)).then_some(request.tool),
            height: round_written(height),
            rotate_first: false,
            lift_cutoff: cutoff(head.last_waypoint.unwrap_or(g)),
            cutoff: cutoff(g),
            offsets: [
                head.tool.map_or([0.0; 2], |x| x.offset),
                request.tool.offset,
            ],
        };
        let step = draft.program.steps.len();
        draft.pending.push(Pending {
            step,
            alternatives: self.alternatives(&travel, head.z_run),
        });
        draft.program.steps.push(Step::Travel(Box::new(travel)));
        draft.head.tool = Some(request.tool);
    }

    /// Park after the last waypoint: retract, lift to the home height, back
    /// to X0 Y0 and zero angles.
    fn park(&self, draft: &mut Draft, home: &Axes) {
        let head = &draft.head;
        let Some(g) = head.last_waypoint else {
            return;
        };
        let park = Axes {
            xyz: [0.0, 0.0, home.xyz[2]],
            tilt: 0.0,
            c: unwind(self.machine, head.at.c, 0.0),
        };
        let travel = Travel {
            from: head.at,
            to: park,
            waypoint: None,
            e_from: head.e,
            e_to: head.e,
            retract: true,
            new_layer: false,
            tool_change: None,
            height: home.xyz[2].max(head.at.xyz[2]),
            rotate_first: false,
            lift_cutoff: cutoff(g),
            // Everything printed, the last waypoint's bead included.
            cutoff: cutoff(g + 1),
            offsets: [head.tool.map_or([0.0; 2], |x| x.offset); 2],
        };
        draft.pending.push(Pending {
            step: draft.program.steps.len(),
            alternatives: vec![TravelShape {
                height: home.xyz[2],
                rotate_first: true,
            }],
        });
        draft.program.steps.push(Step::Travel(Box::new(travel)));
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
    /// own, so they are split side by side.
    fn bead_pieces(&self, sections: &[SectionPlan], written: &[Vec<Axes>]) -> Vec<Vec<MoveSpec>> {
        let beads: Vec<(&Axes, &Axes, usize, u32)> = sections
            .iter()
            .zip(written)
            .flat_map(|(sec, w)| {
                (1..sec.stops.len())
                    .filter(|&k| !sec.stops[k].break_before)
                    .map(move |k| {
                        let from = sec.stops[k - 1].waypoint;
                        (&w[k - 1], &w[k], sec.layer, cutoff(from))
                    })
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

    /// The shapes `t` may take instead should it fail, in the order they
    /// are tried: each height [`heights`] gives (never below the travel's
    /// own), the rotation with the horizontal move and before it.
    fn alternatives(&self, t: &Travel, z_run: f64) -> Vec<TravelShape> {
        let own = TravelShape {
            height: t.height,
            rotate_first: t.rotate_first,
        };
        let mut alternatives = Vec::new();
        for h in heights(self.machine, &t.from, &t.to, z_run, self.sphere_z) {
            let height = h.max(t.height);
            for rotate_first in [false, true] {
                let shape = TravelShape {
                    height,
                    rotate_first,
                };
                if shape != own && !alternatives.contains(&shape) {
                    alternatives.push(shape);
                }
            }
        }
        alternatives
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
                let shape = p.alternatives.remove(0);
                if let Step::Travel(t) = &mut prog.steps[step] {
                    t.height = shape.height;
                    t.rotate_first = shape.rotate_first;
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
                specs.push(mv.spec_from(at));
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

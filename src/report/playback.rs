//! A program as it runs, for the eye: when each line ends, where the
//! machine's axes stand then, and which material exists. `program.glb`
//! (`program_glb.rs`) animates it; the report's pictures (`snapshot.rs`)
//! freeze it at a problem's line, and the page gives the same times.
//!
//! Times are the program's own: each line takes the duration `simulate`
//! measures for it ([`crate::simulate::measure`]), so a line ends at the
//! sum of the durations up to it. A long program keeps every line's end
//! up to [`MAX_KEYS`] keys; beyond that every `k`-th line, every line with
//! a problem and every line that turns a rotary axis by more than
//! [`KEEP_TURN_DEG`] are kept, and the machine moves straight between
//! them.

use crate::io::gcode_read::GcodeMove;
use crate::simulate::{Problem, ProblemKind, Simulation, Timeline};

/// Most lines kept as keys of the animation before sampling.
pub const MAX_KEYS: usize = 120_000;

/// A line turning a rotary axis by more than this (degrees) is always kept.
pub const KEEP_TURN_DEG: f64 = 10.0;

/// What a stretch of the program is doing, for its colour.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LineClass {
    /// Extruding.
    Printing,
    /// Moving without extruding.
    Travel,
    /// A problem (the worst of the line's, in [`ProblemKind`]'s order).
    Problem(ProblemKind),
}

/// The program's timing and material, line by line.
#[derive(Clone, Debug)]
pub struct Playback<'a> {
    /// The program's lines that move, dwell or extrude.
    pub moves: &'a [GcodeMove],
    /// Per move: program time at its end (s).
    pub ends: Vec<f64>,
    /// Per move: scene stamps below this exist once it has ended
    /// (never decreasing; at the end everything printed exists).
    pub present_after: Vec<u32>,
    /// Per move: stamps below this exist while it runs (what its check
    /// used).
    pub cutoffs: &'a [u32],
    /// Per move: what it is doing.
    pub classes: Vec<LineClass>,
    /// The problems, in line order.
    pub problems: &'a [Problem],
}

impl<'a> Playback<'a> {
    /// The playback of `moves` as `sim` measured them over `timeline`.
    pub fn new(moves: &'a [GcodeMove], sim: &'a Simulation, timeline: &'a Timeline) -> Self {
        let mut t = 0.0;
        let ends = sim
            .moves
            .iter()
            .map(|r| {
                t += r.seconds;
                t
            })
            .collect();
        let cutoffs = &timeline.cutoffs[..];
        let n = cutoffs.len();
        let mut most = 0u32;
        let present_after = (0..n)
            .map(|i| {
                if i + 1 == n {
                    return u32::MAX - 1;
                }
                most = most.max(cutoffs[i]).max(cutoffs[i + 1]);
                most
            })
            .collect();
        let mut classes: Vec<LineClass> = moves
            .iter()
            .map(|m| {
                if m.extrudes() {
                    LineClass::Printing
                } else {
                    LineClass::Travel
                }
            })
            .collect();
        // Problems come in line order, as the moves do.
        let mut k = 0;
        for p in &sim.problems {
            while k < moves.len() && moves[k].line < p.line {
                k += 1;
            }
            if k < moves.len() && moves[k].line == p.line {
                classes[k] = match classes[k] {
                    LineClass::Problem(q) if q <= p.kind => LineClass::Problem(q),
                    _ => LineClass::Problem(p.kind),
                };
            }
        }
        Playback {
            moves,
            ends,
            present_after,
            cutoffs,
            classes,
            problems: &sim.problems,
        }
    }

    /// The program's duration (s).
    pub fn duration(&self) -> f64 {
        self.ends.last().copied().unwrap_or(0.0)
    }

    /// The index in `moves` of G-code line `line`.
    pub fn index_of_line(&self, line: usize) -> Option<usize> {
        self.moves.binary_search_by_key(&line, |m| m.line).ok()
    }

    /// The program time at which line `line` ends (s).
    pub fn time_of_line(&self, line: usize) -> Option<f64> {
        self.index_of_line(line).map(|i| self.ends[i])
    }

    /// The first move after whose end material stamped `stamp` exists
    /// (`None`: never printed).
    pub fn appears_after(&self, stamp: u32) -> Option<usize> {
        let i = self.present_after.partition_point(|&c| c <= stamp);
        (i < self.present_after.len()).then_some(i)
    }

    /// The moves kept as keys: all of them up to [`MAX_KEYS`], else every
    /// `k`-th, the last, those with a problem and those that turn far.
    pub fn kept(&self) -> Vec<usize> {
        let n = self.moves.len();
        let stride = n.div_ceil(MAX_KEYS).max(1);
        (0..n)
            .filter(|&i| {
                stride == 1
                    || i % stride == 0
                    || i + 1 == n
                    || matches!(self.classes[i], LineClass::Problem(_))
                    || turn_deg(&self.moves[i]) > KEEP_TURN_DEG
            })
            .collect()
    }
}

/// |Δtilt| + |ΔC| of a line (degrees).
pub fn turn_deg(m: &GcodeMove) -> f64 {
    (m.to[3] - m.from[3]).abs() + (m.to[4] - m.from[4]).abs()
}

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
        let ends = sim.ends();
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simulate::{MoveReport, Simulation, Summary};

    fn program(n: usize) -> (Vec<GcodeMove>, Simulation, Timeline) {
        let moves: Vec<GcodeMove> = (0..n)
            .map(|i| GcodeMove {
                line: 10 + 2 * i,
                linear: true,
                from: [i as f64, 0.0, 0.0, 0.0, 0.0],
                to: [
                    i as f64 + 1.0,
                    0.0,
                    0.0,
                    0.0,
                    if i == 7 { 30.0 } else { 0.0 },
                ],
                e: 0.0,
                de: if i % 5 == 4 { 0.0 } else { 0.1 },
                f: 600.0,
                inverse_time: false,
                tcp: false,
                tool: 0,
                dwell: 0.0,
            })
            .collect();
        let reports = moves
            .iter()
            .map(|mv| MoveReport {
                line: mv.line,
                extrudes: mv.extrudes(),
                tcp: false,
                layer: Some(0),
                seconds: 0.5,
                length_mm: 1.0,
                tip_speed: 2.0,
                deviation_mm: 0.0,
                rotary_step_deg: 0.0,
                tilt_deg: 0.0,
                c_deg: 0.0,
                e_per_mm: 0.1,
                collides: false,
            })
            .collect();
        let problems = vec![
            Problem {
                line: 14,
                kind: ProblemKind::Blob,
                value: 1.0,
                layer: Some(0),
            },
            Problem {
                line: 14,
                kind: ProblemKind::Collision,
                value: 0.0,
                layer: Some(0),
            },
        ];
        // Extruding lines leave out the bead they lay; others count all.
        let mut count = 0;
        let cutoffs = moves
            .iter()
            .map(|mv| {
                if mv.extrudes() {
                    count += 1;
                    count - 1
                } else {
                    count + 1
                }
            })
            .collect();
        let sim = Simulation {
            summary: Summary::default(),
            problems,
            moves: reports,
        };
        let timeline = Timeline {
            printed: Vec::new(),
            cutoffs,
            layers: vec![Some(0); n],
        };
        (moves, sim, timeline)
    }

    #[test]
    fn lines_end_at_the_sum_of_their_durations() {
        let (moves, sim, timeline) = program(10);
        let p = Playback::new(&moves, &sim, &timeline);
        assert_eq!(p.ends[0], 0.5);
        assert_eq!(p.duration(), 5.0);
        assert_eq!(p.time_of_line(14), Some(1.5));
        assert_eq!(p.time_of_line(15), None);
    }

    #[test]
    fn material_once_there_stays_and_all_is_there_at_the_end() {
        let (moves, sim, timeline) = program(10);
        let p = Playback::new(&moves, &sim, &timeline);
        assert!(p.present_after.windows(2).all(|w| w[0] <= w[1]));
        for (i, &c) in p.present_after.iter().enumerate() {
            assert!(c >= timeline.cutoffs[i]);
        }
        assert_eq!(p.appears_after(0), Some(0));
        assert_eq!(p.appears_after(u32::MAX), None);
        // A stamp first present during move i appears after a move before it.
        let during = timeline.cutoffs.iter().position(|&c| c > 5).unwrap();
        assert!(p.appears_after(5).unwrap() < during.max(1));
    }

    #[test]
    fn a_line_takes_its_worst_problem() {
        let (moves, sim, timeline) = program(10);
        let p = Playback::new(&moves, &sim, &timeline);
        assert_eq!(p.classes[2], LineClass::Problem(ProblemKind::Collision));
        assert_eq!(p.classes[4], LineClass::Travel);
        assert_eq!(p.classes[0], LineClass::Printing);
    }

    #[test]
    fn a_long_program_keeps_every_kth_line_its_problems_and_its_turns() {
        let n = 3 * MAX_KEYS + 10;
        let (moves, sim, timeline) = program(n);
        let p = Playback::new(&moves, &sim, &timeline);
        let kept = p.kept();
        assert!(kept.len() <= n / 4 + 10, "{}", kept.len());
        for must in [2, 7, n - 1] {
            assert!(kept.contains(&must), "{must}");
        }
        assert!(kept.windows(2).all(|w| w[0] < w[1]));
        let (short, sim, timeline) = program(50);
        assert_eq!(Playback::new(&short, &sim, &timeline).kept().len(), 50);
    }
}

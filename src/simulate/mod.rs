//! `simulate`: what a 5-axis program — ours or anyone's — will do on the
//! machine, before it runs.
//!
//! Three stages, each a plain function:
//!
//! 0. [`against`]: the part the program is checked against (a job's, or
//!    its own) and its timeline.
//! 1. [`timeline()`]: read as [`crate::io::gcode_read::read_program`] reads
//!    it, the program prints the toolpath's layer surfaces in its own
//!    order; [`Timeline`] says which material exists during each line, and
//!    [`crate::scene::Scene::restamp`] turns that into a scene. Without a
//!    toolpath, [`own_part()`]: the beads the program lays itself, in its
//!    order, are the part.
//! 2. [`check_moves`]: every line that moves is proven free or colliding
//!    with the evaluator, completely (the planner's
//!    [`crate::prove::Prover`]: samples close enough for the head's
//!    size, at the machine's safety margin), interpolated as the
//!    controller does — joint-linear, or the tip straight under
//!    tool-centre-point control.
//! 3. [`report`]: each line measured ([`measure`]) and the problems listed
//!    with their G-code lines, plus a summary.

pub mod against;
pub mod measure;
pub mod own_part;
pub mod timeline;

use crate::collide::cpu::CpuBackend;
use crate::collide::{Backend, CollideError};
use crate::io::gcode_read::{axes_of, read_program, GcodeError, GcodeMove};
use crate::kinematics::{Dialect, Machine};
use crate::plan::head_reach;
use crate::plan::layer_reading::NearestLayer;
use crate::prove::{MoveSpec, Prover, Ticker};
use crate::scene::Scene;
use crate::toolpath::Toolpath;
pub use measure::{Deviation, MoveReport, Problem, ProblemKind};
pub use own_part::{own_part, platform_under, OwnPart};
use rayon::prelude::*;
use serde::Serialize;
pub use timeline::Timeline;

/// What a simulation found, in numbers.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Summary {
    /// Lines that move an axis or the extruder, or dwell.
    pub moves: usize,
    /// Lines that extrude while moving.
    pub extruding_moves: usize,
    /// Bead laid (mm, part frame).
    pub extruded_mm: f64,
    /// The program's duration at the modelled speeds (s).
    pub seconds: f64,
    /// Lines that move an axis, all checked for collisions.
    pub checked_moves: usize,
    /// Of those, lines that come within the margin of the platform or
    /// printed material.
    pub colliding_moves: usize,
    /// Safety margin of the checks (mm).
    pub margin: f64,
    /// Collision queries the checks took.
    pub collision_queries: u64,
    /// Waypoints of the toolpath.
    pub waypoints: usize,
    /// Waypoints the program extrudes at.
    pub printed_waypoints: usize,
    /// Largest tip deviation from the bead while extruding (mm).
    pub tip_deviation_max_mm: f64,
    /// Its 99th percentile (mm).
    pub tip_deviation_p99_mm: f64,
    /// Extruding lines whose tip leaves the bead by more than the machine's
    /// tip tolerance.
    pub tip_deviation_over_tolerance: usize,
    /// Share of extruding lines whose tip speed leaves the extruder's range (%).
    pub speed_violation_pct: f64,
    /// The same share of the extruded length (%).
    pub speed_violation_pct_length: f64,
    /// Largest rotary step of an extruding line (degrees).
    pub rotary_step_max_deg: f64,
    /// Extruding lines turning more than [`measure::SWING_DEG`].
    pub swings: usize,
    /// Travels (runs of lines between extruding ones).
    pub travels: usize,
    /// Largest C rotation of one travel (degrees).
    pub travel_c_max_deg: f64,
    /// Travels turning C by more than half a turn.
    pub long_travel_turns: usize,
    /// Median filament per mm of bead.
    pub e_per_mm_median: f64,
    /// Largest filament per mm of bead.
    pub e_per_mm_max: f64,
    /// Lines reported as blobs.
    pub blobs: usize,
}

/// Everything a simulation found.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Simulation {
    /// The numbers.
    pub summary: Summary,
    /// Every problem at its line, in line order.
    pub problems: Vec<Problem>,
    /// Every line that moves, measured.
    pub moves: Vec<MoveReport>,
}

impl Simulation {
    /// Per measured line, the program time at its end (s): the sum of
    /// the durations up to it, the time `program.glb` shows it at.
    pub fn ends(&self) -> Vec<f64> {
        let mut t = 0.0;
        self.moves
            .iter()
            .map(|r| {
                t += r.seconds;
                t
            })
            .collect()
    }

    /// The program time at which each problem's line ends, in the
    /// problems' order.
    pub fn problem_times(&self) -> Vec<f64> {
        let ends = self.ends();
        self.problems
            .iter()
            .map(|p| {
                let i = self.moves.partition_point(|r| r.line < p.line);
                ends.get(i).copied().unwrap_or(0.0)
            })
            .collect()
    }
}

/// `m` interpolating as its joint dialect, and as tool-centre-point
/// control: the two ways a line of a program can move.
pub fn machines(m: &Machine) -> (Machine, Machine) {
    let mut joint = m.clone();
    joint.post.dialect = Dialect::Joint;
    let mut tcp = m.clone();
    tcp.post.dialect = Dialect::G43_4;
    (joint, tcp)
}

/// Stage 1: which material exists during each line of `moves` printing
/// `toolpath` (part frame, as the scene was built).
pub fn timeline(m: &Machine, toolpath: &Toolpath, moves: &[GcodeMove]) -> Timeline {
    let reader = NearestLayer::of(toolpath);
    Timeline::new(m, &reader, &toolpath.positions(), moves)
}

/// Stage 2: does each line of `moves` that moves an axis come within
/// `margin` of the material present (`cutoffs`, in the stamps of
/// `scene`, which `backend` was built on)? `None` for lines that move
/// only the extruder. `step` is the initial sample spacing (mm); queries
/// the backend answers slowly go to the cpu backend beside it
/// ([`Prover::with_wide`]). Returns the verdicts and the queries they
/// took.
#[allow(clippy::too_many_arguments)]
pub fn check_moves(
    m: &Machine,
    backend: &dyn Backend,
    scene: &Scene,
    margin: f64,
    step: f64,
    moves: &[GcodeMove],
    cutoffs: &[u32],
    ticker: Option<Ticker>,
) -> Result<(Vec<Option<bool>>, u64), CollideError> {
    let (joint, tcp) = machines(m);
    let mut out = vec![None; moves.len()];
    let mut queries = 0;
    let (reach, cpu) = (head_reach(scene), CpuBackend::new(scene));
    for (machine, is_tcp) in [(&joint, false), (&tcp, true)] {
        let mut prover = Prover::new(machine, backend, reach, margin, step).with_wide(&cpu);
        if let Some(t) = ticker {
            prover = prover.with_ticker(t);
        }
        let idx: Vec<usize> = (0..moves.len())
            .filter(|&i| moves[i].tcp == is_tcp && moves[i].moves_axes())
            .collect();
        let specs: Vec<MoveSpec> = idx
            .iter()
            .map(|&i| MoveSpec {
                from: axes_of(&moves[i].from),
                to: axes_of(&moves[i].to),
                cutoff: cutoffs[i],
            })
            .collect();
        let hits = prover.moves(&specs)?;
        for (&i, h) in idx.iter().zip(hits) {
            out[i] = Some(h);
        }
        queries += prover.queries();
    }
    Ok((out, queries))
}

/// Stage 3: every line measured, the problems and the summary.
/// `collides` and `queries` are [`check_moves`]'s answer; `deviation`
/// says how the tip deviations are found ([`Deviation::Sampled`]: the
/// summary's deviation figures are the sampled ones).
#[allow(clippy::too_many_arguments)]
pub fn report(
    m: &Machine,
    moves: &[GcodeMove],
    timeline: &Timeline,
    collides: &[Option<bool>],
    queries: u64,
    margin: f64,
    deviation: Deviation,
) -> Simulation {
    let (joint, tcp) = machines(m);
    let reports: Vec<MoveReport> = moves
        .par_iter()
        .enumerate()
        .map(|(i, mv)| {
            let mut r = measure::measure(if mv.tcp { &tcp } else { &joint }, mv, deviation);
            r.layer = timeline.layers[i];
            r.collides = collides[i] == Some(true);
            r
        })
        .collect();
    let problems = measure::problems(m, moves, &reports);
    let ext: Vec<(&GcodeMove, &MoveReport)> = moves
        .iter()
        .zip(&reports)
        .filter(|(_, r)| r.extrudes)
        .collect();
    let count = |k: ProblemKind| problems.iter().filter(|p| p.kind == k).count();
    let extruded: f64 = ext.iter().map(|(_, r)| r.length_mm).sum();
    let violating: Vec<&MoveReport> = ext
        .iter()
        .filter(|(mv, r)| measure::outside_range(r.tip_speed, measure::tip_range(m, mv.tool)))
        .map(|(_, r)| *r)
        .collect();
    let travels = measure::travels(moves);
    let dev: Vec<f64> = ext.iter().map(|(_, r)| r.deviation_mm).collect();
    let summary = Summary {
        moves: moves.len(),
        extruding_moves: ext.len(),
        extruded_mm: extruded,
        seconds: reports.iter().map(|r| r.seconds).sum(),
        checked_moves: collides.iter().filter(|c| c.is_some()).count(),
        colliding_moves: count(ProblemKind::Collision),
        margin,
        collision_queries: queries,
        waypoints: timeline.printed.len(),
        printed_waypoints: timeline.printed.iter().filter(|p| p.is_some()).count(),
        tip_deviation_max_mm: dev.iter().copied().fold(0.0, f64::max),
        tip_deviation_p99_mm: measure::quantile(dev.clone(), 0.99),
        tip_deviation_over_tolerance: count(ProblemKind::TipDeviation),
        speed_violation_pct: 100.0 * violating.len() as f64 / ext.len().max(1) as f64,
        speed_violation_pct_length: 100.0 * violating.iter().map(|r| r.length_mm).sum::<f64>()
            / extruded.max(1e-18)
            + 0.0,
        rotary_step_max_deg: ext
            .iter()
            .map(|(_, r)| r.rotary_step_deg)
            .fold(0.0, f64::max),
        swings: count(ProblemKind::Swing),
        travels: travels.len(),
        travel_c_max_deg: travels.iter().map(|t| t.1).fold(0.0, f64::max),
        long_travel_turns: count(ProblemKind::LongTravelTurn),
        e_per_mm_median: measure::median(ext.iter().map(|(_, r)| r.e_per_mm)),
        e_per_mm_max: ext.iter().map(|(_, r)| r.e_per_mm).fold(0.0, f64::max),
        blobs: count(ProblemKind::Blob),
    };
    Simulation {
        summary,
        problems,
        moves: reports,
    }
}

/// A program whose every move is already proven free (a plan's), read
/// back from its text and measured as any program is: its moves, when
/// it prints `toolpath`'s waypoints, and what [`report`] finds in it
/// without checking collisions again. Its problems and durations are
/// `simulate`'s; tip deviations are sampled only where they may pass
/// the tolerance ([`Deviation::OverTolerance`]: elsewhere the summary's
/// deviation figures are the bow's bounds).
pub fn replay(
    m: &Machine,
    toolpath: &Toolpath,
    gcode: &str,
    margin: f64,
) -> Result<(Vec<GcodeMove>, Timeline, Simulation), GcodeError> {
    let moves = read_program(gcode, m)?;
    let timeline = timeline(m, toolpath, &moves);
    let unchecked = vec![None; moves.len()];
    let sim = report(
        m,
        &moves,
        &timeline,
        &unchecked,
        0,
        margin,
        Deviation::OverTolerance,
    );
    Ok((moves, timeline, sim))
}

//! Stage 7, verify: the written program re-checked pose by pose and move
//! by move and measured ([`Metrics`]), and the plan's waypoints as
//! plan.csv lists them; beside the stages, the input as given measured by
//! the same rules (direct IK, C unwound, orientations unchanged).

use super::extrusion::Extrusion;
use super::graph::Route;
use super::metrics::{self, Metrics, SegmentStats};
use super::program::{motion_specs, Move, Program};
use super::setup::{distance, Setup};
use super::{singular, PlanError, PlannedWaypoint, Skip};
use crate::kinematics::{ik_angles, orientation, wrap, Axes, Machine};
use crate::prove::{MoveSpec, Prover};
use crate::scene::cutoff;
use glam::DVec3;
use rayon::prelude::*;
use std::ops::Range;

/// Sample spacing of the input's own moves (mm of head motion).
pub const INPUT_STEP: f64 = 2.0;

/// Skipped waypoints named one by one in the warnings (report.json and
/// plan.csv list them all).
const NAMED_SKIPS: usize = 20;

/// Stage 7's result.
pub(super) struct Verified {
    /// The plan's figures.
    pub metrics: Metrics,
    /// Every waypoint as planned (the input's side not filled in yet:
    /// [`with_input`]).
    pub waypoints: Vec<PlannedWaypoint>,
    /// What the user should know, one line each.
    pub warnings: Vec<String>,
}

/// Stage 7: the written `program` re-checked with `prover` and measured,
/// with the `route` it prints and the E and heights of `extruded`.
pub(super) fn verify(
    setup: &Setup,
    route: &Route,
    extruded: &Extrusion,
    program: &Program,
    prover: &Prover,
) -> Result<Verified, PlanError> {
    let n = setup.waypoints();
    let written = Written::of(setup.machine, program, n);
    let visited: Vec<(Axes, u32)> = (0..n)
        .filter_map(|g| written.at[g].map(|a| (a, cutoff(g))))
        .collect();
    let pose_hits = prover.poses_at(&visited, prover.margin)?;
    let move_hits = prover.moves(&written.specs)?;
    let mut metrics = Metrics {
        waypoints: n,
        residual_collisions: pose_hits.iter().filter(|&&h| h).count(),
        colliding_edges: move_hits.iter().filter(|&&h| h).count(),
        program_moves: written.specs.len(),
        axis_limit_violations: written.axis_limit_violations,
        tip_deviation_max_mm: written.tip_deviation,
        travel_c_max_deg: written.travel_c,
        breaks: route
            .sections
            .iter()
            .map(|s| s.breaks.iter().filter(|&&b| b).count())
            .sum(),
        ..Metrics::default()
    };
    measure_beads(setup, route, &extruded.heights, &written.at, &mut metrics);
    count_skipped(&route.skip, &mut metrics);
    let waypoints = planned_waypoints(setup, route, extruded, &written.at);
    measure_orientations(setup, &waypoints, &mut metrics);
    let warnings = warnings(setup, &route.skip, &waypoints, &metrics, prover.margin);
    Ok(Verified {
        metrics,
        waypoints,
        warnings,
    })
}

/// What the written program says before any query is asked.
struct Written {
    /// Where the program puts each waypoint it visits.
    at: Vec<Option<Axes>>,
    /// Its moves that move the axes, as the prover proves them.
    specs: Vec<MoveSpec>,
    /// Largest tip deviation of an extruding move (mm).
    tip_deviation: f64,
    /// Largest C rotation between two extruding moves (degrees).
    travel_c: f64,
    /// Positions outside the machine's axis ranges.
    axis_limit_violations: usize,
}

impl Written {
    /// Read `program` (of a toolpath of `n` waypoints) on machine `m`. The
    /// moves themselves are let go on return, before the prover's own
    /// work: the checks need only their specs.
    fn of(m: &Machine, program: &Program, n: usize) -> Self {
        let moves = program.moves(m);
        let mut at: Vec<Option<Axes>> = vec![None; n];
        for (_, mv) in &moves {
            if let Some(g) = mv.waypoint {
                at[g] = Some(mv.to);
            }
        }
        let tip_deviation = largest_tip_deviation(m, &moves);
        let mut travel_c: f64 = 0.0;
        let mut run_c = 0.0;
        let mut axis_limit_violations = 0;
        for (from, mv) in &moves {
            if mv.kind.extrudes() {
                travel_c = travel_c.max(run_c);
                run_c = 0.0;
            } else {
                run_c += (mv.to.c - from.c).abs().to_degrees();
            }
            if metrics::outside_limits(m, &mv.to) {
                axis_limit_violations += 1;
            }
        }
        Written {
            at,
            specs: motion_specs(&moves),
            tip_deviation,
            travel_c: travel_c.max(run_c),
            axis_limit_violations,
        }
    }
}

/// The segment figures of the beads printed between consecutive visited
/// waypoints, as written (between the tips the axes `at` give), and the
/// share of them whose layer height is the clamp's.
fn measure_beads(
    setup: &Setup,
    route: &Route,
    heights: &[super::extrusion::Height],
    at: &[Option<Axes>],
    out: &mut Metrics,
) {
    let m = setup.machine;
    let mut stats = SegmentStats::default();
    let mut clamped = 0usize;
    let mut segments = 0usize;
    for sec in &route.sections {
        let cm = setup.cost_model(setup.toolpath.layer_of[sec.waypoints.start]);
        for (k, g) in sec.waypoints.clone().enumerate().skip(1) {
            if sec.breaks[k] {
                continue;
            }
            let (a, b) = (at[g - 1].expect("visited"), at[g].expect("visited"));
            let len = distance(m.tip(&a), m.tip(&b));
            stats.add(&cm, len, &a, &b);
            segments += 1;
            clamped += (heights[g - 1].clamped || heights[g].clamped) as usize;
        }
    }
    stats.finish(out);
    out.height_clamped_pct = 100.0 * clamped as f64 / segments.max(1) as f64;
}

/// The skipped waypoints, and how many for each reason.
fn count_skipped(skip: &[Option<Skip>], out: &mut Metrics) {
    let count = |why: Option<Skip>| skip.iter().filter(|&&s| s == why).count();
    out.skipped_waypoints = skip.iter().filter(|s| s.is_some()).count();
    out.unreachable_waypoints = count(Some(Skip::Unreachable));
    out.isolated_waypoints = count(Some(Skip::Isolated));
}

/// Every waypoint as planned, at the axes `at` the program puts it (the
/// skipped ones with default axes and their input directions).
fn planned_waypoints(
    setup: &Setup,
    route: &Route,
    extruded: &Extrusion,
    at: &[Option<Axes>],
) -> Vec<PlannedWaypoint> {
    let (toolpath, n) = (setup.toolpath, setup.waypoints());
    let mut section_start = vec![false; n];
    let mut break_before = vec![false; n];
    for sec in &route.sections {
        if let Some(g) = sec.waypoints.clone().find(|&g| route.skip[g].is_none()) {
            section_start[g] = true;
        }
        for (k, g) in sec.waypoints.clone().enumerate() {
            break_before[g] = sec.breaks[k] && !section_start[g];
        }
    }
    let rot = setup.machine.rotary;
    (0..n)
        .map(|g| {
            let (axes, dir) = match at[g] {
                Some(a) => (a, orientation(rot, a.tilt, a.c)),
                None => (Axes::default(), toolpath.input_dirs[g]),
            };
            let layer = toolpath.layer_of[g];
            PlannedWaypoint {
                layer,
                support: toolpath.layer_is_support[layer],
                p: toolpath.pos[g],
                n: dir,
                axes,
                e: extruded.e[g],
                height: extruded.heights[g].h,
                section_start: section_start[g],
                break_before: break_before[g],
                was_colliding: false,
                was_singular: toolpath.was_singular[g],
                singular: at[g].is_some() && singular::is_singular(dir, setup.opts.alpha),
                skipped: route.skip[g],
            }
        })
        .collect()
}

/// The planned orientations' figures: how many are singular, and how far
/// the visited ones turned from the input's.
fn measure_orientations(setup: &Setup, waypoints: &[PlannedWaypoint], out: &mut Metrics) {
    out.singular_waypoints = waypoints.iter().filter(|w| w.singular).count();
    let deviation: Vec<f64> = waypoints
        .iter()
        .zip(&setup.toolpath.input_dirs)
        .filter(|(w, _)| w.skipped.is_none())
        .map(|(w, n)| {
            let cos = DVec3::from(w.n).dot(DVec3::from(*n));
            cos.clamp(-1.0, 1.0).acos().to_degrees()
        })
        .collect();
    out.max_deviation_deg = deviation.iter().copied().fold(0.0, f64::max);
    out.mean_deviation_deg = deviation.iter().sum::<f64>() / deviation.len().max(1) as f64;
}

/// The warnings a user must see: the first few skipped waypoints by name,
/// the isolated ones, machine Z below 0, moves not proven to keep the
/// `margin`.
fn warnings(
    setup: &Setup,
    skip: &[Option<Skip>],
    waypoints: &[PlannedWaypoint],
    metrics: &Metrics,
    margin: f64,
) -> Vec<String> {
    let toolpath = setup.toolpath;
    let mut out = Vec::new();
    let unsafe_skips: Vec<usize> = (0..skip.len())
        .filter(|&g| skip[g].is_some() && skip[g] != Some(Skip::Isolated))
        .collect();
    for &g in unsafe_skips.iter().take(NAMED_SKIPS) {
        let l = toolpath.layer_of[g];
        let why = match skip[g] {
            Some(Skip::Unreachable) => "outside the machine's axis ranges in every orientation",
            _ => "no orientation the machine can reach keeps the safety margin",
        };
        out.push(format!(
            "waypoint {g} (layer {l}, #{} in it) skipped: {why}",
            g - toolpath.layer_start[l]
        ));
    }
    if unsafe_skips.len() > NAMED_SKIPS {
        out.push(format!(
            "{} more waypoints skipped (listed in report.json and plan.csv)",
            unsafe_skips.len() - NAMED_SKIPS
        ));
    }
    if metrics.isolated_waypoints > 0 {
        out.push(format!(
            "{} isolated waypoint(s) not visited: no bead is printed to or from them",
            metrics.isolated_waypoints
        ));
    }
    let below = waypoints
        .iter()
        .filter(|w| w.skipped.is_none() && w.axes.xyz[2] < 0.0)
        .count();
    if below > 0 {
        out.push(format!(
            "{below} waypoint(s) put machine Z below 0: check --place and the machine's Z origin"
        ));
    }
    if metrics.colliding_edges > 0 {
        out.push(format!(
            "{} move(s) of the program could not be proven to keep the {margin:.3} mm margin",
            metrics.colliding_edges
        ));
    }
    out
}

/// The input as given, measured: its figures, its axes (direct IK, C
/// unwound) and which of its poses collide.
pub(super) struct InputMeasured {
    /// The input's figures.
    pub metrics: Metrics,
    /// Its axes, per waypoint ([`input_axes`]).
    pub axes: Vec<Axes>,
    /// Per waypoint: its pose comes within the margin of material.
    pub colliding: Vec<bool>,
}

/// The input's metrics, its axes and which of its poses collide: a move
/// from or to a pose within the margin collides; the others — C swings of
/// hundreds of degrees between neighbours, mostly — are sampled
/// ([`INPUT_STEP`] mm of head motion apart, at most 16 samples), so the
/// colliding-edge count is a lower bound. It needs nothing the planner
/// finds, so it runs beside the stages.
pub(super) fn measure_input(setup: &Setup, prover: &Prover) -> Result<InputMeasured, PlanError> {
    let (m, toolpath) = (setup.machine, setup.toolpath);
    let axes = input_axes(m, &toolpath.pos, &toolpath.input_dirs, &toolpath.runs);
    let items: Vec<(Axes, u32)> = axes
        .iter()
        .enumerate()
        .map(|(g, a)| (*a, cutoff(g)))
        .collect();
    let hit = prover.poses_at(&items, prover.margin)?;
    let edges: Vec<usize> = toolpath
        .runs
        .iter()
        .flat_map(|r| r.start + 1..r.end)
        .collect();
    let specs: Vec<MoveSpec> = edges
        .iter()
        .filter(|&&g| !hit[g - 1] && !hit[g])
        .map(|&g| MoveSpec {
            from: axes[g - 1],
            to: axes[g],
            cutoff: cutoff(g - 1),
        })
        .collect();
    let sampled = prover.sampled_moves(&specs, INPUT_STEP, 16)?;
    let colliding_edges = edges.len() - specs.len() + sampled.iter().filter(|&&h| h).count();
    let mut out = Metrics {
        waypoints: toolpath.pos.len(),
        residual_collisions: hit.iter().filter(|&&h| h).count(),
        colliding_edges,
        singular_waypoints: toolpath.was_singular.iter().filter(|&&s| s).count(),
        ..Metrics::default()
    };
    let mut stats = SegmentStats::default();
    for r in &toolpath.runs {
        let cm = setup.cost_model(toolpath.layer_of[r.start]);
        for g in r.start + 1..r.end {
            let len = distance(toolpath.pos[g - 1], toolpath.pos[g]);
            stats.add(&cm, len, &axes[g - 1], &axes[g]);
        }
    }
    stats.finish(&mut out);
    out.axis_limit_violations = axes
        .iter()
        .filter(|a| metrics::outside_limits(m, a))
        .count();
    Ok(InputMeasured {
        metrics: out,
        axes,
        colliding: hit,
    })
}

/// The planned `waypoints` with the input's side filled in: whether the
/// input's pose collided, and for the skipped ones the input's axes.
pub(super) fn with_input(
    waypoints: Vec<PlannedWaypoint>,
    input: &InputMeasured,
) -> Vec<PlannedWaypoint> {
    waypoints
        .into_iter()
        .zip(&input.axes)
        .zip(&input.colliding)
        .map(|((mut w, axes), &colliding)| {
            w.was_colliding = colliding;
            if w.skipped.is_some() {
                w.axes = *axes;
            }
            w
        })
        .collect()
}

/// The largest tip deviation of the extruding moves (sampled as a
/// controller interpolates, [`metrics::tip_deviation`]: 63 poses a move).
/// No move deviates more than its analytic bound
/// ([`crate::prove::tip_deviation_bound`]), so moves are sampled in order of
/// their bounds, largest first, in parallel blocks, until no bound left
/// can beat the largest found: the same maximum as sampling every move.
fn largest_tip_deviation(m: &Machine, moves: &[(Axes, Move)]) -> f64 {
    largest_tip_deviation_in(m, moves, 4096)
}

/// [`largest_tip_deviation`], sampling `block` moves at a time.
fn largest_tip_deviation_in(m: &Machine, moves: &[(Axes, Move)], block: usize) -> f64 {
    let mut bounded: Vec<(f64, usize)> = moves
        .par_iter()
        .enumerate()
        .filter(|(_, (_, mv))| mv.kind.extrudes())
        .map(|(i, (from, mv))| (crate::prove::tip_deviation_bound(m, from, &mv.to), i))
        .collect();
    bounded.par_sort_unstable_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    let mut best: f64 = 0.0;
    for block in bounded.chunks(block) {
        // (Rounding: a bound is compared with a little to spare.)
        if block[0].0 * (1.0 + 1e-9) + 1e-12 < best {
            break;
        }
        best = block
            .par_iter()
            .map(|&(_, i)| metrics::tip_deviation(m, &moves[i].0, &moves[i].1.to))
            .reduce(|| best, f64::max);
    }
    best
}

/// Direct IK of the input, as written: per waypoint the solution closest
/// to the previous one (the first: the smaller |C|), C unwound along each
/// run. This is how `check` poses the head too.
pub fn input_axes(
    m: &Machine,
    pos: &[[f64; 3]],
    n: &[[f64; 3]],
    runs: &[Range<usize>],
) -> Vec<Axes> {
    let rot = m.rotary;
    let mut out = vec![Axes::default(); pos.len()];
    for r in runs {
        let mut prev: Option<(f64, f64)> = None;
        for i in r.clone() {
            let s = ik_angles(rot, n[i]);
            let pick = match prev {
                None => {
                    if s[1].1.abs() < s[0].1.abs() {
                        s[1]
                    } else {
                        s[0]
                    }
                }
                Some((pt, pc)) => {
                    let cost = |x: (f64, f64)| (x.0 - pt).abs() + wrap(x.1 - pc).abs();
                    let best = if cost(s[1]) < cost(s[0]) { s[1] } else { s[0] };
                    (best.0, pc + wrap(best.1 - pc))
                }
            };
            out[i] = m.axes_at(pos[i], pick);
            prev = Some((out[i].tilt, out[i].c));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::super::program::MoveKind;
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The pruned search finds what sampling every extruding move finds,
    /// and ignores moves that do not extrude however far they bow.
    #[test]
    fn the_largest_tip_deviation_matches_sampling_every_move() {
        let m = Machine::default();
        let mut rng = ChaCha8Rng::seed_from_u64(0x2545_f491_4f6c_dd1d);
        let mut rnd = || rng.random::<f64>();
        let mut moves = Vec::new();
        for k in 0..20_000 {
            let p = [
                rnd() * 100.0 - 50.0,
                rnd() * 100.0 - 50.0,
                40.0 + rnd() * 30.0,
            ];
            let (t, c) = ((rnd() * 90.0 - 45.0).to_radians(), rnd() * 6.0);
            let from = m.axes_at(p, (t, c));
            let kind = if k % 10 == 0 {
                MoveKind::Travel
            } else {
                MoveKind::Print
            };
            // Travels turn far; beads a little, some more than others.
            let turn = if kind == MoveKind::Travel {
                2.0
            } else {
                rnd().powi(4) * 0.3
            };
            let q = [p[0] + rnd() - 0.5, p[1] + rnd() - 0.5, p[2] + 0.1 * rnd()];
            let to = m.axes_at(q, (t + 0.3 * turn, c + turn));
            let mv = Move {
                kind,
                to,
                e: 0.0,
                feed: 10.0,
                cutoff: 1,
                waypoint: None,
                offset: [0.0; 2],
            };
            moves.push((from, mv));
        }
        let plain = moves
            .iter()
            .filter(|(_, mv)| mv.kind.extrudes())
            .map(|(from, mv)| metrics::tip_deviation(&m, from, &mv.to))
            .fold(0.0, f64::max);
        let all = moves
            .iter()
            .map(|(from, mv)| metrics::tip_deviation(&m, from, &mv.to))
            .fold(0.0, f64::max);
        assert!(plain > 0.0 && all > plain);
        for block in [1, 7, 4096] {
            assert_eq!(largest_tip_deviation_in(&m, &moves, block), plain);
        }
    }
}

//! The [`Prover`]: boolean queries turned into proofs about whole moves.
//!
//! An interval `[a, b]` of a move is proven when `λ_a + λ_b ≥ b − a`, or
//! one end alone reaches `b − a` (levels: [`super::levels`]): every pose in
//! between is within reach of one end's clearance; the same holds for
//! material points seen from the head, so containment cannot appear in
//! between either. Samples start `step` mm of tip travel apart and are
//! asked half their intervals each; where one fails, its intervals are
//! halved, down to `min_step`. A move is declared colliding only when it
//! cannot be proven at that resolution.
//!
//! Work is shared where moves meet. A waypoint's own pose is asked once,
//! in the columns, for what the beads to its neighbours will ask of their
//! ends ([`Prover::end_need`]), and the answer is kept as a sloped
//! clearance, so those beads start proven at that end. Ends that several
//! moves ask in the same round (the bead into a pose and the bead out of
//! it, the pieces of a split bead) are one query asking the most any of
//! them needs (`share_ends`).

use super::bounds::{displacement_bound, sweep, Sweep};
use super::levels::{level_query, Clearance};
use crate::collide::moves::SampledMove;
use crate::collide::{Backend, CollideError};
use crate::geometry::Pose;
use crate::kinematics::{Axes, Machine};
use crate::scene::Query;
use rayon::prelude::*;
use rustc_hash::FxHashMap as HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;
use std::time::Instant;

/// One joint-linear move to prove: from `from` to `to` with the material
/// of stamps below `cutoff` present.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MoveSpec {
    /// Start axes.
    pub from: Axes,
    /// End axes.
    pub to: Axes,
    /// Material with `stamp < cutoff` exists during the move.
    pub cutoff: u32,
}

type Key = [i32; 11];

/// A move's identity on the program's grid (micrometres, millidegrees, in
/// 32 bits: ±2 km, ±5,965 turns), with C taken modulo a turn at the start:
/// moves that differ only by whole turns of C are the same motion.
fn key(mv: &MoveSpec) -> Key {
    let um = |x: f64| (x * 1000.0).round() as i32;
    let md = |a: f64| (a.to_degrees() * 1000.0).round() as i32;
    let (a, b) = (&mv.from, &mv.to);
    let (ca, cb) = (md(a.c), md(b.c));
    [
        um(a.xyz[0]),
        um(a.xyz[1]),
        um(a.xyz[2]),
        md(a.tilt),
        ca.rem_euclid(360_000),
        um(b.xyz[0]),
        um(b.xyz[1]),
        um(b.xyz[2]),
        md(b.tilt),
        cb.wrapping_sub(ca),
        mv.cutoff as i32,
    ]
}

/// A pose's identity on the program's grid, with its cutoff.
fn pose_key(a: &Axes, cutoff: u32) -> PoseKey {
    let um = |x: f64| (x * 1000.0).round() as i32;
    let md = |a: f64| (a.to_degrees() * 1000.0).round() as i32;
    [
        um(a.xyz[0]),
        um(a.xyz[1]),
        um(a.xyz[2]),
        md(a.tilt),
        md(a.c).rem_euclid(360_000),
        cutoff as i32,
    ]
}

/// [`pose_key`]'s value.
type PoseKey = [i32; 6];

/// The most intervals a move starts with. A sample asks the margin plus
/// half its interval's travel: a travel that turns the part far (hundreds
/// of mm of sweep) asked several millimetres at 64 intervals, and such a
/// query beside the part walks every node within them down to its
/// triangles (on dome_cut tilted 70°, 34 k queries over 8 mm took 10 of
/// the program stage's 12 serial seconds; at 128 they lie away from the
/// part and take 10 ms). More intervals cost more queries again (192: the
/// stage 20 % slower than 128).
pub const MAX_FIRST_SAMPLES: usize = 128;

/// Proves poses and joint-linear moves free at the safety margin, with
/// one backend, in batches. What it has proven is kept (moves keyed by
/// their exact values, poses by theirs and the margins known free or
/// colliding), so re-checking a written program costs only its new poses
/// and moves.
pub struct Prover<'a> {
    machine: &'a Machine,
    backend: &'a dyn Backend,
    reach: f64,
    /// The safety margin every pose and move must keep (mm).
    pub margin: f64,
    /// Initial spacing of the samples of a move: the largest distance the
    /// tip moves between two of them (mm); long moves start with at most
    /// [`MAX_FIRST_SAMPLES`].
    pub step: f64,
    /// Finest spacing before a move is declared colliding (mm). Poses are
    /// checked with `margin + min_step` so that the moves out of them can
    /// always be proven.
    pub min_step: f64,
    /// Moves proven, by their identity ([`key`]): `true` where one
    /// collides (or cannot be proven free).
    move_verdicts: Mutex<HashMap<Key, bool>>,
    /// Poses known free, and what they are known free at (colliding
    /// poses are not kept: they are rarely asked again).
    pose_clearances: Mutex<HashMap<PoseKey, Clearance>>,
    queries: AtomicU64,
    /// Backend calls made, the nanoseconds spent in them, and of those
    /// the queries answered beside and the nanoseconds that took.
    calls: AtomicU64,
    answering_ns: AtomicU64,
    beside: AtomicU64,
    beside_ns: AtomicU64,
    /// Hears `(done, total)` queries of each batch as it is answered.
    ticker: Option<Ticker<'a>>,
    /// Where queries that reach farther than the backend answers well
    /// ([`Backend::wide_above`]) go instead, and that reach (mm).
    wide: Option<(&'a dyn Backend, f32)>,
}

/// What a [`Prover`]'s backend calls took, so far or over a stage (the
/// difference of two readings): the evaluator's share of the planner's
/// time, the rest being the planner's own work.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Answering {
    /// Backend calls made.
    pub calls: u64,
    /// The wall time spent in them (s).
    pub seconds: f64,
    /// Queries sent to the backend beside ([`Prover::with_wide`]).
    pub beside: u64,
    /// The wall time the backend beside took over them (s), at the same
    /// time as the backend answered the others.
    pub beside_seconds: f64,
}

impl std::ops::Sub for Answering {
    type Output = Answering;
    fn sub(self, earlier: Answering) -> Answering {
        Answering {
            calls: self.calls - earlier.calls,
            seconds: self.seconds - earlier.seconds,
            beside: self.beside - earlier.beside,
            beside_seconds: self.beside_seconds - earlier.beside_seconds,
        }
    }
}

/// Run `call`, adding `count.1` to the counter `count.0` and the
/// nanoseconds it took to `ns`.
fn timed_into<T>(count: (&AtomicU64, u64), ns: &AtomicU64, call: impl FnOnce() -> T) -> T {
    let asked = Instant::now();
    let out = call();
    count.0.fetch_add(count.1, Ordering::Relaxed);
    ns.fetch_add(asked.elapsed().as_nanos() as u64, Ordering::Relaxed);
    out
}

/// Where a [`Prover`] reports the progress of its batches.
pub type Ticker<'a> = &'a (dyn Fn(u64, u64) + Sync);

/// Queries per backend call when a [`Ticker`] listens: large enough to
/// keep a batch backend busy (or the backend's own
/// [`Backend::batch_hint`], when larger), small enough for a progress bar
/// to move.
const TICK_BATCH: usize = 1 << 16;

/// Per-sample state of a move being proven: parameter, largest level it
/// is known free at, smallest level it is known to fail at (levels:
/// [`level_query`]).
#[derive(Clone, Copy)]
struct Sample {
    t: f64,
    free: f64,
    hit: f64,
    /// An end whose shared query failed: asked on its own from now on.
    solo: bool,
}

impl<'a> Prover<'a> {
    /// A prover for `machine` over `backend`; `reach` is the head's largest
    /// distance from its tip (mm).
    pub fn new(
        machine: &'a Machine,
        backend: &'a dyn Backend,
        reach: f64,
        margin: f64,
        step: f64,
    ) -> Self {
        Prover {
            machine,
            backend,
            reach,
            margin,
            step: step.max(1e-3),
            min_step: 0.005,
            move_verdicts: Mutex::new(HashMap::default()),
            pose_clearances: Mutex::new(HashMap::default()),
            queries: AtomicU64::new(0),
            calls: AtomicU64::new(0),
            answering_ns: AtomicU64::new(0),
            beside: AtomicU64::new(0),
            beside_ns: AtomicU64::new(0),
            ticker: None,
            wide: None,
        }
    }

    /// Answer the queries that reach farther than the backend answers
    /// well ([`Backend::wide_above`]) on `beside`, at the same time as the
    /// backend answers the others. Both must give the same verdicts (every
    /// backend does: the differential tests hold them to it), so which
    /// answers a query changes no plan.
    pub fn with_wide(mut self, beside: &'a dyn Backend) -> Self {
        self.wide = self.backend.wide_above().map(|above| (beside, above));
        self
    }

    /// Report every batch's progress to `ticker` (queries done, total).
    pub fn with_ticker(mut self, ticker: Ticker<'a>) -> Self {
        self.ticker = Some(ticker);
        self
    }

    /// Collision queries answered so far.
    pub fn queries(&self) -> u64 {
        self.queries.load(Ordering::Relaxed)
    }

    /// The backend calls made so far and the wall time they took.
    pub fn answering(&self) -> Answering {
        let seconds = |ns: &AtomicU64| ns.load(Ordering::Relaxed) as f64 * 1e-9;
        Answering {
            calls: self.calls.load(Ordering::Relaxed),
            seconds: seconds(&self.answering_ns),
            beside: self.beside.load(Ordering::Relaxed),
            beside_seconds: seconds(&self.beside_ns),
        }
    }

    /// The margin poses are checked with: the safety margin plus the
    /// finest step, so every accepted pose can start a provable move.
    pub fn pose_margin(&self) -> f64 {
        self.margin + self.min_step
    }

    fn evaluate(&self, q: &[Query]) -> Result<Vec<bool>, CollideError> {
        self.evaluate_made(q.len(), |i| q[i])
    }

    /// [`Prover::evaluate`] over the `n` queries `query` makes, made a
    /// backend call at a time: a round of a large program asks millions,
    /// whose records, made all at once, stood at a tenth of the plan's
    /// peak. The [`Ticker`] hears each call.
    fn evaluate_made(
        &self,
        n: usize,
        query: impl Fn(usize) -> Query + Sync,
    ) -> Result<Vec<bool>, CollideError> {
        self.queries.fetch_add(n as u64, Ordering::Relaxed);
        let call = TICK_BATCH.max(self.backend.batch_hint());
        let mut out = Vec::with_capacity(n);
        for start in (0..n).step_by(call) {
            let q: Vec<Query> = (start..(start + call).min(n))
                .into_par_iter()
                .map(&query)
                .collect();
            out.extend(self.timed(|| self.evaluate_call(&q))?);
            if let Some(tick) = self.ticker {
                tick(out.len() as u64, n as u64);
            }
        }
        Ok(out)
    }

    /// One backend call's queries: those reaching farther than the backend
    /// answers well go to the backend beside ([`Prover::with_wide`]).
    fn evaluate_call(&self, q: &[Query]) -> Result<Vec<bool>, CollideError> {
        let Some((beside, above)) = self.wide else {
            return self.backend.evaluate(q);
        };
        // A query's margin at the head's farthest point.
        let reach = self.reach as f32;
        let wide: Vec<bool> = q
            .iter()
            .map(|x| x.margin + x.slope * reach > above)
            .collect();
        if !wide.contains(&true) {
            return self.backend.evaluate(q);
        }
        let pick = |far: bool| -> Vec<Query> {
            q.iter()
                .zip(&wide)
                .filter(|&(_, &w)| w == far)
                .map(|(x, _)| *x)
                .collect()
        };
        let (far, near) = (pick(true), pick(false));
        let (near, far) = rayon::join(
            || self.backend.evaluate(&near),
            || {
                let counted = (&self.beside, far.len() as u64);
                timed_into(counted, &self.beside_ns, || beside.evaluate(&far))
            },
        );
        let (mut near, mut far) = (near?.into_iter(), far?.into_iter());
        Ok(wide
            .into_iter()
            .map(|w| if w { far.next() } else { near.next() })
            .map(|v| v.expect("a verdict per query"))
            .collect())
    }

    fn query(&self, a: &Axes, cutoff: u32, margin: f64) -> Query {
        self.query_pose(self.machine.pose(a), cutoff, margin)
    }

    fn query_pose(&self, pose: Pose, cutoff: u32, margin: f64) -> Query {
        Query {
            pose,
            cutoff,
            margin: margin as f32,
            slope: 0.0,
        }
    }

    /// Do the poses `(axes, cutoff)` come within the pose margin of
    /// existing material? One verdict each.
    pub fn poses(&self, items: &[(Axes, u32)]) -> Result<Vec<bool>, CollideError> {
        self.poses_at(items, self.pose_margin())
    }

    /// [`Prover::poses`] for poses that are usually free (a waypoint's own
    /// orientation), each first asked once for what the moves into and
    /// out of it will ask of their ends ([`Prover::poses_short_of_need`]), so
    /// those moves start proven at their ends; only those that fail are
    /// asked again at the pose margin (a pose that merely grazes is free).
    /// `needs[i]` is item `i`'s `(margin, slope)`.
    pub fn poses_wide(
        &self,
        items: &[(Axes, u32)],
        needs: &[(f64, f64)],
    ) -> Result<Vec<bool>, CollideError> {
        let wide = self.poses_short_of_need(items, needs)?;
        let near: Vec<usize> = (0..items.len()).filter(|&i| wide[i]).collect();
        let again: Vec<(Axes, u32)> = near.iter().map(|&i| items[i]).collect();
        let hits = self.poses(&again)?;
        let mut out = vec![false; items.len()];
        for (&i, h) in near.iter().zip(hits) {
            out[i] = h;
        }
        Ok(out)
    }

    /// Do the poses `(axes, cutoff)` fall short of what the moves into
    /// and out of them will ask of their ends ([`Prover::end_need`]: a
    /// margin of at least `margin + step / 2`, growing with distance from
    /// the tip where the moves turn)? `true` where a pose grazes or
    /// collides; what the others keep is remembered as a sloped
    /// clearance. `needs[i]` is item `i`'s `(margin, slope)`.
    pub fn poses_short_of_need(
        &self,
        items: &[(Axes, u32)],
        needs: &[(f64, f64)],
    ) -> Result<Vec<bool>, CollideError> {
        let q: Vec<Query> = items
            .par_iter()
            .zip(needs)
            .map(|(&(a, cutoff), &(margin, slope))| Query {
                slope: slope as f32,
                ..self.query(&a, cutoff, margin)
            })
            .collect();
        let wide = self.evaluate(&q)?;
        let mut known = self.pose_clearances.lock().expect("prover cache");
        for ((&(a, cutoff), &(margin, slope)), &h) in items.iter().zip(needs).zip(&wide) {
            if !h {
                let e = known
                    .entry(pose_key(&a, cutoff))
                    .or_insert(Clearance::new(margin, slope));
                *e = e.merged(Clearance::new(margin, slope));
            }
        }
        Ok(wide)
    }

    /// The `(margin, slope)` a pose `a` must keep so that the moves
    /// between it and each of `neighbours` need no query at this end:
    /// the level their first samples ask of an end (half the first
    /// interval), as one query (`level_query`); never less than
    /// `margin + step / 2`. Moves that turn too far for a sloped query
    /// (the uniform form) add nothing: their ends are asked as they come.
    pub fn end_need(&self, a: &Axes, neighbours: &[Axes]) -> (f64, f64) {
        let mut need = (self.margin + 0.5 * self.step, 0.0f64);
        for b in neighbours {
            let sw = sweep(self.machine, a, b);
            let level = 0.5 / self.first_samples(&sw) as f64;
            if level * sw.turn < 0.5 {
                let (margin, slope) = level_query(self.margin, &sw, self.reach, level);
                need = (need.0.max(margin), need.1.max(slope));
            }
        }
        need
    }

    /// Intervals a move with sweep `sw` starts with: the tip moves no
    /// farther than `step` over one; long moves (travels) start coarser,
    /// with at most [`MAX_FIRST_SAMPLES`], refined only where material is
    /// near.
    fn first_samples(&self, sw: &Sweep) -> usize {
        ((sw.tip / self.step).ceil() as usize).clamp(1, MAX_FIRST_SAMPLES)
    }

    /// Record that each pose `(a, cutoff)` of `poses` has the verdict of
    /// the pose `(like, cutoff)` it is congruent to (the same head
    /// geometry turned by a symmetry) at the pose margin, where that one's
    /// is known. The keys are made and looked up on every core, under one
    /// lock: a steep part's columns record a mirror for each of a million
    /// poses, which one lock and two lookups at a time made a fifth of
    /// the eager search's own work.
    pub fn same_as_each(&self, poses: &[(Axes, u32, Axes)]) {
        if poses.is_empty() {
            return;
        }
        let mut known = self.pose_clearances.lock().expect("prover cache");
        let found: Vec<(PoseKey, Clearance)> = {
            let known: &HashMap<PoseKey, Clearance> = &known;
            poses
                .par_iter()
                .filter_map(|(a, cutoff, like)| {
                    let k = known.get(&pose_key(like, *cutoff))?;
                    Some((pose_key(a, *cutoff), *k))
                })
                .collect()
        };
        known.reserve(found.len());
        known.extend(found);
    }

    /// Do the poses `(axes, cutoff)` come within `margin` of existing
    /// material? Poses already known free at a larger margin are answered
    /// without a query.
    pub fn poses_at(&self, items: &[(Axes, u32)], margin: f64) -> Result<Vec<bool>, CollideError> {
        let keys: Vec<PoseKey> = items.par_iter().map(|(a, c)| pose_key(a, *c)).collect();
        let mut out: Vec<Option<bool>> = {
            let known = self.pose_clearances.lock().expect("prover cache");
            let known: &HashMap<PoseKey, Clearance> = &known;
            keys.par_iter()
                .map(|k| {
                    known
                        .get(k)
                        .and_then(|free| (free.plain >= margin as f32).then_some(false))
                })
                .collect()
        };
        let todo: Vec<usize> = (0..items.len()).filter(|&i| out[i].is_none()).collect();
        let q: Vec<Query> = todo
            .par_iter()
            .map(|&i| self.query(&items[i].0, items[i].1, margin))
            .collect();
        let hits = self.evaluate(&q)?;
        let mut known = self.pose_clearances.lock().expect("prover cache");
        for (&i, h) in todo.iter().zip(hits) {
            if !h {
                let e = known.entry(keys[i]).or_insert(Clearance::new(margin, 0.0));
                *e = e.merged(Clearance::new(margin, 0.0));
            }
            out[i] = Some(h);
        }
        Ok(out.into_iter().map(|v| v.unwrap_or(true)).collect())
    }

    /// A lower bound for moves too wild to prove (the input's own): does
    /// any of at most `max_samples` poses along each move, about `step` mm
    /// of head motion apart, come within the margin?
    pub fn sampled_moves(
        &self,
        moves: &[MoveSpec],
        step: f64,
        max_samples: usize,
    ) -> Result<Vec<bool>, CollideError> {
        let asked: Vec<SampledMove> = moves
            .par_iter()
            .map(|mv| {
                let d = displacement_bound(self.machine, &mv.from, &mv.to, self.reach);
                let n = ((d / step).ceil() as usize).clamp(1, max_samples + 1);
                SampledMove {
                    from: mv.from,
                    to: mv.to,
                    cutoff: mv.cutoff,
                    margin: self.margin as f32,
                    intervals: n as u32,
                }
            })
            .collect();
        let samples: u64 = asked.iter().map(|m| m.intervals as u64 - 1).sum();
        self.queries.fetch_add(samples, Ordering::Relaxed);
        self.timed(|| self.backend.sampled_moves(self.machine, &asked))
    }

    /// `call` to the backend, counted and timed ([`Prover::answering`]).
    fn timed<T>(&self, call: impl FnOnce() -> T) -> T {
        timed_into((&self.calls, 1), &self.answering_ns, call)
    }

    /// Does each move come within the margin of existing material at any
    /// point (or can it not be proven free)? One verdict each.
    pub fn moves(&self, moves: &[MoveSpec]) -> Result<Vec<bool>, CollideError> {
        let keys: Vec<Key> = moves.par_iter().map(key).collect();
        let mut out: Vec<Option<bool>> = {
            let cache = self.move_verdicts.lock().expect("prover cache");
            let cache: &HashMap<Key, bool> = &cache;
            keys.par_iter().map(|k| cache.get(k).copied()).collect()
        };
        let todo: Vec<usize> = (0..moves.len()).filter(|&i| out[i].is_none()).collect();
        let found = self.prove(&todo.iter().map(|&i| moves[i]).collect::<Vec<_>>())?;
        let mut cache = self.move_verdicts.lock().expect("prover cache");
        for (&i, v) in todo.iter().zip(found) {
            cache.insert(keys[i], v);
            out[i] = Some(v);
        }
        Ok(out.into_iter().map(|v| v.unwrap_or(true)).collect())
    }

    /// The adaptive proof (module comment) for moves not in the cache:
    /// rounds of queries, each asking what the undecided moves' unproven
    /// intervals need, until every move is proven or cannot be.
    fn prove(&self, moves: &[MoveSpec]) -> Result<Vec<bool>, CollideError> {
        let sweeps: Vec<Sweep> = moves
            .par_iter()
            .map(|mv| sweep(self.machine, &mv.from, &mv.to))
            .collect();
        let bounds: Vec<f64> = sweeps.iter().map(|s| s.within(self.reach)).collect();
        let mut samples = self.initial_samples(moves, &sweeps, &bounds);
        let mut verdict: Vec<Option<bool>> = vec![None; moves.len()];
        loop {
            let round = Self::next_round(&mut samples, &mut verdict, &bounds, self.min_step);
            if round.is_empty() {
                break;
            }
            let asks = self.asks(moves, &sweeps, &samples, &round);
            let (slot, shared, grown) = share_ends(&asks, |j| end_axes(moves, round[j]));
            let hits = self.ask_shared(moves, &samples, &round, &shared, &grown)?;
            self.record(moves, &mut samples, &round, &asks, (&slot, &grown), &hits);
        }
        Ok(verdict.into_iter().map(|v| v.unwrap_or(true)).collect())
    }

    /// Each move's first samples: intervals over which the tip moves no
    /// farther than `step` (material near the tip is proven at that first
    /// resolution; material farther out, which a turn sweeps faster,
    /// splits the intervals it comes near). The ends start with what is
    /// known of them as poses (a pose free with more material present is
    /// free with less): a plain margin `M` certifies level
    /// `(M − m) / bound`.
    fn initial_samples(
        &self,
        moves: &[MoveSpec],
        sweeps: &[Sweep],
        bounds: &[f64],
    ) -> Vec<Vec<Sample>> {
        let m = self.margin;
        let known = self.pose_clearances.lock().expect("prover cache");
        let known: &HashMap<PoseKey, Clearance> = &known;
        let at = |a: &Axes, cutoff: u32, sw: &Sweep, d: f64| {
            [cutoff, cutoff + 1]
                .iter()
                .filter_map(|&c| known.get(&pose_key(a, c)))
                .map(|k| k.level(m, sw, d))
                .fold(f64::NEG_INFINITY, f64::max)
        };
        sweeps
            .par_iter()
            .zip(bounds)
            .zip(moves)
            .map(|((sw, &d), mv)| {
                let n = self.first_samples(sw);
                (0..=n)
                    .map(|k| Sample {
                        t: k as f64 / n as f64,
                        free: match k {
                            0 => at(&mv.from, mv.cutoff, sw, d),
                            _ if k == n => at(&mv.to, mv.cutoff, sw, d),
                            _ => f64::NEG_INFINITY,
                        },
                        hit: f64::INFINITY,
                        solo: false,
                    })
                    .collect()
            })
            .collect()
    }

    /// One round's requests, `(move, sample, level)`: per undecided move,
    /// the samples to query and at what level, splitting intervals that
    /// cannot be proven as they stand ([`plan_requests`]); moves that are
    /// decided now get their verdict.
    fn next_round(
        samples: &mut [Vec<Sample>],
        verdict: &mut [Option<bool>],
        bounds: &[f64],
        min_step: f64,
    ) -> Vec<(usize, usize, f64)> {
        samples
            .par_iter_mut()
            .zip(verdict.par_iter_mut())
            .zip(bounds.par_iter())
            .enumerate()
            .flat_map_iter(|(i, ((s, v), &d))| {
                let req = if v.is_some() {
                    Vec::new()
                } else {
                    let (req, decided) = plan_requests(s, d, min_step);
                    *v = decided;
                    req
                };
                req.into_iter().map(move |(k, level)| (i, k, level))
            })
            .collect()
    }

    /// What each request of a round asks: the `(margin, slope)` of its
    /// level, and the end it stands at (which neighbouring moves may
    /// share), unless that end is asked on its own.
    fn asks(
        &self,
        moves: &[MoveSpec],
        sweeps: &[Sweep],
        samples: &[Vec<Sample>],
        round: &[(usize, usize, f64)],
    ) -> Vec<Ask> {
        round
            .par_iter()
            .map(|&(i, k, level)| {
                let mv = &moves[i];
                let (margin, slope) = level_query(self.margin, &sweeps[i], self.reach, level);
                let last = samples[i].len() - 1;
                Ask {
                    end: !samples[i][k].solo && (k == 0 || k == last),
                    cutoff: mv.cutoff,
                    margin,
                    slope,
                }
            })
            .collect()
    }

    /// The round's shared queries (`shared[q]`: the request whose pose
    /// query `q` takes; `grown[q]`: what it asks), one verdict each.
    fn ask_shared(
        &self,
        moves: &[MoveSpec],
        samples: &[Vec<Sample>],
        round: &[(usize, usize, f64)],
        shared: &[usize],
        grown: &[Ask],
    ) -> Result<Vec<bool>, CollideError> {
        self.evaluate_made(shared.len(), |q| {
            let (a, (i, k, _)) = (&grown[q], round[shared[q]]);
            let mv = &moves[i];
            let pose = self.machine.pose_along(&mv.from, &mv.to, samples[i][k].t);
            Query {
                slope: a.slope as f32,
                ..self.query_pose(pose, a.cutoff, a.margin)
            }
        })
    }

    /// What a round's answers teach: a free sample's level, a shared end's
    /// clearance (kept as the pose's), a failed sample's level; a shared
    /// query that asked more than this end needs and failed makes the end
    /// ask on its own from now on.
    fn record(
        &self,
        moves: &[MoveSpec],
        samples: &mut [Vec<Sample>],
        round: &[(usize, usize, f64)],
        asks: &[Ask],
        (slot, grown): (&[usize], &[Ask]),
        hits: &[bool],
    ) {
        let mut known = self.pose_clearances.lock().expect("prover cache");
        for (j, &(i, k, level)) in round.iter().enumerate() {
            let q = &grown[slot[j]];
            let s = &mut samples[i][k];
            if !hits[slot[j]] {
                s.free = s.free.max(level);
                // The group shares this end's pose.
                if q.end {
                    let e = known
                        .entry(pose_key(&end_axes(moves, round[j]), q.cutoff))
                        .or_insert(Clearance::new(q.margin, q.slope));
                    *e = e.merged(Clearance::new(q.margin, q.slope));
                }
            } else if asks[j].same_need(q) {
                s.hit = s.hit.min(level);
            } else {
                // The shared query asked more than this end needs.
                s.solo = true;
            }
        }
    }
}

/// One query a round of [`Prover::prove`] needs: a sample of a move at
/// the `(margin, slope)` of its level; `end` when the sample is a move's
/// end (which neighbouring moves may share: [`end_axes`]).
#[derive(Clone, Copy)]
struct Ask {
    end: bool,
    cutoff: u32,
    margin: f64,
    slope: f64,
}

impl Ask {
    /// Does `self` ask as much as `other` on every count?
    fn same_need(&self, other: &Ask) -> bool {
        self.cutoff >= other.cutoff && self.margin >= other.margin && self.slope >= other.slope
    }
}

/// The axes of a round's request `(move, sample, level)` at an end of its
/// move.
fn end_axes(moves: &[MoveSpec], (i, k, _): (usize, usize, f64)) -> Axes {
    if k == 0 {
        moves[i].from
    } else {
        moves[i].to
    }
}

/// Ends of moves asked in the same round at the same pose (the bead into
/// a waypoint and the bead out of it; the pieces of a split bead) become
/// one query asking the most any of them asks — the largest margin, slope
/// and cutoff — which certifies each; `end(j)` is ask `j`'s pose when it
/// is an end. Returns, per ask, the index of its query; per query, the
/// ask whose pose it takes (the first of its group) and what it asks (the
/// group's need).
fn share_ends(asks: &[Ask], end: impl Fn(usize) -> Axes) -> (Vec<usize>, Vec<usize>, Vec<Ask>) {
    let mut first: HashMap<PoseKey, usize> = HashMap::default();
    let mut slot = Vec::with_capacity(asks.len());
    let mut shared: Vec<usize> = Vec::new();
    let mut grown: Vec<Ask> = Vec::new();
    for (j, a) in asks.iter().enumerate() {
        let group = a.end.then(|| pose_key(&end(j), 0));
        match group.and_then(|key| first.get(&key).copied()) {
            Some(q) => {
                let g = &mut grown[q];
                g.cutoff = g.cutoff.max(a.cutoff);
                g.margin = g.margin.max(a.margin);
                g.slope = g.slope.max(a.slope);
                slot.push(q);
            }
            None => {
                if let Some(key) = group {
                    first.insert(key, shared.len());
                }
                slot.push(shared.len());
                shared.push(j);
                grown.push(*a);
            }
        }
    }
    (slot, shared, grown)
}

/// One round of the proof of one move (its farthest moving head point
/// travels `d`): the `(sample, level)` queries its unproven intervals need,
/// splitting each interval that no query can settle any more (an end
/// already failed at the level asked of it). An interval `[a, b]` is
/// proven when `level(a) + level(b) ≥ b − a` (or one end's level alone
/// reaches `b − a`); its ends are asked half
/// each, or, when one end is already known free at a quarter of the span
/// or more, the other asked the rest. Returns the decision instead once
/// the move is proven free (`Some(false)`) or cannot be (`Some(true)`: a
/// blocked interval whose half moves the head less than `min_step`).
fn plan_requests(s: &mut Vec<Sample>, d: f64, min_step: f64) -> (Vec<(usize, f64)>, Option<bool>) {
    // A pose that fails at level 0 comes within the margin itself: no
    // interval around it can be proven, at any resolution.
    if s.iter().any(|x| x.hit <= 0.0) {
        return (Vec::new(), Some(true));
    }
    let stuck: Vec<usize> = (0..s.len() - 1)
        .filter(|&k| !proven(&s[k], &s[k + 1]) && blocked(&s[k], &s[k + 1]))
        .collect();
    let plain = plain_asks(s, &stuck);
    if !plain.is_empty() {
        return (plain, None);
    }
    // Splits, from the last so that the earlier indices stand.
    for &k in stuck.iter().rev() {
        let (a, b) = (s[k], s[k + 1]);
        if 0.5 * d * (b.t - a.t) < min_step {
            return (Vec::new(), Some(true));
        }
        s.insert(
            k + 1,
            Sample {
                t: 0.5 * (a.t + b.t),
                free: f64::NEG_INFINITY,
                hit: f64::INFINITY,
                solo: false,
            },
        );
    }
    // Queries for the ends of every interval not yet proven.
    let mut need: Vec<(usize, f64)> = Vec::new();
    for k in 0..s.len() - 1 {
        let (a, b) = (s[k], s[k + 1]);
        if proven(&a, &b) {
            continue;
        }
        let (wa, wb) = want(&a, &b);
        for (idx, w) in [(k, wa), (k + 1, wb)] {
            if s[idx].free < w && s[idx].hit > w {
                match need.last_mut() {
                    Some(last) if last.0 == idx => last.1 = last.1.max(w),
                    _ => need.push((idx, w)),
                }
            }
        }
    }
    if need.is_empty() {
        // Nothing left to ask: either all proven, or only splits remain.
        let all = (0..s.len() - 1).all(|k| proven(&s[k], &s[k + 1]));
        return (need, all.then_some(false));
    }
    (need, None)
}

/// Is the interval between samples `a` and `b` proven? (The tolerance
/// absorbs rounding.) One end known at the whole span covers the
/// interval alone, whatever is known of the other.
fn proven(a: &Sample, b: &Sample) -> bool {
    let span = (b.t - a.t) * (1.0 - 1e-9);
    a.free >= span || b.free >= span || a.free + b.free >= span
}

/// The levels wanted of the ends of an unproven interval.
fn want(a: &Sample, b: &Sample) -> (f64, f64) {
    let span = b.t - a.t;
    if a.free >= 0.25 * span && a.free >= b.free {
        (a.free, span - a.free)
    } else if b.free >= 0.25 * span {
        (span - b.free, b.free)
    } else {
        (0.5 * span, 0.5 * span)
    }
}

/// Has an end of the interval already failed at the level wanted of it?
fn blocked(a: &Sample, b: &Sample) -> bool {
    let (wa, wb) = want(a, b);
    (a.free < wa && a.hit <= wa) || (b.free < wb && b.hit <= wb)
}

/// A move blocked at this many intervals or more asks its blocking poses
/// at level 0 before any of those intervals is split (`plain_asks`).
const PLAIN_AFTER: usize = 8;

/// The level-0 asks of a move blocked at the intervals `stuck` (each
/// from `s[k]` to `s[k + 1]`), [`PLAIN_AFTER`] or more: each blocking
/// pose not known free at level 0 yet, asked at the plain margin.
/// Halving a move that passes through material along a stretch doubles
/// its samples there each round until they are `min_step` apart, every
/// one a hit (dome_cut's bead model tilted 50°: 18.2 M graph queries,
/// 2.9 M with these asks); one of its poses within the margin settles it
/// at once. A move that only grazes finds its poses free at level 0 and
/// is split a round later; the verdicts are the same, as a pose within
/// the margin is one no proof can cover.
fn plain_asks(s: &[Sample], stuck: &[usize]) -> Vec<(usize, f64)> {
    let mut asks: Vec<(usize, f64)> = Vec::new();
    if stuck.len() < PLAIN_AFTER {
        return asks;
    }
    for &k in stuck {
        let (wa, wb) = want(&s[k], &s[k + 1]);
        for (idx, w) in [(k, wa), (k + 1, wb)] {
            let x = &s[idx];
            if x.free < 0.0 && x.hit <= w && asks.last().is_none_or(|l| l.0 != idx) {
                asks.push((idx, 0.0));
            }
        }
    }
    asks
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::Machine;
    use crate::scene::cutoff;

    fn axes(m: &Machine, p: [f64; 3], tilt_deg: f64, c_deg: f64) -> Axes {
        m.axes_at(p, (tilt_deg.to_radians(), c_deg.to_radians()))
    }

    /// Seven waypoints half a millimetre apart, C turning 2° a step.
    fn chain(m: &Machine) -> Vec<Axes> {
        (0..7)
            .map(|k| axes(m, [0.5 * k as f64, 0.0, 40.0], 10.0, 2.0 * k as f64))
            .collect()
    }

    /// The beads printed along `way`, each with the material of the
    /// waypoints before its start.
    fn beads(way: &[Axes]) -> Vec<MoveSpec> {
        way.windows(2)
            .enumerate()
            .map(|(k, w)| MoveSpec {
                from: w[0],
                to: w[1],
                cutoff: cutoff(k),
            })
            .collect()
    }

    /// A backend that answers by the query alone: a hit when it asks for
    /// more than `margin` and more than `slope` at once (monotone, as
    /// every real backend is: asking more never turns a hit free).
    struct Profile {
        margin: f32,
        slope: f32,
        asked: Mutex<Vec<Query>>,
    }

    impl Backend for Profile {
        fn name(&self) -> &'static str {
            "profile"
        }
        fn evaluate(&self, q: &[Query]) -> Result<Vec<bool>, CollideError> {
            self.asked.lock().unwrap().extend_from_slice(q);
            Ok(q.iter()
                .map(|q| q.margin > self.margin && q.slope > self.slope)
                .collect())
        }
    }

    fn profile(margin: f32, slope: f32) -> Profile {
        Profile {
            margin,
            slope,
            asked: Mutex::new(Vec::new()),
        }
    }

    /// The default machine, a backend that finds every pose free, and
    /// [`chain`] on that machine.
    fn free_chain() -> (Machine, Profile, Vec<Axes>) {
        let m = Machine::default();
        let way = chain(&m);
        (m, profile(f32::INFINITY, f32::INFINITY), way)
    }

    /// The tests' prover: a head reaching 36 mm from its tip, a 0.05 mm
    /// margin, a first sample every 0.3 mm of tip travel.
    fn prover<'a>(m: &'a Machine, backend: &'a Profile) -> Prover<'a> {
        Prover::new(m, backend, 36.0, 0.05, 0.3)
    }

    /// The samples inside `beads` (not their ends) the prover asks first.
    fn interior_samples(prover: &Prover, m: &Machine, beads: &[MoveSpec]) -> usize {
        beads
            .iter()
            .map(|b| prover.first_samples(&sweep(m, &b.from, &b.to)) - 1)
            .sum()
    }

    /// The queries `backend` was asked at the pose of axes `a`.
    fn asked_at(backend: &Profile, m: &Machine, a: &Axes) -> Vec<Query> {
        let pose = m.pose(a);
        let asked = backend.asked.lock().unwrap();
        asked
            .iter()
            .filter(|q| q.pose.tip == pose.tip && q.pose.cols == pose.cols)
            .copied()
            .collect()
    }

    /// A chain of beads through free poses: each waypoint between two beads
    /// is asked once for both (shared ends), not once per bead.
    #[test]
    fn beads_of_a_chain_share_their_ends() {
        let (m, fake, way) = free_chain();
        let prover = prover(&m, &fake);
        let beads = beads(&way);
        let interior = interior_samples(&prover, &m, &beads);
        assert!(prover.moves(&beads).unwrap().iter().all(|&h| !h));
        // Every sample once: the 7 waypoints and the interior samples.
        assert_eq!(prover.queries() as usize, way.len() + interior);
        // A shared end asks what its neighbour's bead needs, with the later
        // bead's material.
        let at_mid = asked_at(&fake, &m, &way[3]);
        assert_eq!(at_mid.first().expect("waypoint 3 asked").cutoff, 4);
    }

    /// Waypoints asked for what their beads need of them
    /// ([`Prover::end_need`]) start those beads proven at both ends: the
    /// beads ask only their interior samples.
    #[test]
    fn waypoints_asked_for_their_beads_need_no_end_samples() {
        let (m, fake, way) = free_chain();
        let prover = prover(&m, &fake);
        let items: Vec<(Axes, u32)> = (0..way.len()).map(|k| (way[k], cutoff(k))).collect();
        let needs: Vec<(f64, f64)> = (0..way.len())
            .map(|k| {
                let near: Vec<Axes> = [k.wrapping_sub(1), k + 1]
                    .iter()
                    .filter_map(|&j| way.get(j).copied())
                    .collect();
                prover.end_need(&way[k], &near)
            })
            .collect();
        // Turning beads need a slope.
        assert!(needs.iter().all(|n| n.1 > 0.0 && n.0 > 0.05));
        assert!(prover
            .poses_wide(&items, &needs)
            .unwrap()
            .iter()
            .all(|&h| !h));
        let before = prover.queries() as usize;
        assert_eq!(before, way.len());
        let beads = beads(&way);
        let interior = interior_samples(&prover, &m, &beads);
        assert!(interior > 0);
        assert!(prover.moves(&beads).unwrap().iter().all(|&h| !h));
        assert_eq!(prover.queries() as usize - before, interior);
    }

    /// When the shared query of an end asks more than one of its beads
    /// needs and fails, each bead asks that end again on its own, and
    /// both are proven; the failure is not held against the weaker ask.
    #[test]
    fn a_failed_shared_end_is_asked_again_alone() {
        let m = Machine::default();
        let (a, b, c) = (
            axes(&m, [0.0, 0.0, 40.0], 10.0, 0.0),
            axes(&m, [0.59, 0.0, 40.0], 10.0, 0.0),
            axes(&m, [0.79, 0.0, 40.0], 10.0, 4.0),
        );
        // What each bead asks of b at its first samples' level.
        let need = |x: &Axes, y: &Axes| {
            let sw = sweep(&m, x, y);
            let n = ((sw.tip / 0.3).ceil() as usize).clamp(1, MAX_FIRST_SAMPLES);
            level_query(0.05, &sw, 36.0, 0.5 / n as f64)
        };
        let ((m1, k1), (m2, k2)) = (need(&a, &b), need(&b, &c));
        assert!(m1 > m2 && k2 > k1, "({m1}, {k1}) ({m2}, {k2})");
        // Free for each alone, a hit for both at once.
        let fake = profile(0.5 * (m1 + m2) as f32, 0.5 * (k1 + k2) as f32);
        let prover = prover(&m, &fake);
        let beads = [
            MoveSpec {
                from: a,
                to: b,
                cutoff: 1,
            },
            MoveSpec {
                from: b,
                to: c,
                cutoff: 2,
            },
        ];
        assert_eq!(prover.moves(&beads).unwrap(), vec![false, false]);
        let ends = asked_at(&fake, &m, &b);
        // Shared (failed), then once for each bead.
        assert_eq!(ends.len(), 3, "{ends:?}");
    }

    /// One end known free for the whole span proves the interval, however
    /// little is known of the other end.
    #[test]
    fn one_end_can_cover_an_interval_alone() {
        let sample = |t: f64, free: f64| Sample {
            t,
            free,
            hit: f64::INFINITY,
            solo: false,
        };
        let mut s = vec![sample(0.0, 1.0), sample(1.0, f64::NEG_INFINITY)];
        assert_eq!(plan_requests(&mut s, 1.0, 0.005), (Vec::new(), Some(false)));
        let mut s = vec![sample(0.0, 0.6), sample(1.0, f64::NEG_INFINITY)];
        let (ask, decided) = plan_requests(&mut s, 1.0, 0.005);
        assert_eq!(decided, None);
        assert_eq!(ask.len(), 1);
        assert!((ask[0].1 - 0.4).abs() < 1e-12);
    }

    /// A straight 5 mm move at 40 mm, tilted 10°.
    fn long_move(m: &Machine) -> MoveSpec {
        MoveSpec {
            from: axes(m, [0.0, 0.0, 40.0], 10.0, 0.0),
            to: axes(m, [5.0, 0.0, 40.0], 10.0, 0.0),
            cutoff: 1,
        }
    }

    /// A move through material along its whole length is settled by its
    /// poses at the plain margin, not halved down to `min_step` (about
    /// 2,000 queries, every one a hit).
    #[test]
    fn a_move_through_material_is_settled_at_the_plain_margin() {
        let m = Machine::default();
        let fake = profile(-1.0, -1.0);
        let prover = prover(&m, &fake);
        assert_eq!(prover.moves(&[long_move(&m)]).unwrap(), vec![true]);
        let asked = fake.asked.lock().unwrap();
        assert!(asked.len() < 60, "{} queries", asked.len());
        assert!(asked.iter().any(|q| q.margin == 0.05 && q.slope == 0.0));
    }

    /// A move that keeps the margin but little more along its whole
    /// length is blocked at every first sample, free at the plain margin,
    /// and proven free by halving.
    #[test]
    fn a_move_grazing_along_its_length_is_still_proven_free() {
        let m = Machine::default();
        let fake = profile(0.07, -1.0);
        let prover = prover(&m, &fake);
        assert_eq!(prover.moves(&[long_move(&m)]).unwrap(), vec![false]);
        let asked = fake.asked.lock().unwrap();
        let plain = asked.iter().filter(|q| q.margin == 0.05).count();
        assert!(plain >= PLAIN_AFTER, "{plain} plain asks");
    }

    /// A backend that answers as a [`Profile`] and answers well only
    /// queries reaching 1 mm or less ([`Backend::wide_above`]).
    struct Narrow(Profile);

    impl Backend for Narrow {
        fn name(&self) -> &'static str {
            "narrow"
        }
        fn evaluate(&self, q: &[Query]) -> Result<Vec<bool>, CollideError> {
            self.0.evaluate(q)
        }
        fn wide_above(&self) -> Option<f32> {
            Some(1.0)
        }
    }

    /// One pose asked `n` times, query `k` with the `(margin, slope)`
    /// that `level(k)` gives.
    fn one_pose_asked(m: &Machine, n: usize, level: impl Fn(usize) -> (f32, f32)) -> Vec<Query> {
        let pose = m.pose(&axes(m, [0.0, 0.0, 40.0], 10.0, 0.0));
        (0..n)
            .map(|k| Query {
                pose,
                cutoff: 1,
                margin: level(k).0,
                slope: level(k).1,
            })
            .collect()
    }

    /// Queries reaching farther than the backend answers well (margin
    /// plus slope times the head's 36 mm) are asked of the backend beside
    /// it, the others of the backend; the verdicts come back in the order
    /// asked, as the backend alone gives them.
    #[test]
    fn wide_queries_go_to_the_backend_beside_with_verdicts_in_order() {
        let m = Machine::default();
        let queries = one_pose_asked(&m, 200, |k| {
            (0.01 * k as f32, if k % 3 == 0 { 0.01 } else { 0.0 })
        });
        let (narrow, beside, alone) = (
            Narrow(profile(0.5, -1.0)),
            profile(0.5, -1.0),
            profile(0.5, -1.0),
        );
        let split = Prover::new(&m, &narrow, 36.0, 0.05, 0.3).with_wide(&beside);
        let plain = Prover::new(&m, &alone, 36.0, 0.05, 0.3);
        let verdicts = split.evaluate(&queries).unwrap();
        assert_eq!(verdicts, plain.evaluate(&queries).unwrap());
        assert!(verdicts.contains(&true) && verdicts.contains(&false));
        let reach = |q: &Query| q.margin + 36.0 * q.slope;
        let (far, near) = (beside.asked.lock().unwrap(), narrow.0.asked.lock().unwrap());
        assert!(far.iter().all(|q| reach(q) > 1.0) && near.iter().all(|q| reach(q) <= 1.0));
        assert_eq!(far.len() + near.len(), queries.len());
        assert!(
            far.len() > 50 && near.len() > 50,
            "{} far, {} near",
            far.len(),
            near.len()
        );
    }

    /// A pose recorded the same as a pose known free is answered free
    /// without a query; one recorded the same as a pose nothing is known
    /// of is not recorded, and is asked.
    #[test]
    fn a_pose_the_same_as_a_free_one_is_answered_without_a_query() {
        let (m, backend, way) = free_chain();
        let p = prover(&m, &backend);
        let margin = p.pose_margin();
        assert_eq!(p.poses_at(&[(way[0], 3)], margin).unwrap(), [false]);
        p.same_as_each(&[(way[1], 3, way[0]), (way[2], 3, way[3])]);
        let asked = backend.asked.lock().unwrap().len();
        assert_eq!(p.poses_at(&[(way[1], 3)], margin).unwrap(), [false]);
        assert_eq!(backend.asked.lock().unwrap().len(), asked, "recorded");
        p.poses_at(&[(way[2], 3)], margin).unwrap();
        assert_eq!(backend.asked.lock().unwrap().len(), asked + 1, "not known");
        // Another cutoff is another pose.
        p.poses_at(&[(way[1], 4)], margin).unwrap();
        assert_eq!(backend.asked.lock().unwrap().len(), asked + 2);
    }

    /// Every backend call is counted and timed, and the queries sent
    /// beside are counted apart.
    #[test]
    fn the_backend_calls_are_counted_and_timed() {
        let m = Machine::default();
        let queries = one_pose_asked(&m, 30, |k| (0.1 * k as f32, 0.0));
        let (narrow, beside) = (Narrow(profile(0.5, -1.0)), profile(0.5, -1.0));
        let p = Prover::new(&m, &narrow, 36.0, 0.05, 0.3).with_wide(&beside);
        assert_eq!(p.answering(), Answering::default());
        p.evaluate(&queries).unwrap();
        p.evaluate(&queries[..5]).unwrap();
        let a = p.answering();
        assert_eq!(a.calls, 2);
        assert_eq!(a.beside as usize, beside.asked.lock().unwrap().len());
        assert!(a.beside > 0 && a.beside < 30, "{a:?}");
        assert!(a.seconds > 0.0 && a.beside_seconds > 0.0, "{a:?}");
        assert_eq!((a - a).calls, 0);
    }
}

//! What the machine does between two G-code lines, and proofs that it is
//! safe.
//!
//! In the joint-space dialect the controller moves X, Y, Z, tilt and C
//! linearly and together from one line to the next, so the nozzle tip bows
//! away from the straight bead and every point of the head sweeps a curve
//! in the part frame. This file bounds both:
//!
//! - [`sweep`]: a head point `r` mm from the tip moves no farther than
//!   `tip + turn · r` over the whole move (and no farther than `Δt` times
//!   that over any fraction `Δt` of it); [`displacement_bound`] is that
//!   for the head's farthest point;
//! - [`tip_deviation_bound`]: the tip never leaves the part-frame chord by
//!   more than this; [`tip_subdivision`] inserts points until every piece
//!   keeps it within the machine's `tip_tolerance`.
//!
//! Both come from one derivation. Write the tip as `tip(t) = Mᵀ(t) X(t)`
//! (configuration III: `M = R_y(B) R_z(C)`; the offsets of configurations
//! I and II add lever arms `d + h + r`), `p(t)` the chord between the two
//! tips and `g = M (tip − p) = X − M p`. `g` vanishes at both ends and
//! `g'' = −M'' p − 2 M' Δp`, so with `ω = |ΔB| + |ΔC|` (radians per unit
//! move) and `P` the largest `|p|`: `|g''| ≤ G = ω² P + 2 ω |Δp|`, hence
//! `|tip − p| = |g| ≤ G / 8` and `|tip' − Δp| ≤ G / 2 + ω G / 8`. A head
//! point `tip + R h` adds `ω · |h|`.
//!
//! [`Prover`] turns boolean queries into proofs about whole moves. A pose
//! of a move is *free at level `λ`* when no head point `h` comes within
//! `m + λ (tip + turn |h|)` of material: then no head point reaches the
//! margin `m` while the move advances by a fraction `λ` either way (it
//! moves no farther than that in the time). So an interval `[a, b]` of
//! the move is proven when `λ_a + λ_b ≥ b − a`, or one end alone reaches
//! `b − a` (every pose in between is within reach of one end's
//! clearance; the same holds for material points seen from the head, so
//! containment cannot appear in between either). A level is asked as one query whose margin grows with
//! distance from the tip ([`crate::scene::Query::slope`], see
//! [`level_query`]): material near the tip needs little more than the
//! tip's own travel, however far the rest of the head swings. Samples
//! start `step` mm of tip travel apart and are asked half their
//! intervals each; where one fails, its intervals are halved, down to
//! `min_step`. A move is declared colliding only when it cannot be
//! proven at that resolution.
//!
//! Work is shared where moves meet. A waypoint's own pose is asked once,
//! in the columns, for what the beads to its neighbours will ask of their
//! ends ([`Prover::end_need`]), and the answer is kept as a sloped
//! clearance, so those beads start proven at that end. Ends that several
//! moves ask in the same round (the bead into a pose and the bead out of
//! it, the pieces of a split bead) are one query asking the most any of
//! them needs ([`share_ends`]).

use crate::collide::moves::SampledMove;
use crate::collide::{Backend, CollideError};
use crate::geometry::Pose;
use crate::kinematics::{Axes, Interpolation, Machine};
use crate::scene::Query;
use rayon::prelude::*;
use rustc_hash::FxHashMap as HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    norm([a[0] - b[0], a[1] - b[1], a[2] - b[2]])
}

/// (A square root of the squares, not `hypot`: part-frame millimetres
/// neither overflow nor underflow, and libm's `hypot` was 2 % of a plan's
/// CPU.)
fn norm(a: [f64; 3]) -> f64 {
    (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt()
}

/// `G = ω² P + 2 ω |Δp|` of the move `a → b` (see the module comment);
/// 0 under tool-centre-point control, where the tip does not bow.
fn bow(m: &Machine, a: &Axes, b: &Axes) -> (f64, f64, f64) {
    let (pa, pb) = (m.tip(a), m.tip(b));
    let w = a.rotation_to(b);
    let dp = dist(pa, pb);
    if m.post.interpolation() == Interpolation::TipLinear {
        return (0.0, w, dp);
    }
    let lever = norm(pa).max(norm(pb)) + m.d.abs() + m.h.abs() + m.r.abs();
    (w * w * lever + 2.0 * w * dp, w, dp)
}

/// How far head points travel over a move, by their distance from the tip:
/// a point `r` mm from the tip (head frame) moves no farther than
/// `tip + turn · r` over the whole move, and a fraction `Δt` of the move
/// moves it no farther than `Δt` times that.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sweep {
    /// The tip's part (mm): its travel, its bow, the machine's lever arms.
    pub tip: f64,
    /// The rotation's part (mm per mm from the tip): `ω = |ΔB| + |ΔC|`.
    pub turn: f64,
}

impl Sweep {
    /// The farthest a point within `reach` of the tip travels (mm).
    pub fn within(&self, reach: f64) -> f64 {
        self.tip + self.turn * reach
    }
}

/// [`Sweep`] of the move `a → b` as the machine interpolates it. Under
/// tool-centre-point control the tip moves straight: `|Δp| + ω r`.
pub fn sweep(m: &Machine, a: &Axes, b: &Axes) -> Sweep {
    let (g, w, dp) = bow(m, a, b);
    if m.post.interpolation() == Interpolation::TipLinear {
        return Sweep { tip: dp, turn: w };
    }
    let lever = m.d.abs() + m.h.abs() + m.r.abs();
    Sweep {
        tip: dp + 0.5 * g + w * g / 8.0 + w * lever,
        turn: w,
    }
}

/// Largest distance any head point within `reach` of the tip travels over
/// the move `a → b` as the machine interpolates it (mm); a fraction `Δt`
/// of the move moves no point farther than `Δt` times this.
pub fn displacement_bound(m: &Machine, a: &Axes, b: &Axes, reach: f64) -> f64 {
    sweep(m, a, b).within(reach)
}

/// Largest distance of the tip from the part-frame chord between the two
/// ends of the joint-linear move `a → b` (mm).
pub fn tip_deviation_bound(m: &Machine, a: &Axes, b: &Axes) -> f64 {
    bow(m, a, b).0 / 8.0
}

/// The axes after `a` (excluded) up to `b` (included) that split the
/// extruding move `a → b` into pieces whose tips stay within `tol` of the
/// straight bead: intermediate tips on the part-frame chord, rotary axes
/// interpolated linearly, every value rounded as written. Just `[b]` when
/// the move needs no split.
pub fn tip_subdivision(m: &Machine, a: &Axes, b: &Axes, tol: f64) -> Vec<Axes> {
    tip_subdivision_where(m, a, b, tol, |_| true).0
}

/// Piece counts tried beyond the smallest that keeps the tolerance when a
/// split tip lands where `fits` refuses it.
const EXTRA_PIECES: usize = 8;

/// Fractions of the bead a split tip may take when even splits do not fit
/// (see [`tip_subdivision_where`]), per piece of the smallest split.
const UNEVEN_STEPS: usize = 16;

/// The finest grid an uneven split searches (it costs up to the grid
/// times the pieces in [`tip_deviation_bound`] calls).
const MAX_UNEVEN_STEPS: usize = 1024;

/// [`tip_subdivision`] with a say over where split tips land: of the
/// piece counts from the smallest that keeps `tol` up to
/// [`EXTRA_PIECES`] more, the first whose every split tip (part frame, as
/// rounded) `fits`. When no even split does (a region that does not fit
/// around the bead's middle, say, where an even split always puts a tip),
/// an uneven one: from the start, each split tip at the farthest fraction
/// on a fine grid that `fits` and keeps the piece within `tol`. The
/// smallest even split when that fails too. Also says whether every
/// split tip fits. The planner passes "reads as the bead's own layer" (see
/// [`super::layer_reading`]).
pub fn tip_subdivision_where(
    m: &Machine,
    a: &Axes,
    b: &Axes,
    tol: f64,
    fits: impl Fn([f64; 3]) -> bool,
) -> (Vec<Axes>, bool) {
    let g = bow(m, a, b).0;
    let tips = (m.tip(a), m.tip(b));
    let split = |n: usize| -> Vec<Axes> { (1..=n).map(|k| along(m, (a, b), tips, k, n)).collect() };
    // Rounding moves the pieces' ends a little: re-check each piece.
    let within = |pts: &[Axes]| {
        std::iter::once(a)
            .chain(pts)
            .zip(pts)
            .all(|(x, y)| tip_deviation_bound(m, x, y) <= tol)
    };
    let mut n = ((g / (8.0 * tol)).sqrt().ceil() as usize).max(1);
    let smallest = loop {
        let pts = split(n);
        if within(&pts) || n > 4096 {
            break pts;
        }
        n += (n / 4).max(1);
    };
    let n0 = smallest.len();
    let fit = |pts: &[Axes]| pts[..pts.len() - 1].iter().all(|x| fits(m.tip(x)));
    if fit(&smallest) {
        return (smallest, true);
    }
    (n0 + 1..=n0 + EXTRA_PIECES)
        .map(split)
        .find(|pts| within(pts) && fit(pts))
        .or_else(|| {
            uneven_split(
                m,
                a,
                b,
                tol,
                (n0 * UNEVEN_STEPS).min(MAX_UNEVEN_STEPS),
                &fits,
            )
        })
        .map_or((smallest, false), |pts| (pts, true))
}

/// The axes `k/n` of the way along the extruding move `a → b` whose tips
/// are `pa → pb`: the tip on the part-frame chord, the rotary axes
/// interpolated linearly (`b` itself at `k = n`).
fn along(
    m: &Machine,
    (a, b): (&Axes, &Axes),
    (pa, pb): ([f64; 3], [f64; 3]),
    k: usize,
    n: usize,
) -> Axes {
    if k == n {
        return *b;
    }
    let s = k as f64 / n as f64;
    let p = std::array::from_fn(|i| pa[i] + s * (pb[i] - pa[i]));
    m.axes_at(p, (a.tilt + s * (b.tilt - a.tilt), a.c + s * (b.c - a.c)))
}

/// The uneven split of [`tip_subdivision_where`] on a grid of `steps`
/// fractions: greedy, each split tip as far along as the tolerance and
/// `fits` allow; `None` when some piece cannot move on.
fn uneven_split(
    m: &Machine,
    a: &Axes,
    b: &Axes,
    tol: f64,
    steps: usize,
    fits: &impl Fn([f64; 3]) -> bool,
) -> Option<Vec<Axes>> {
    let tips = (m.tip(a), m.tip(b));
    let at = |j: usize| along(m, (a, b), tips, j, steps);
    let mut pts = Vec::new();
    let (mut from, mut i) = (*a, 0);
    while i < steps {
        let next = (i + 1..=steps).rev().find_map(|j| {
            let q = at(j);
            (tip_deviation_bound(m, &from, &q) <= tol && (j == steps || fits(m.tip(&q))))
                .then_some((j, q))
        })?;
        (i, from) = next;
        pts.push(from);
    }
    Some(pts)
}

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
    /// 64 samples.
    pub step: f64,
    /// Finest spacing before a move is declared colliding (mm). Poses are
    /// checked with `margin + min_step` so that the moves out of them can
    /// always be proven.
    pub min_step: f64,
    cache: Mutex<HashMap<Key, bool>>,
    /// Poses known free, and what they are known free at (colliding
    /// poses are not kept: they are rarely asked again).
    known: Mutex<HashMap<PoseKey, Clearance>>,
    queries: AtomicU64,
    /// Hears `(done, total)` queries of each batch as it is answered.
    ticker: Option<Ticker<'a>>,
}

/// What a pose is known to keep: every material point `q` (head frame)
/// at least `plain` from the head, and, from a sloped query, at least
/// `margin + slope · |q|` (`slope` 0: none known). Kept as the queries
/// asked them (f32), 12 bytes a pose.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Clearance {
    plain: f32,
    margin: f32,
    slope: f32,
}

impl Clearance {
    /// Known free at `(margin, slope)`.
    fn new(margin: f64, slope: f64) -> Self {
        let (margin, slope) = (margin as f32, slope as f32);
        if slope > 0.0 {
            Clearance {
                plain: margin,
                margin,
                slope,
            }
        } else {
            Clearance {
                plain: margin,
                margin: 0.0,
                slope: 0.0,
            }
        }
    }

    /// What is known, with `other` learnt too.
    fn merged(self, other: Clearance) -> Self {
        // The steeper slope certifies more of a turning move's levels.
        let steeper =
            other.slope > self.slope || (other.slope == self.slope && other.margin > self.margin);
        let (margin, slope) = if steeper {
            (other.margin, other.slope)
        } else {
            (self.margin, self.slope)
        };
        Clearance {
            plain: self.plain.max(other.plain),
            margin,
            slope,
        }
    }

    /// The largest level (see [`level_query`]) this certifies for a move
    /// with sweep `s` whose farthest head point travels `bound`, safety
    /// margin `m`.
    fn level(&self, m: f64, s: &Sweep, bound: f64) -> f64 {
        let plain = plain_level(self.plain as f64, m, bound);
        if self.slope > 0.0 {
            plain.max(sloped_level(self.margin as f64, self.slope as f64, m, s))
        } else {
            plain
        }
    }
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
            cache: Mutex::new(HashMap::default()),
            known: Mutex::new(HashMap::default()),
            queries: AtomicU64::new(0),
            ticker: None,
        }
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

    /// The margin poses are checked with: the safety margin plus the
    /// finest step, so every accepted pose can start a provable move.
    pub fn pose_margin(&self) -> f64 {
        self.margin + self.min_step
    }

    fn evaluate(&self, q: &[Query]) -> Result<Vec<bool>, CollideError> {
        self.queries.fetch_add(q.len() as u64, Ordering::Relaxed);
        let Some(tick) = self.ticker else {
            return self.backend.evaluate(q);
        };
        let mut out = Vec::with_capacity(q.len());
        for chunk in q.chunks(TICK_BATCH.max(self.backend.batch_hint())) {
            out.extend(self.backend.evaluate(chunk)?);
            tick(out.len() as u64, q.len() as u64);
        }
        Ok(out)
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
    /// out of it will ask of their ends ([`Prover::poses_clear`]), so
    /// those moves start proven at their ends; only those that fail are
    /// asked again at the pose margin (a pose that merely grazes is free).
    /// `needs[i]` is item `i`'s `(margin, slope)`.
    pub fn poses_wide(
        &self,
        items: &[(Axes, u32)],
        needs: &[(f64, f64)],
    ) -> Result<Vec<bool>, CollideError> {
        let wide = self.poses_clear(items, needs)?;
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
    pub fn poses_clear(
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
        let mut known = self.known.lock().expect("prover cache");
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
    /// interval), as one query ([`level_query`]); never less than
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
    /// with at most 64, refined only where material is near.
    fn first_samples(&self, sw: &Sweep) -> usize {
        ((sw.tip / self.step).ceil() as usize).clamp(1, 64)
    }

    /// Record that the pose `(a, cutoff)` has the verdict of a pose it is
    /// congruent to (the same head geometry turned by a symmetry) at the
    /// pose margin.
    pub fn same_as(&self, a: &Axes, cutoff: u32, like: &Axes) {
        let mut known = self.known.lock().expect("prover cache");
        if let Some(k) = known.get(&pose_key(like, cutoff)).copied() {
            known.insert(pose_key(a, cutoff), k);
        }
    }

    /// Do the poses `(axes, cutoff)` come within `margin` of existing
    /// material? Poses already known free at a larger margin are answered
    /// without a query.
    pub fn poses_at(&self, items: &[(Axes, u32)], margin: f64) -> Result<Vec<bool>, CollideError> {
        let keys: Vec<PoseKey> = items.par_iter().map(|(a, c)| pose_key(a, *c)).collect();
        let mut out: Vec<Option<bool>> = {
            let known = self.known.lock().expect("prover cache");
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
        let mut known = self.known.lock().expect("prover cache");
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
        self.backend.sampled_moves(self.machine, &asked)
    }

    /// Does each move come within the margin of existing material at any
    /// point (or can it not be proven free)? One verdict each.
    pub fn moves(&self, moves: &[MoveSpec]) -> Result<Vec<bool>, CollideError> {
        let keys: Vec<Key> = moves.par_iter().map(key).collect();
        let mut out: Vec<Option<bool>> = {
            let cache = self.cache.lock().expect("prover cache");
            let cache: &HashMap<Key, bool> = &cache;
            keys.par_iter().map(|k| cache.get(k).copied()).collect()
        };
        let todo: Vec<usize> = (0..moves.len()).filter(|&i| out[i].is_none()).collect();
        let found = self.prove(&todo.iter().map(|&i| moves[i]).collect::<Vec<_>>())?;
        let mut cache = self.cache.lock().expect("prover cache");
        for (&i, v) in todo.iter().zip(found) {
            cache.insert(keys[i], v);
            out[i] = Some(v);
        }
        Ok(out.into_iter().map(|v| v.unwrap_or(true)).collect())
    }

    /// The adaptive proof (module comment) for moves not in the cache.
    fn prove(&self, moves: &[MoveSpec]) -> Result<Vec<bool>, CollideError> {
        let m = self.margin;
        let sweeps: Vec<Sweep> = moves
            .par_iter()
            .map(|mv| sweep(self.machine, &mv.from, &mv.to))
            .collect();
        let bounds: Vec<f64> = sweeps.iter().map(|s| s.within(self.reach)).collect();
        // Initial samples: intervals over which the tip moves no farther
        // than `step` (material near the tip is proven at that first
        // resolution; material farther out, which a turn sweeps faster,
        // splits the intervals it comes near). The ends start with what is
        // known of them as poses (a pose free with more material present
        // is free with less): a plain margin `M` certifies level
        // `(M − m) / bound`.
        let mut samples: Vec<Vec<Sample>> = {
            let known = self.known.lock().expect("prover cache");
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
                .zip(&bounds)
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
        };
        let mut verdict: Vec<Option<bool>> = vec![None; moves.len()];
        loop {
            // Per undecided move: the samples to query and at what level,
            // splitting intervals that cannot be proven as they stand.
            let requests: Vec<Vec<(usize, f64)>> = samples
                .par_iter_mut()
                .zip(verdict.par_iter_mut())
                .zip(bounds.par_iter())
                .map(|((s, v), &d)| {
                    if v.is_some() {
                        return Vec::new();
                    }
                    let (req, decided) = plan_requests(s, d, self.min_step);
                    *v = decided;
                    req
                })
                .collect();
            let flat: Vec<(usize, usize, f64)> = requests
                .iter()
                .enumerate()
                .flat_map(|(i, r)| r.iter().map(move |&(k, level)| (i, k, level)))
                .collect();
            if flat.is_empty() {
                break;
            }
            let asks: Vec<Ask> = flat
                .par_iter()
                .map(|&(i, k, level)| {
                    let mv = &moves[i];
                    let (margin, slope) = level_query(m, &sweeps[i], self.reach, level);
                    let last = samples[i].len() - 1;
                    let end = match k {
                        _ if samples[i][k].solo => None,
                        0 => Some(mv.from),
                        _ if k == last => Some(mv.to),
                        _ => None,
                    };
                    Ask {
                        end,
                        cutoff: mv.cutoff,
                        margin,
                        slope,
                    }
                })
                .collect();
            let (slot, shared, grown) = share_ends(&asks);
            let queries: Vec<Query> = shared
                .par_iter()
                .zip(&grown)
                .map(|(&j, a)| {
                    let (i, k, _) = flat[j];
                    let mv = &moves[i];
                    let pose = self.machine.pose_along(&mv.from, &mv.to, samples[i][k].t);
                    Query {
                        slope: a.slope as f32,
                        ..self.query_pose(pose, a.cutoff, a.margin)
                    }
                })
                .collect();
            let hits = self.evaluate(&queries)?;
            let mut known = self.known.lock().expect("prover cache");
            for (j, &(i, k, level)) in flat.iter().enumerate() {
                let q = &grown[slot[j]];
                let s = &mut samples[i][k];
                if !hits[slot[j]] {
                    s.free = s.free.max(level);
                    if let Some(a) = q.end {
                        let e = known
                            .entry(pose_key(&a, q.cutoff))
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
        Ok(verdict.into_iter().map(|v| v.unwrap_or(true)).collect())
    }
}

/// One query a round of [`Prover::prove`] needs: a sample of a move at
/// the `(margin, slope)` of its level; `end` is the sample's axes when it
/// is a move's end (which neighbouring moves may share).
#[derive(Clone, Copy)]
struct Ask {
    end: Option<Axes>,
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

/// Ends of moves asked in the same round at the same pose (the bead into
/// a waypoint and the bead out of it; the pieces of a split bead) become
/// one query asking the most any of them asks — the largest margin, slope
/// and cutoff — which certifies each. Returns, per ask, the index of its
/// query; per query, the ask whose pose it takes (the first of its group)
/// and what it asks (the group's need).
fn share_ends(asks: &[Ask]) -> (Vec<usize>, Vec<usize>, Vec<Ask>) {
    let mut first: HashMap<PoseKey, usize> = HashMap::default();
    let mut slot = Vec::with_capacity(asks.len());
    let mut shared: Vec<usize> = Vec::new();
    let mut grown: Vec<Ask> = Vec::new();
    for (j, a) in asks.iter().enumerate() {
        let group = a.end.map(|e| pose_key(&e, 0));
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

/// The level (fraction of its move, see [`level_query`]) a pose known free
/// at the plain margin `margin` certifies, for a move whose farthest
/// moving head point travels `bound` (`m` the safety margin).
fn plain_level(margin: f64, m: f64, bound: f64) -> f64 {
    if margin < m {
        f64::NEG_INFINITY
    } else if bound > 0.0 {
        (margin - m) / bound
    } else {
        f64::INFINITY
    }
}

/// The level a pose known free at `(margin, slope)` certifies for a move
/// with sweep `s` (safety margin `m`): the largest `λ` whose
/// [`level_query`] asks no more, `margin ≥ (m + λ tip) / (1 − λ turn)`
/// and `slope ≥ λ turn / (1 − λ turn)`.
fn sloped_level(margin: f64, slope: f64, m: f64, s: &Sweep) -> f64 {
    if margin < m {
        return f64::NEG_INFINITY;
    }
    let by_margin = if s.tip + margin * s.turn > 0.0 {
        (margin - m) / (s.tip + margin * s.turn)
    } else {
        f64::INFINITY
    };
    let by_slope = if s.turn > 0.0 {
        slope / ((1.0 + slope) * s.turn)
    } else {
        f64::INFINITY
    };
    by_margin.min(by_slope)
}

/// The query `(margin, slope)` that certifies a pose of a move with sweep
/// `s` at level `λ`: no head point `h` comes within
/// `m + λ (s.tip + s.turn |h|)` of material, so none reaches the margin
/// `m` while the move advances by a fraction `λ` either way. Asking each
/// material point `q` (head frame) to keep `M₀ + k |q|` with
/// `M₀ = (m + λ tip) / (1 − λ turn)`, `k = λ turn / (1 − λ turn)` does it:
/// the head point `h` nearest to `q` has `|h| ≤ |q| + |q − h|`. Material
/// near the tip then needs little more than the tip's own travel, however
/// far the rest of the head swings. Large turns (`λ turn ≥ ½`) ask the
/// plain margin `m + λ · s.within(reach)` instead.
fn level_query(m: f64, s: &Sweep, reach: f64, level: f64) -> (f64, f64) {
    let k = level * s.turn;
    if k < 0.5 {
        ((m + level * s.tip) / (1.0 - k), k / (1.0 - k))
    } else {
        (m + level * s.within(reach), 0.0)
    }
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
    // (The tolerance absorbs rounding.) One end known at the whole span
    // covers the interval alone, whatever is known of the other.
    let proven = |a: &Sample, b: &Sample| {
        let span = (b.t - a.t) * (1.0 - 1e-9);
        a.free >= span || b.free >= span || a.free + b.free >= span
    };
    // The levels wanted of the ends of an unproven interval.
    let want = |a: &Sample, b: &Sample| {
        let span = b.t - a.t;
        if a.free >= 0.25 * span && a.free >= b.free {
            (a.free, span - a.free)
        } else if b.free >= 0.25 * span {
            (span - b.free, b.free)
        } else {
            (0.5 * span, 0.5 * span)
        }
    };
    let blocked = |a: &Sample, b: &Sample| {
        let (wa, wb) = want(a, b);
        (a.free < wa && a.hit <= wa) || (b.free < wb && b.hit <= wb)
    };
    // Splits.
    let mut k = 0;
    while k + 1 < s.len() {
        let (a, b) = (s[k], s[k + 1]);
        if !proven(&a, &b) && blocked(&a, &b) {
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
            k += 2;
        } else {
            k += 1;
        }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::Machine;

    fn axes(m: &Machine, p: [f64; 3], tilt_deg: f64, c_deg: f64) -> Axes {
        m.axes_at(p, (tilt_deg.to_radians(), c_deg.to_radians()))
    }

    /// The bounds hold for densely sampled joint-linear moves: each head
    /// point moves no farther than its own sweep (`tip + turn · |h|`), nor
    /// than the displacement bound at the head's reach.
    #[test]
    fn bounds_cover_sampled_motion() {
        let m = Machine::default();
        let reach = 36.0;
        let head_pts = [[0.0, 0.0, 0.0], [20.0, 0.0, 20.0], [-14.0, 14.0, 30.0]];
        let cases = [
            (
                axes(&m, [10.0, -5.0, 45.0], 0.0, 0.0),
                axes(&m, [10.5, -5.2, 45.1], 2.0, 3.0),
            ),
            (
                axes(&m, [-30.0, 20.0, 60.0], -40.0, 170.0),
                axes(&m, [-29.0, 21.0, 60.5], 35.0, -100.0),
            ),
            (
                axes(&m, [80.0, 0.0, 41.0], 10.0, 0.0),
                axes(&m, [80.0, 0.7, 41.0], 12.0, 45.0),
            ),
        ];
        for (a, b) in cases {
            let d = displacement_bound(&m, &a, &b, reach);
            let sw = sweep(&m, &a, &b);
            let dev = tip_deviation_bound(&m, &a, &b);
            let (pa, pb) = (m.tip(&a), m.tip(&b));
            let n = 2000;
            let mut worst_dev: f64 = 0.0;
            for h in head_pts {
                let own = sw.within(norm(h));
                assert!(own <= d);
                let pt = |t: f64| m.pose(&a.lerp(&b, t)).to_part(h.map(|x| x as f32));
                for k in 0..n {
                    let (t0, t1) = (k as f64 / n as f64, (k + 1) as f64 / n as f64);
                    let (x0, x1) = (pt(t0), pt(t1));
                    let step = dist(x0.map(|v| v as f64), x1.map(|v| v as f64));
                    assert!(
                        step <= own * (t1 - t0) * 1.001 + 1e-4,
                        "{step} > {} for a point {} mm from the tip",
                        own * (t1 - t0),
                        norm(h)
                    );
                }
            }
            for k in 0..=n {
                let t = k as f64 / n as f64;
                let tip = m.tip(&a.lerp(&b, t));
                let p: [f64; 3] = std::array::from_fn(|i| pa[i] + t * (pb[i] - pa[i]));
                worst_dev = worst_dev.max(dist(tip, p));
            }
            assert!(
                worst_dev <= dev * 1.0001 + 1e-9,
                "tip deviation {worst_dev} > bound {dev}"
            );
        }
    }

    /// A pose asked at level `λ` keeps every head point `h` at least
    /// `m + λ (tip + turn |h|)` from material: with the material point `q`
    /// at exactly the asked `margin + slope |q|` from the head, every head
    /// point as far from the tip as it can be (`|h| ≤ |q| + |q − h|`).
    #[test]
    fn level_queries_keep_each_head_point_its_own_sweep() {
        let m = 0.05;
        let reach = 36.0;
        for (tip, turn) in [(0.9, 0.01), (0.3, 0.2), (2.0, 0.04), (0.0, 1.5), (1.0, 3.0)] {
            let s = Sweep { tip, turn };
            for level in [0.01, 0.1, 0.25, 0.5, 1.0] {
                let (margin, slope) = level_query(m, &s, reach, level);
                for q in [0.0, 0.5, 3.0, 10.0, 30.0, 36.0] {
                    let gap = margin + slope * q;
                    // The farthest head point at that distance from q.
                    let h: f64 = q + gap;
                    let need = m + level * s.within(h.min(reach));
                    assert!(
                        gap >= need * (1.0 - 1e-12),
                        "sweep {s:?}, level {level}, |q| {q}: {gap} < {need}"
                    );
                }
                // Never asks more of the tip's neighbourhood than one margin
                // for the whole head would.
                assert!(margin <= m + level * s.within(reach) + 1e-12 || slope == 0.0);
            }
        }
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

    /// A chain of beads through free poses: each waypoint between two beads
    /// is asked once for both (shared ends), not once per bead.
    #[test]
    fn beads_of_a_chain_share_their_ends() {
        let m = Machine::default();
        let fake = profile(f32::INFINITY, f32::INFINITY);
        let prover = Prover::new(&m, &fake, 36.0, 0.05, 0.3);
        let way: Vec<Axes> = (0..7)
            .map(|k| axes(&m, [0.5 * k as f64, 0.0, 40.0], 10.0, 2.0 * k as f64))
            .collect();
        let beads: Vec<MoveSpec> = way
            .windows(2)
            .enumerate()
            .map(|(k, w)| MoveSpec {
                from: w[0],
                to: w[1],
                cutoff: k as u32 + 1,
            })
            .collect();
        let intervals: usize = beads
            .iter()
            .map(|b| prover.first_samples(&sweep(&m, &b.from, &b.to)))
            .sum();
        assert!(prover.moves(&beads).unwrap().iter().all(|&h| !h));
        // Every sample once: the 7 waypoints and the interior samples.
        let interior = intervals - beads.len();
        assert_eq!(prover.queries() as usize, way.len() + interior);
        // A shared end asks what its neighbour's bead needs, with the later
        // bead's material.
        let asked = fake.asked.lock().unwrap();
        let mid = m.pose(&way[3]);
        let q = asked
            .iter()
            .find(|q| q.pose.tip == mid.tip && q.pose.cols == mid.cols)
            .expect("waypoint 3 asked");
        assert_eq!(q.cutoff, 4);
    }

    /// Waypoints asked for what their beads need of them
    /// ([`Prover::end_need`]) start those beads proven at both ends: the
    /// beads ask only their interior samples.
    #[test]
    fn waypoints_asked_for_their_beads_need_no_end_samples() {
        let m = Machine::default();
        let fake = profile(f32::INFINITY, f32::INFINITY);
        let prover = Prover::new(&m, &fake, 36.0, 0.05, 0.3);
        let way: Vec<Axes> = (0..7)
            .map(|k| axes(&m, [0.5 * k as f64, 0.0, 40.0], 10.0, 2.0 * k as f64))
            .collect();
        let items: Vec<(Axes, u32)> = (0..way.len()).map(|k| (way[k], k as u32 + 1)).collect();
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
        let beads: Vec<MoveSpec> = way
            .windows(2)
            .enumerate()
            .map(|(k, w)| MoveSpec {
                from: w[0],
                to: w[1],
                cutoff: k as u32 + 1,
            })
            .collect();
        let interior: usize = beads
            .iter()
            .map(|b| prover.first_samples(&sweep(&m, &b.from, &b.to)) - 1)
            .sum();
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
            let n = ((sw.tip / 0.3).ceil() as usize).clamp(1, 64);
            level_query(0.05, &sw, 36.0, 0.5 / n as f64)
        };
        let ((m1, k1), (m2, k2)) = (need(&a, &b), need(&b, &c));
        assert!(m1 > m2 && k2 > k1, "({m1}, {k1}) ({m2}, {k2})");
        // Free for each alone, a hit for both at once.
        let fake = profile(0.5 * (m1 + m2) as f32, 0.5 * (k1 + k2) as f32);
        let prover = Prover::new(&m, &fake, 36.0, 0.05, 0.3);
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
        let asked = fake.asked.lock().unwrap();
        let at_b = m.pose(&b);
        let ends: Vec<&Query> = asked
            .iter()
            .filter(|q| q.pose.tip == at_b.tip && q.pose.cols == at_b.cols)
            .collect();
        // Shared (failed), then once for each bead.
        assert_eq!(ends.len(), 3, "{ends:?}");
    }

    /// A pose known free at a sloped clearance certifies, for a move, the
    /// largest level whose query asks no more than that clearance.
    #[test]
    fn sloped_clearances_certify_the_levels_they_cover() {
        let m = 0.05;
        for (tip, turn) in [(0.5, 0.0), (0.3, 0.02), (0.1, 0.3), (2.0, 0.05)] {
            let s = Sweep { tip, turn };
            for level in [0.05, 0.2, 0.5, 0.9] {
                if level * turn >= 0.5 {
                    continue;
                }
                let (margin, slope) = level_query(m, &s, 36.0, level);
                let got = sloped_level(margin, slope, m, &s);
                assert!(
                    (got - level).abs() <= 1e-9 * level.max(1.0) || (turn == 0.0 && got >= level),
                    "sweep {s:?}, level {level}: certified {got}"
                );
                // A little less clearance certifies less.
                assert!(sloped_level(margin * 0.99, slope, m, &s) < level);
            }
        }
        // A plain clearance certifies by the head's whole sweep.
        let c = Clearance::new(0.2, 0.0);
        let s = Sweep {
            tip: 0.3,
            turn: 0.01,
        };
        // (Kept as the query asked it: in f32.)
        let want = (0.2f32 as f64 - m) / s.within(36.0);
        assert!((c.level(m, &s, s.within(36.0)) - want).abs() < 1e-12);
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

    #[test]
    fn subdivision_keeps_the_tip_on_the_bead() {
        let m = Machine::default();
        let a = axes(&m, [30.0, 10.0, 50.0], -20.0, 10.0);
        let b = axes(&m, [30.6, 10.2, 50.1], -20.0, 70.0);
        assert!(tip_deviation_bound(&m, &a, &b) > 0.05);
        let pts = tip_subdivision(&m, &a, &b, 0.05);
        assert!(pts.len() > 1);
        assert_eq!(*pts.last().unwrap(), b);
        let (pa, pb) = (m.tip(&a), m.tip(&b));
        let mut prev = a;
        for q in &pts {
            assert!(tip_deviation_bound(&m, &prev, q) <= 0.05);
            // Every piece's tip lies on the original bead.
            let t = m.tip(q);
            let seg: [f64; 3] = std::array::from_fn(|i| pb[i] - pa[i]);
            let u = ((t[0] - pa[0]) * seg[0] + (t[1] - pa[1]) * seg[1] + (t[2] - pa[2]) * seg[2])
                / (seg[0] * seg[0] + seg[1] * seg[1] + seg[2] * seg[2]);
            let on: [f64; 3] = std::array::from_fn(|i| pa[i] + u * seg[i]);
            assert!(dist(t, on) < 0.002);
            prev = *q;
        }
    }

    /// Split tips avoid where `fits` refuses them when a few more pieces
    /// allow it, and keep the tolerance either way.
    #[test]
    fn subdivision_moves_split_tips_where_they_fit() {
        let m = Machine::default();
        let a = axes(&m, [30.0, 10.0, 50.0], -20.0, 10.0);
        let b = axes(&m, [30.6, 10.2, 50.1], -20.0, 70.0);
        let plain = tip_subdivision(&m, &a, &b, 0.05);
        let (pa, pb) = (m.tip(&a), m.tip(&b));
        // Refuse the middle third of the bead around the first split tip.
        let u = |p: [f64; 3]| {
            let seg: [f64; 3] = std::array::from_fn(|i| pb[i] - pa[i]);
            ((p[0] - pa[0]) * seg[0] + (p[1] - pa[1]) * seg[1] + (p[2] - pa[2]) * seg[2])
                / (seg[0] * seg[0] + seg[1] * seg[1] + seg[2] * seg[2])
        };
        let u0 = u(m.tip(&plain[0]));
        let fits = |p: [f64; 3]| (u(p) - u0).abs() > 0.02;
        assert!(!fits(m.tip(&plain[0])));
        let moved = tip_subdivision_where(&m, &a, &b, 0.05, fits).0;
        assert!(moved.len() > plain.len());
        assert_eq!(*moved.last().unwrap(), b);
        let mut prev = a;
        for q in &moved {
            assert!(tip_deviation_bound(&m, &prev, q) <= 0.05);
            prev = *q;
        }
        assert!(moved[..moved.len() - 1].iter().all(|q| fits(m.tip(q))));
        // Nowhere fits: the smallest split.
        assert_eq!(tip_subdivision_where(&m, &a, &b, 0.05, |_| false).0, plain);
    }

    /// A refused band around the bead's middle catches a tip of every
    /// even split: the split tips go uneven, around the band.
    #[test]
    fn subdivision_goes_uneven_around_a_refused_middle() {
        let m = Machine::default();
        let a = axes(&m, [30.0, 10.0, 50.0], -20.0, 10.0);
        let b = axes(&m, [30.6, 10.2, 50.1], -20.0, 30.0);
        let (pa, pb) = (m.tip(&a), m.tip(&b));
        let u = |p: [f64; 3]| {
            let seg: [f64; 3] = std::array::from_fn(|i| pb[i] - pa[i]);
            ((p[0] - pa[0]) * seg[0] + (p[1] - pa[1]) * seg[1] + (p[2] - pa[2]) * seg[2])
                / (seg[0] * seg[0] + seg[1] * seg[1] + seg[2] * seg[2])
        };
        // Every even split of n pieces has a tip within 1/(2n) of the
        // middle (0 for even n): refuse a little more than the widest.
        let n0 = tip_subdivision(&m, &a, &b, 0.05).len();
        let widest = (n0..=n0 + EXTRA_PIECES)
            .map(|n| if n % 2 == 0 { 0.0 } else { 0.5 / n as f64 })
            .fold(0.0, f64::max);
        let half = 1.02 * widest;
        let fits = |p: [f64; 3]| (u(p) - 0.5).abs() >= half;
        for n in n0..=n0 + EXTRA_PIECES {
            let refused = (1..n).any(|k| (k as f64 / n as f64 - 0.5).abs() < half);
            assert!(refused, "an even split of {n} pieces would fit");
        }
        let moved = tip_subdivision_where(&m, &a, &b, 0.05, fits).0;
        assert_eq!(*moved.last().unwrap(), b);
        assert!(moved[..moved.len() - 1].iter().all(|q| fits(m.tip(q))));
        let mut prev = a;
        for q in &moved {
            assert!(tip_deviation_bound(&m, &prev, q) <= 0.05);
            prev = *q;
        }
    }
}

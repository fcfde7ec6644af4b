//! Bounds on what the machine does between two G-code lines.
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

use crate::kinematics::{Axes, Interpolation, Machine};
use glam::DVec3;

/// `G = ω² P + 2 ω |Δp|` of the move `a → b` (see the module comment);
/// 0 under tool-centre-point control, where the tip does not bow.
/// (Lengths are square roots of the squares, not `hypot`: part-frame
/// millimetres neither overflow nor underflow, and `hypot` is slow in
/// libm.)
fn bow(m: &Machine, a: &Axes, b: &Axes) -> (f64, f64, f64) {
    let (pa, pb) = (DVec3::from(m.tip(a)), DVec3::from(m.tip(b)));
    let w = a.rotation_to(b);
    let dp = pa.distance(pb);
    if m.post.interpolation() == Interpolation::TipLinear {
        return (0.0, w, dp);
    }
    let lever = pa.length().max(pb.length()) + m.d.abs() + m.h.abs() + m.r.abs();
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

/// How many pieces [`tip_subdivision`] splits an extruding move into
/// whose tips lie within `reach` of the part frame's origin, `len` mm
/// apart, while the orientation turns by at most `turn` radians: the
/// fewest that keep `tol` by the bow's bound, and a quarter and one more
/// for the rounding of the written ends (a split needs that rarely). One
/// under tool-centre-point control.
pub fn pieces_bound(m: &Machine, reach: f64, len: f64, turn: f64, tol: f64) -> usize {
    if m.post.interpolation() == Interpolation::TipLinear {
        return 1;
    }
    let lever = reach + m.d.abs() + m.h.abs() + m.r.abs();
    let g = turn * turn * lever + 2.0 * turn * len;
    let n = ((g / (8.0 * tol)).sqrt().ceil() as usize).max(1);
    n + n / 4 + 1
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
/// `EXTRA_PIECES` more, the first whose every split tip (part frame, as
/// rounded) `fits`. When no even split does (a region that does not fit
/// around the bead's middle, say, where an even split always puts a tip),
/// an uneven one: from the start, each split tip at the farthest fraction
/// on a fine grid that `fits` and keeps the piece within `tol`. The
/// smallest even split when that fails too. Also says whether every
/// split tip fits. The planner passes "reads as the bead's own layer" (see
/// [`crate::plan::layer_reading`]).
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
    let fewest = smallest.len();
    let fit = |pts: &[Axes]| pts[..pts.len() - 1].iter().all(|x| fits(m.tip(x)));
    if fit(&smallest) {
        return (smallest, true);
    }
    (fewest + 1..=fewest + EXTRA_PIECES)
        .map(split)
        .find(|pts| within(pts) && fit(pts))
        .or_else(|| {
            uneven_split(
                m,
                a,
                b,
                tol,
                (fewest * UNEVEN_STEPS).min(MAX_UNEVEN_STEPS),
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
    let (pa, pb) = (DVec3::from(pa), DVec3::from(pb));
    let p = pa + s * (pb - pa);
    m.axes_at(
        p.to_array(),
        (a.tilt + s * (b.tilt - a.tilt), a.c + s * (b.c - a.c)),
    )
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::Machine;
    use glam::Vec3;

    fn axes(m: &Machine, p: [f64; 3], tilt_deg: f64, c_deg: f64) -> Axes {
        m.axes_at(p, (tilt_deg.to_radians(), c_deg.to_radians()))
    }

    /// How far along the chord `pa → pb` the point `p` projects (0 at
    /// `pa`, 1 at `pb`).
    fn fraction_along(pa: [f64; 3], pb: [f64; 3], p: [f64; 3]) -> f64 {
        let (pa, seg) = (DVec3::from(pa), DVec3::from(pb) - DVec3::from(pa));
        (DVec3::from(p) - pa).dot(seg) / seg.length_squared()
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
                let own = sw.within(DVec3::from(h).length());
                assert!(own <= d);
                let pt = |t: f64| m.pose(&a.lerp(&b, t)).to_part(h.map(|x| x as f32));
                for k in 0..n {
                    let (t0, t1) = (k as f64 / n as f64, (k + 1) as f64 / n as f64);
                    let (x0, x1) = (pt(t0), pt(t1));
                    let step = Vec3::from(x0)
                        .as_dvec3()
                        .distance(Vec3::from(x1).as_dvec3());
                    assert!(
                        step <= own * (t1 - t0) * 1.001 + 1e-4,
                        "{step} > {} for a point {} mm from the tip",
                        own * (t1 - t0),
                        DVec3::from(h).length()
                    );
                }
            }
            for k in 0..=n {
                let t = k as f64 / n as f64;
                let tip = DVec3::from(m.tip(&a.lerp(&b, t)));
                let (pa, pb) = (DVec3::from(pa), DVec3::from(pb));
                worst_dev = worst_dev.max(tip.distance(pa + t * (pb - pa)));
            }
            assert!(
                worst_dev <= dev * 1.0001 + 1e-9,
                "tip deviation {worst_dev} > bound {dev}"
            );
        }
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
            let u = fraction_along(pa, pb, t);
            let on = DVec3::from(pa) + u * (DVec3::from(pb) - DVec3::from(pa));
            assert!(DVec3::from(t).distance(on) < 0.002);
            prev = *q;
        }
    }

    /// A bead's pieces are no more than `pieces_bound` says, for beads of
    /// every length and turn up to 60°, anywhere on the platform (and
    /// the bound is no loose guess: it is met on many of them).
    #[test]
    fn pieces_bound_holds_over_random_beads() {
        let m = Machine::default();
        let mut u = crate::geometry::xorshift(0x0b0a_7e11);
        let mut met = 0;
        for k in 0..2000 {
            let p = [60.0 * u() - 30.0, 60.0 * u() - 30.0, 10.0 + 60.0 * u()];
            let len = 3.0 * u();
            let q = [p[0] + len * u(), p[1] + len * u(), p[2] + len * u()];
            let (t, c) = (180.0 * u() - 90.0, 360.0 * u());
            let turn = 60.0 * u() * u();
            let share = u();
            let a = axes(&m, p, t, c);
            let b = axes(&m, q, t + share * turn, c + (1.0 - share) * turn);
            let reach = DVec3::from(m.tip(&a))
                .length()
                .max(DVec3::from(m.tip(&b)).length());
            let chord = DVec3::from(m.tip(&a)).distance(DVec3::from(m.tip(&b)));
            let bound = pieces_bound(&m, reach, chord, turn.to_radians(), 0.05);
            let n = tip_subdivision(&m, &a, &b, 0.05).len();
            assert!(n <= bound, "bead {k}: {n} pieces, bound {bound}");
            met += (n + 1 >= bound) as usize;
        }
        assert!(met > 200, "{met} beads near their bound");
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
        let u = |p: [f64; 3]| fraction_along(pa, pb, p);
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
        let u = |p: [f64; 3]| fraction_along(pa, pb, p);
        // Every even split of n pieces has a tip within 1/(2n) of the
        // middle (0 for even n): refuse a little more than the widest.
        let fewest = tip_subdivision(&m, &a, &b, 0.05).len();
        let widest = (fewest..=fewest + EXTRA_PIECES)
            .map(|n| if n % 2 == 0 { 0.0 } else { 0.5 / n as f64 })
            .fold(0.0, f64::max);
        let half = 1.02 * widest;
        let fits = |p: [f64; 3]| (u(p) - 0.5).abs() >= half;
        for n in fewest..=fewest + EXTRA_PIECES {
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

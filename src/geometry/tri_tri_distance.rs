//! Euclidean distance between two triangles in `f32`, for the safety margin
//! (a query collides when an existing triangle comes closer than `margin`
//! to the head; DESIGN.md). `shaders/shared/tri_tri_distance.wgsl` mirrors
//! this file line for line, so the cpu and gpu backends round alike.
//!
//! The classic decomposition: two disjoint triangles are closest at a vertex
//! of one and the face of the other, or at an edge of each. So the distance
//! is the minimum of the 6 vertex–triangle distances (Ericson, "Real-Time
//! Collision Detection", 5.1.5), the 9 edge–edge distances (Ericson 5.1.9)
//! and, so that crossing triangles get 0, the distances from the 6 points
//! where an edge strictly crosses the other triangle's plane to that
//! triangle (0 when the edge pierces it). Every term is the distance between
//! a point of one triangle and the other, so the minimum never
//! underestimates beyond rounding. Everything works on squared distances;
//! callers compare with `margin²`.
//!
//! [`tri_tri_closer_than`] is the predicate the evaluators use: most pairs
//! it sees lie more than the margin apart on either side of one
//! triangle's plane (a lower bound on their distance), which three dot
//! products show ([`plane_separates`]); of the rest, nearly all lie more
//! than the margin apart along an axis `e × f` of an edge of each
//! ([`edge_axes_separate`]: 98 % of the pairs near a nozzle tilted 50°
//! over dome_cut), before the 21 distance terms run.
//!
//! The brute-force evaluator (`collide/brute.rs`) has its own `f64`
//! distance by a different formulation; tests compare the two.

use super::{add, cross, dot, scale, sub, V3};

/// Stands for "no candidate" in a minimum of squared distances (larger than
/// any squared distance in millimetres the scenes produce; WGSL has no
/// infinity literal).
pub const NO_DISTANCE: f32 = 1e30;

/// Squared distance between triangles `(a, b, c)` and `(p, q, r)`; 0 when
/// they touch or cross.
pub fn tri_tri_distance_sq(a: V3, b: V3, c: V3, p: V3, q: V3, r: V3) -> f32 {
    // Vertex of one against the face of the other.
    let mut d = point_triangle_distance_sq(a, p, q, r);
    d = d.min(point_triangle_distance_sq(b, p, q, r));
    d = d.min(point_triangle_distance_sq(c, p, q, r));
    d = d.min(point_triangle_distance_sq(p, a, b, c));
    d = d.min(point_triangle_distance_sq(q, a, b, c));
    d = d.min(point_triangle_distance_sq(r, a, b, c));
    // Edge against edge.
    d = d.min(segment_segment_distance_sq(a, b, p, q));
    d = d.min(segment_segment_distance_sq(a, b, q, r));
    d = d.min(segment_segment_distance_sq(a, b, r, p));
    d = d.min(segment_segment_distance_sq(b, c, p, q));
    d = d.min(segment_segment_distance_sq(b, c, q, r));
    d = d.min(segment_segment_distance_sq(b, c, r, p));
    d = d.min(segment_segment_distance_sq(c, a, p, q));
    d = d.min(segment_segment_distance_sq(c, a, q, r));
    d = d.min(segment_segment_distance_sq(c, a, r, p));
    // Edges piercing the other triangle.
    let n1 = cross(sub(b, a), sub(c, a));
    let n2 = cross(sub(q, p), sub(r, p));
    d = d.min(edge_crossing_distance_sq(a, b, p, q, r, n2));
    d = d.min(edge_crossing_distance_sq(b, c, p, q, r, n2));
    d = d.min(edge_crossing_distance_sq(c, a, p, q, r, n2));
    d = d.min(edge_crossing_distance_sq(p, q, a, b, c, n1));
    d = d.min(edge_crossing_distance_sq(q, r, a, b, c, n1));
    d = d.min(edge_crossing_distance_sq(r, p, a, b, c, n1));
    d
}

/// Are triangles `(a, b, c)` and `(p, q, r)` closer than `margin`
/// (`margin > 0`)? Plane separation first, then the edge axes
/// ([`edge_axes_separate`]), then [`tri_tri_distance_sq`].
#[inline(always)]
pub fn tri_tri_closer_than(a: V3, b: V3, c: V3, p: V3, q: V3, r: V3, margin: f32) -> bool {
    let m2 = margin * margin;
    let n1 = cross(sub(b, a), sub(c, a));
    if plane_separates(n1, -dot(n1, a), m2 * dot(n1, n1), p, q, r) {
        return false;
    }
    let n2 = cross(sub(q, p), sub(r, p));
    if plane_separates(n2, -dot(n2, p), m2 * dot(n2, n2), a, b, c) {
        return false;
    }
    if edge_axes_separate(a, b, c, p, q, r, m2) {
        return false;
    }
    tri_tri_distance_sq(a, b, c, p, q, r) < m2
}

/// Do triangles `(a, b, c)` and `(p, q, r)` lie at least `√m2` apart along
/// one of the nine axes `l = e × f` (`e` an edge of the first, `f` of the
/// second)? The gap between their intervals of `l · x` over `|l|` is a
/// lower bound on their distance (the separating axis theorem), compared
/// squared: `s² ≥ m2 |l|²`. Along `l` an edge's two ends project alike, so
/// each triangle's interval is its edge's value and its third vertex's:
/// three dot products an axis, measured from `e`'s start. Pairs that only
/// the distance terms could tell apart from a pair within the margin are
/// those whose closest points are a vertex and a face (the planes see
/// those) or an edge of each (these axes do).
#[inline(always)]
pub fn edge_axes_separate(a: V3, b: V3, c: V3, p: V3, q: V3, r: V3, m2: f32) -> bool {
    let first = [a, b, c];
    let second = [p, q, r];
    for i in 0..3 {
        let (u0, u1, u2) = (first[i], first[(i + 1) % 3], first[(i + 2) % 3]);
        let e = sub(u1, u0);
        for j in 0..3 {
            let (w0, w1, w2) = (second[j], second[(j + 1) % 3], second[(j + 2) % 3]);
            let l = cross(e, sub(w1, w0));
            let ll = dot(l, l);
            // Parallel edges span no axis.
            if ll <= 1e-12 {
                continue;
            }
            // The first triangle's interval is 0 and x, the second's y0
            // and y1 (all from u0).
            let x = dot(l, sub(u2, u0));
            let y0 = dot(l, sub(w0, u0));
            let y1 = dot(l, sub(w2, u0));
            let gap = y0.min(y1) - x.max(0.0);
            let gap = gap.max(x.min(0.0) - y0.max(y1));
            if gap > 0.0 && gap * gap >= m2 * ll {
                return true;
            }
        }
    }
    false
}

/// Do `p`, `q` and `r` all lie strictly on one side of the plane
/// `n · x + d = 0` (`n` unnormalised), at least `margin` from it, where
/// `lim = margin² · |n|²`? Then every point of their triangle is at least
/// that far from anything in the plane. Squared, so no square root:
/// `s² ≥ lim` with `s = n · x + d`, the form Möller's test
/// (`geometry::tri_tri::TriPlane`) evaluates, so a caller holding that
/// plane can share it.
#[inline(always)]
pub fn plane_separates(n: V3, d: f32, lim: f32, p: V3, q: V3, r: V3) -> bool {
    let sp = dot(n, p) + d;
    let sq = dot(n, q) + d;
    let sr = dot(n, r) + d;
    let lo = sp.min(sq).min(sr);
    let hi = sp.max(sq).max(sr);
    (lo > 0.0 && lo * lo >= lim) || (hi < 0.0 && hi * hi >= lim)
}

/// Distance between triangles `(a, b, c)` and `(p, q, r)`.
pub fn tri_tri_distance(a: V3, b: V3, c: V3, p: V3, q: V3, r: V3) -> f32 {
    tri_tri_distance_sq(a, b, c, p, q, r).sqrt()
}

/// Where segment `(e0, e1)` strictly crosses the plane of triangle
/// `(a, b, c)` (unnormalised normal `n`), the squared distance from that
/// point to the triangle; [`NO_DISTANCE`] when it does not cross.
#[inline(always)]
pub fn edge_crossing_distance_sq(e0: V3, e1: V3, a: V3, b: V3, c: V3, n: V3) -> f32 {
    let s0 = dot(n, sub(e0, a));
    let s1 = dot(n, sub(e1, a));
    if (s0 > 0.0 && s1 < 0.0) || (s0 < 0.0 && s1 > 0.0) {
        let t = s0 / (s0 - s1);
        let x = add(e0, scale(sub(e1, e0), t));
        return point_triangle_distance_sq(x, a, b, c);
    }
    NO_DISTANCE
}

/// Squared distance between segments `(p1, q1)` and `(p2, q2)`: Ericson's
/// clamped closest points (5.1.9).
#[inline(always)]
pub fn segment_segment_distance_sq(p1: V3, q1: V3, p2: V3, q2: V3) -> f32 {
    let d1 = sub(q1, p1);
    let d2 = sub(q2, p2);
    let r = sub(p1, p2);
    let a = dot(d1, d1);
    let e = dot(d2, d2);
    let f = dot(d2, r);
    let c = dot(d1, r);
    let b = dot(d1, d2);
    let mut s = 0.0;
    let mut t = 0.0;
    if a <= 0.0 {
        if e > 0.0 {
            t = clamp01(f / e);
        }
    } else if e <= 0.0 {
        s = clamp01(-c / a);
    } else {
        let denom = a * e - b * b;
        if denom > 0.0 {
            s = clamp01((b * f - c * e) / denom);
        }
        t = (b * s + f) / e;
        if t < 0.0 {
            t = 0.0;
            s = clamp01(-c / a);
        } else if t > 1.0 {
            t = 1.0;
            s = clamp01((b - c) / a);
        }
    }
    let c1 = add(p1, scale(d1, s));
    let c2 = add(p2, scale(d2, t));
    let d = sub(c1, c2);
    dot(d, d)
}

/// `min(max(x, 0), 1)`, as the WGSL twin spells it (the same for every
/// non-NaN `x`, and the arguments here are never NaN).
#[inline(always)]
fn clamp01(x: f32) -> f32 {
    x.clamp(0.0, 1.0)
}

/// Squared distance from `p` to triangle `(a, b, c)`: Ericson's closest
/// point by Voronoi regions (5.1.5).
#[inline(always)]
pub fn point_triangle_distance_sq(p: V3, a: V3, b: V3, c: V3) -> f32 {
    let x = closest_point(p, a, b, c);
    let d = sub(p, x);
    dot(d, d)
}

#[inline(always)]
fn closest_point(p: V3, a: V3, b: V3, c: V3) -> V3 {
    let ab = sub(b, a);
    let ac = sub(c, a);
    let ap = sub(p, a);
    let d1 = dot(ab, ap);
    let d2 = dot(ac, ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = sub(p, b);
    let d3 = dot(ab, bp);
    let d4 = dot(ac, bp);
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return add(a, scale(ab, d1 / (d1 - d3)));
    }
    let cp = sub(p, c);
    let d5 = dot(ab, cp);
    let d6 = dot(ac, cp);
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return add(a, scale(ac, d2 / (d2 - d6)));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return add(b, scale(sub(c, b), (d4 - d3) / ((d4 - d3) + (d5 - d6))));
    }
    let sum = va + vb + vc;
    if sum <= 0.0 {
        // Degenerate triangle (no interior): the edges above decided.
        return a;
    }
    let v = vb / sum;
    let w = vc / sum;
    add(add(a, scale(ab, v)), scale(ac, w))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::point_triangle_distance::point_triangle_distance;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    type T = [V3; 3];

    fn dist(s: &T, t: &T) -> f32 {
        tri_tri_distance(s[0], s[1], s[2], t[0], t[1], t[2])
    }

    /// Both argument orders and every vertex rotation give one answer.
    fn dist_sym(s: &T, t: &T) -> f32 {
        let d = dist(s, t);
        for (x, y) in [(s, t), (t, s)] {
            for k in 0..3 {
                let x = [x[k], x[(k + 1) % 3], x[(k + 2) % 3]];
                let e = dist(&x, y);
                assert!((e - d).abs() <= 1e-5 * (1.0 + d), "{e} vs {d}");
            }
        }
        d
    }

    fn f64v(v: V3) -> [f64; 3] {
        v.map(|c| c as f64)
    }

    fn at(t: &T, u: f64, v: f64) -> [f64; 3] {
        let [a, b, c] = t.map(f64v);
        std::array::from_fn(|k| a[k] + u * (b[k] - a[k]) + v * (c[k] - a[k]))
    }

    /// The smallest distance from points sampled on `s` to triangle `t`
    /// (exact point–triangle distance in f64), on a barycentric grid of
    /// `n` steps over the window `[u0, u0 + w] × [v0, v0 + w]` clipped to
    /// the triangle; returns (distance, u, v).
    fn sample(s: &T, t: &T, n: u32, u0: f64, v0: f64, w: f64) -> (f64, f64, f64) {
        let [ta, tb, tc] = t.map(f64v);
        let mut best = (f64::INFINITY, u0, v0);
        for i in 0..=n {
            for j in 0..=n {
                let u = (u0 + w * i as f64 / n as f64).clamp(0.0, 1.0);
                let v = (v0 + w * j as f64 / n as f64).clamp(0.0, 1.0);
                if u + v > 1.0 {
                    continue;
                }
                let d = point_triangle_distance(at(s, u, v), ta, tb, tc);
                if d < best.0 {
                    best = (d, u, v);
                }
            }
        }
        best
    }

    /// Distance by dense sampling of both triangles, refined by zooming
    /// in on the best sample (the distance from a point of one convex
    /// triangle to another is a convex function, so zooming converges).
    /// An upper bound that approaches the true distance.
    fn sampled(s: &T, t: &T) -> f64 {
        let one_side = |s: &T, t: &T| {
            let (mut d, mut u, mut v) = sample(s, t, 60, 0.0, 0.0, 1.0);
            let mut w = 1.0;
            for _ in 0..8 {
                w /= 8.0;
                let best = sample(s, t, 24, u - w, v - w, 2.0 * w);
                if best.0 <= d {
                    (d, u, v) = best;
                }
            }
            d
        };
        one_side(s, t).min(one_side(t, s))
    }

    fn random_tri(r: &mut ChaCha8Rng, centre: V3, size: f32) -> T {
        std::array::from_fn(|_| std::array::from_fn(|k| centre[k] + r.random_range(-size..size)))
    }

    /// A unit-size triangle at the origin and one up to 2.5 along x: from
    /// crossing to well apart.
    fn side_by_side(r: &mut ChaCha8Rng) -> (T, T) {
        let s = random_tri(r, [0.0; 3], 1.0);
        let c = r.random_range(0.0..2.5f32);
        (s, random_tri(r, [c, 0.0, 0.0], 1.0))
    }

    #[test]
    fn random_pairs_match_dense_sampling() {
        let mut r = ChaCha8Rng::seed_from_u64(11);
        let (mut crossing, mut near) = (0, 0);
        for i in 0..300 {
            let s = random_tri(&mut r, [0.0; 3], 1.0);
            // From overlapping to well apart, near the data's 100 mm scale.
            let off = r.random_range(0.0..2.0f32);
            let dir: V3 = std::array::from_fn(|_| r.random_range(-1.0..1.0f32));
            let size = r.random_range(0.2..1.5);
            let t = random_tri(
                &mut r,
                [
                    40.0 + off * dir[0],
                    -30.0 + off * dir[1],
                    60.0 + off * dir[2],
                ],
                size,
            );
            let s = s.map(|v| add(v, [40.0, -30.0, 60.0]));
            let got = dist_sym(&s, &t) as f64;
            let want = sampled(&s, &t);
            if got < 1e-5 {
                crossing += 1;
            } else if got < 0.3 {
                near += 1;
            }
            assert!(
                (got - want).abs() < 2e-4,
                "pair {i}: {got} vs sampled {want}: {s:?} {t:?}"
            );
        }
        assert!(
            crossing > 20 && near > 20,
            "{crossing} crossing, {near} near"
        );
    }

    #[test]
    fn parallel_and_coplanar() {
        let s: T = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]];
        // Parallel planes, overlapping in projection: the plane gap.
        let above: T = [[0.5, 0.5, 0.3], [1.5, 0.2, 0.3], [0.2, 1.5, 0.3]];
        assert!((dist_sym(&s, &above) - 0.3).abs() < 1e-6);
        // Parallel, offset sideways: edge to edge across the hypotenuse.
        let beside: T = [[1.5, 1.5, 0.4], [3.0, 1.5, 0.4], [1.5, 3.0, 0.4]];
        let want = (2.0f64 * 0.5f64.powi(2) + 0.16).sqrt() as f32;
        assert!((dist_sym(&s, &beside) - want).abs() < 1e-6);
        // Coplanar and apart: gap between the hypotenuse and a vertex.
        let apart: T = [[1.5, 1.5, 0.0], [3.0, 1.5, 0.0], [1.5, 3.0, 0.0]];
        assert!((dist_sym(&s, &apart) - 0.5f32.sqrt()).abs() < 1e-6);
        // Coplanar, overlapping: 0.
        let over: T = [[0.5, 0.5, 0.0], [3.0, 0.5, 0.0], [0.5, 3.0, 0.0]];
        assert_eq!(dist_sym(&s, &over), 0.0);
        // Parallel edges (degenerate closest-point problem).
        let edge: T = [[0.0, -0.25, 0.0], [2.0, -0.25, 0.0], [1.0, -1.0, 0.0]];
        assert!((dist_sym(&s, &edge) - 0.25).abs() < 1e-6);
        let sampled_edge = sampled(&s, &edge);
        assert!((sampled_edge - 0.25).abs() < 1e-5);
    }

    #[test]
    fn touching_and_crossing() {
        let s: T = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]];
        // A needle through the middle: only the edge-crossing terms see it.
        let needle: T = [[0.5, 0.5, -3.0], [0.6, 0.5, 3.0], [0.5, 0.6, 3.0]];
        assert_eq!(dist_sym(&s, &needle), 0.0);
        // A vertex resting on the face.
        let resting: T = [[0.5, 0.5, 0.0], [1.0, 0.5, 1.0], [0.5, 1.0, 1.0]];
        assert_eq!(dist_sym(&s, &resting), 0.0);
        // Sharing an edge.
        let hinge: T = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [1.0, -1.0, 1.0]];
        assert_eq!(dist_sym(&s, &hinge), 0.0);
    }

    #[test]
    fn edge_to_edge_only() {
        // Skew edges: the closest points are inside an edge of each; every
        // vertex is much farther from the other face, and where an edge
        // crosses the other plane it is outside the other triangle.
        let s: T = [[-1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 3.0, -3.0]];
        let t: T = [[0.0, -1.0, 0.04], [0.0, 1.0, 0.04], [3.0, 0.0, 3.04]];
        let d = dist_sym(&s, &t);
        assert!((d - 0.04).abs() < 1e-6, "{d}");
        assert!((sampled(&s, &t) - 0.04).abs() < 1e-5);
        // Without the edge-edge terms the others say ≥ 0.056.
        let n1 = cross(sub(s[1], s[0]), sub(s[2], s[0]));
        let n2 = cross(sub(t[1], t[0]), sub(t[2], t[0]));
        let others = [
            point_triangle_distance_sq(s[0], t[0], t[1], t[2]),
            point_triangle_distance_sq(s[1], t[0], t[1], t[2]),
            point_triangle_distance_sq(s[2], t[0], t[1], t[2]),
            point_triangle_distance_sq(t[0], s[0], s[1], s[2]),
            point_triangle_distance_sq(t[1], s[0], s[1], s[2]),
            point_triangle_distance_sq(t[2], s[0], s[1], s[2]),
            edge_crossing_distance_sq(s[0], s[1], t[0], t[1], t[2], n2),
            edge_crossing_distance_sq(s[1], s[2], t[0], t[1], t[2], n2),
            edge_crossing_distance_sq(s[2], s[0], t[0], t[1], t[2], n2),
            edge_crossing_distance_sq(t[0], t[1], s[0], s[1], s[2], n1),
            edge_crossing_distance_sq(t[1], t[2], s[0], s[1], s[2], n1),
            edge_crossing_distance_sq(t[2], t[0], s[0], s[1], s[2], n1),
        ]
        .into_iter()
        .fold(f32::INFINITY, f32::min)
        .sqrt();
        assert!(others > 0.056, "{others}");
    }

    #[test]
    fn closer_than_agrees_with_the_distance() {
        let mut r = ChaCha8Rng::seed_from_u64(3);
        let mut separated = 0;
        for _ in 0..3000 {
            let (s, t) = side_by_side(&mut r);
            let d = dist(&s, &t);
            let m = r.random_range(0.01..1.0f32);
            let n = cross(sub(t[1], t[0]), sub(t[2], t[0]));
            let lim = m * m * dot(n, n);
            separated += plane_separates(n, -dot(n, t[0]), lim, s[0], s[1], s[2]) as u32;
            if (d - m).abs() > 1e-5 {
                assert_eq!(
                    tri_tri_closer_than(s[0], s[1], s[2], t[0], t[1], t[2], m),
                    d < m,
                    "{d} vs margin {m}: {s:?} {t:?}"
                );
            }
        }
        assert!(separated > 300, "{separated} pairs separated by a plane");
    }

    /// Does either triangle's plane part `s` and `t` by `√m2`?
    fn planes_part(s: &T, t: &T, m2: f32) -> bool {
        let beyond = |u: &T, v: &T| {
            let n = cross(sub(u[1], u[0]), sub(u[2], u[0]));
            plane_separates(n, -dot(n, u[0]), m2 * dot(n, n), v[0], v[1], v[2])
        };
        beyond(s, t) || beyond(t, s)
    }

    /// The edge axes never part a pair within the margin, and they part
    /// most pairs beside each other that neither plane does.
    #[test]
    fn edge_axes_part_only_pairs_farther_than_the_margin() {
        let mut r = ChaCha8Rng::seed_from_u64(5);
        let (mut past_planes, mut parted) = (0, 0);
        for _ in 0..4000 {
            let (s, t) = side_by_side(&mut r);
            let d = dist(&s, &t);
            let m = r.random_range(0.01..0.5f32);
            let m2 = m * m;
            let [a, b, cc] = s;
            let [p, q, rr] = t;
            if edge_axes_separate(a, b, cc, p, q, rr, m2) {
                assert!(d >= m * (1.0 - 1e-4), "{d} vs margin {m}: {s:?} {t:?}");
            }
            if !planes_part(&s, &t, m2) && d > 1.5 * m {
                past_planes += 1;
                parted += edge_axes_separate(a, b, cc, p, q, rr, m2) as u32;
            }
        }
        assert!(past_planes > 200, "{past_planes} pairs past the planes");
        assert!(
            parted * 2 > past_planes,
            "{parted} of {past_planes} pairs past the planes parted by an edge axis"
        );
    }

    /// Skew edges, each the other's nearest: only an edge axis parts them
    /// before the distance terms.
    #[test]
    fn skew_edges_are_parted_by_their_axis() {
        // Two triangles whose closest points are inside an edge of each,
        // 1 apart along z, each plane cutting through the other triangle.
        let s: T = [[-1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.5, -2.0]];
        let t: T = [[0.0, -1.0, 1.0], [0.0, 1.0, 1.0], [0.5, 0.0, 3.0]];
        let [a, b, c] = s;
        let [p, q, r] = t;
        assert!(!planes_part(&s, &t, 0.25));
        assert!((dist(&s, &t) - 1.0).abs() < 1e-3, "{}", dist(&s, &t));
        assert!(edge_axes_separate(a, b, c, p, q, r, 0.9 * 0.9));
        assert!(!edge_axes_separate(a, b, c, p, q, r, 1.1 * 1.1));
        assert!(!tri_tri_closer_than(a, b, c, p, q, r, 0.9));
        assert!(tri_tri_closer_than(a, b, c, p, q, r, 1.1));
    }

    #[test]
    fn segments() {
        let d = |a: V3, b: V3, c: V3, e: V3| segment_segment_distance_sq(a, b, c, e).sqrt();
        // Crossing in projection, 1 apart.
        assert!(
            (d([0.0; 3], [2.0, 0.0, 0.0], [1.0, -1.0, 1.0], [1.0, 1.0, 1.0]) - 1.0).abs() < 1e-6
        );
        // Collinear, gap 1.
        assert!(
            (d([0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0], [3.0, 0.0, 0.0]) - 1.0).abs() < 1e-6
        );
        // Parallel, overlapping.
        assert!(
            (d([0.0; 3], [2.0, 0.0, 0.0], [1.0, 0.5, 0.0], [3.0, 0.5, 0.0]) - 0.5).abs() < 1e-6
        );
        // Point against segment.
        assert!(
            (d([1.0, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0; 3], [2.0, 0.0, 0.0]) - 1.0).abs() < 1e-6
        );
    }
}

//! Möller's triangle–triangle overlap test ("A Fast Triangle-Triangle
//! Intersection Test", JGT 1997), with the coplanar case, and a tolerance
//! given in millimetres rather than Möller's absolute `EPSILON`.
//!
//! A vertex closer than `tol` to the other triangle's plane is snapped onto
//! it, so touching within `tol` counts as contact; this is the one place
//! where the backends may legitimately differ from an exact-arithmetic
//! answer (DESIGN.md: near-contacts under 1e-3 mm). Intervals that merely
//! touch count as overlapping. `shaders/shared/tri_tri.wgsl` mirrors this
//! file line for line.

use super::{cross, dot, length, sub, V3};

/// True when triangles `(v0, v1, v2)` and `(u0, u1, u2)` share a point
/// (within `tol` mm of each other's planes). Degenerate (zero-area)
/// triangles never overlap: loaders drop them.
pub fn tri_tri_overlap(v0: V3, v1: V3, v2: V3, u0: V3, u1: V3, u2: V3, tol: f32) -> bool {
    TriPlane::new(v0, v1, v2, tol).overlaps(v0, v1, v2, u0, u1, u2, tol)
}

/// The plane of a triangle `V` with its snapping threshold, computed once
/// when `V` is tested against many triangles.
#[derive(Clone, Copy, Debug)]
pub struct TriPlane {
    /// Unnormalised normal `(v1 − v0) × (v2 − v0)`.
    pub n: V3,
    /// Offset: `n · x + d = 0` on the plane.
    pub d: f32,
    /// `tol · |n|`: distances (scaled by `|n|`) below it snap to 0.
    pub t: f32,
}

impl TriPlane {
    /// The plane of `(v0, v1, v2)`.
    #[inline(always)]
    pub fn new(v0: V3, v1: V3, v2: V3, tol: f32) -> TriPlane {
        let n = cross(sub(v1, v0), sub(v2, v0));
        TriPlane {
            n,
            d: -dot(n, v0),
            t: tol * length(n),
        }
    }

    /// Möller's test of `V = (v0, v1, v2)` (this plane's triangle) against
    /// `U = (u0, u1, u2)`.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub fn overlaps(&self, v0: V3, v1: V3, v2: V3, u0: V3, u1: V3, u2: V3, tol: f32) -> bool {
        let (n1, d1, t1) = (self.n, self.d, self.t);
        if t1 == 0.0 {
            return false;
        }
        let du0 = snap(dot(n1, u0) + d1, t1);
        let du1 = snap(dot(n1, u1) + d1, t1);
        let du2 = snap(dot(n1, u2) + d1, t1);
        let du0du1 = du0 * du1;
        let du0du2 = du0 * du2;
        if du0du1 > 0.0 && du0du2 > 0.0 {
            return false; // U strictly on one side of V's plane.
        }
        overlap_rest(n1, v0, v1, v2, u0, u1, u2, du0, du1, du2, tol)
    }
}

/// The rest of Möller's test once `U` straddles `V`'s plane.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn overlap_rest(
    n1: V3,
    v0: V3,
    v1: V3,
    v2: V3,
    u0: V3,
    u1: V3,
    u2: V3,
    du0: f32,
    du1: f32,
    du2: f32,
    tol: f32,
) -> bool {
    let du0du1 = du0 * du1;
    let du0du2 = du0 * du2;
    // Plane of U.
    let n2 = cross(sub(u1, u0), sub(u2, u0));
    let l2 = length(n2);
    if l2 == 0.0 {
        return false;
    }
    let d2 = -dot(n2, u0);
    let t2 = tol * l2;
    let dv0 = snap(dot(n2, v0) + d2, t2);
    let dv1 = snap(dot(n2, v1) + d2, t2);
    let dv2 = snap(dot(n2, v2) + d2, t2);
    let dv0dv1 = dv0 * dv1;
    let dv0dv2 = dv0 * dv2;
    if dv0dv1 > 0.0 && dv0dv2 > 0.0 {
        return false;
    }

    // Direction of the planes' intersection line; project on its largest axis.
    let d = cross(n1, n2);
    let ax = d[0].abs();
    let ay = d[1].abs();
    let az = d[2].abs();
    let mut index = 0usize;
    let mut max = ax;
    if ay > max {
        max = ay;
        index = 1;
    }
    if az > max {
        index = 2;
    }
    let vp0 = v0[index];
    let vp1 = v1[index];
    let vp2 = v2[index];
    let up0 = u0[index];
    let up1 = u1[index];
    let up2 = u2[index];

    let iv = match interval(vp0, vp1, vp2, dv0, dv1, dv2, dv0dv1, dv0dv2) {
        Some(i) => i,
        None => return coplanar_tri_tri(n1, v0, v1, v2, u0, u1, u2),
    };
    let iu = match interval(up0, up1, up2, du0, du1, du2, du0du1, du0du2) {
        Some(i) => i,
        None => return coplanar_tri_tri(n1, v0, v1, v2, u0, u1, u2),
    };
    let (a0, a1) = sorted(iv.0, iv.1);
    let (b0, b1) = sorted(iu.0, iu.1);
    !(a1 < b0 || b1 < a0)
}

#[inline(always)]
fn snap(d: f32, t: f32) -> f32 {
    if d.abs() < t {
        0.0
    } else {
        d
    }
}

#[inline(always)]
fn sorted(a: f32, b: f32) -> (f32, f32) {
    if a > b {
        (b, a)
    } else {
        (a, b)
    }
}

/// The interval where a triangle crosses the other's plane, on the
/// projection axis; `None` when the triangle lies in that plane.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn interval(
    vv0: f32,
    vv1: f32,
    vv2: f32,
    d0: f32,
    d1: f32,
    d2: f32,
    d0d1: f32,
    d0d2: f32,
) -> Option<(f32, f32)> {
    if d0d1 > 0.0 {
        // d0, d1 on the same side; d2 on the other (or on the plane).
        Some(isect(vv2, vv0, vv1, d2, d0, d1))
    } else if d0d2 > 0.0 {
        Some(isect(vv1, vv0, vv2, d1, d0, d2))
    } else if d1 * d2 > 0.0 || d0 != 0.0 {
        Some(isect(vv0, vv1, vv2, d0, d1, d2))
    } else if d1 != 0.0 {
        Some(isect(vv1, vv0, vv2, d1, d0, d2))
    } else if d2 != 0.0 {
        Some(isect(vv2, vv0, vv1, d2, d0, d1))
    } else {
        None
    }
}

/// Where edges from the lone vertex `a` (signed distance `da`) to `b` and `c`
/// cross the plane, as parameters on the projection axis.
#[inline(always)]
fn isect(a: f32, b: f32, c: f32, da: f32, db: f32, dc: f32) -> (f32, f32) {
    (a + (b - a) * da / (da - db), a + (c - a) * da / (da - dc))
}

/// Coplanar case: project onto the axis-aligned plane where the triangles
/// are largest, then edge–edge and containment tests in 2-D.
fn coplanar_tri_tri(n: V3, v0: V3, v1: V3, v2: V3, u0: V3, u1: V3, u2: V3) -> bool {
    let a = [n[0].abs(), n[1].abs(), n[2].abs()];
    let (i0, i1) = if a[0] > a[1] {
        if a[0] > a[2] {
            (1, 2)
        } else {
            (0, 1)
        }
    } else if a[2] > a[1] {
        (0, 1)
    } else {
        (0, 2)
    };
    let p = |v: V3| [v[i0], v[i1]];
    let (pv0, pv1, pv2) = (p(v0), p(v1), p(v2));
    let (pu0, pu1, pu2) = (p(u0), p(u1), p(u2));
    edge_against_tri(pv0, pv1, pu0, pu1, pu2)
        || edge_against_tri(pv1, pv2, pu0, pu1, pu2)
        || edge_against_tri(pv2, pv0, pu0, pu1, pu2)
        || point_in_tri_2d(pv0, pu0, pu1, pu2)
        || point_in_tri_2d(pu0, pv0, pv1, pv2)
}

type P2 = [f32; 2];

/// Edge `(a, b)` against the three edges of triangle `(c0, c1, c2)`.
#[inline(always)]
fn edge_against_tri(a: P2, b: P2, c0: P2, c1: P2, c2: P2) -> bool {
    edge_edge(a, b, c0, c1) || edge_edge(a, b, c1, c2) || edge_edge(a, b, c2, c0)
}

/// Franklin Antonio's segment–segment test (Graphics Gems III), as in
/// Möller's code: closed segments, so touching counts.
#[inline(always)]
fn edge_edge(v0: P2, v1: P2, u0: P2, u1: P2) -> bool {
    let ax = v1[0] - v0[0];
    let ay = v1[1] - v0[1];
    let bx = u0[0] - u1[0];
    let by = u0[1] - u1[1];
    let cx = v0[0] - u0[0];
    let cy = v0[1] - u0[1];
    let f = ay * bx - ax * by;
    let d = by * cx - bx * cy;
    if (f > 0.0 && d >= 0.0 && d <= f) || (f < 0.0 && d <= 0.0 && d >= f) {
        let e = ax * cy - ay * cx;
        if f > 0.0 {
            if e >= 0.0 && e <= f {
                return true;
            }
        } else if e <= 0.0 && e >= f {
            return true;
        }
    }
    false
}

/// Is `p` inside (or on) the 2-D triangle `(a, b, c)`, either orientation.
#[inline(always)]
fn point_in_tri_2d(p: P2, a: P2, b: P2, c: P2) -> bool {
    let e0 = (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]);
    let e1 = (c[0] - b[0]) * (p[1] - b[1]) - (c[1] - b[1]) * (p[0] - b[0]);
    let e2 = (a[0] - c[0]) * (p[1] - c[1]) - (a[1] - c[1]) * (p[0] - c[0]);
    (e0 >= 0.0 && e1 >= 0.0 && e2 >= 0.0) || (e0 <= 0.0 && e1 <= 0.0 && e2 <= 0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    const T: f32 = 1e-5;

    #[test]
    fn crossing_triangles_overlap() {
        let a = ([0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]);
        let b = ([0.5, 0.5, -1.0], [0.5, 0.5, 1.0], [1.5, 0.2, 0.0]);
        assert!(tri_tri_overlap(a.0, a.1, a.2, b.0, b.1, b.2, T));
        assert!(tri_tri_overlap(b.0, b.1, b.2, a.0, a.1, a.2, T));
    }

    #[test]
    fn separated_triangles_do_not() {
        let a = ([0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]);
        let b = ([0.5, 0.5, 0.1], [0.5, 0.5, 1.0], [1.5, 0.2, 0.5]);
        assert!(!tri_tri_overlap(a.0, a.1, a.2, b.0, b.1, b.2, T));
        // Straddles the plane but outside the triangle.
        let c = ([3.0, 3.0, -1.0], [3.0, 3.0, 1.0], [4.0, 3.0, 0.0]);
        assert!(!tri_tri_overlap(a.0, a.1, a.2, c.0, c.1, c.2, T));
    }

    #[test]
    fn coplanar_cases() {
        let a = ([0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]);
        let inside = ([0.2, 0.2, 0.0], [0.5, 0.2, 0.0], [0.2, 0.5, 0.0]);
        let crossing = ([1.0, -1.0, 0.0], [1.0, 3.0, 0.0], [3.0, 1.0, 0.0]);
        let apart = ([3.0, 3.0, 0.0], [4.0, 3.0, 0.0], [3.0, 4.0, 0.0]);
        let edge_touch = ([2.0, 0.0, 0.0], [3.0, 0.0, 0.0], [2.0, 1.0, 0.0]);
        for (t, want) in [
            (inside, true),
            (crossing, true),
            (apart, false),
            (edge_touch, true),
        ] {
            assert_eq!(tri_tri_overlap(a.0, a.1, a.2, t.0, t.1, t.2, T), want);
            assert_eq!(tri_tri_overlap(t.0, t.1, t.2, a.0, a.1, a.2, T), want);
        }
    }

    #[test]
    fn touching_within_tolerance_counts() {
        let a = ([0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]);
        let b = ([0.5, 0.5, 0.5e-5], [0.5, 0.5, 1.0], [1.5, 0.2, 0.5]);
        assert!(tri_tri_overlap(a.0, a.1, a.2, b.0, b.1, b.2, T));
        let c = ([0.5, 0.5, 1e-3], [0.5, 0.5, 1.0], [1.5, 0.2, 0.5]);
        assert!(!tri_tri_overlap(a.0, a.1, a.2, c.0, c.1, c.2, T));
    }
}

//! Brute force, the ground truth for tests: every existing part triangle
//! against every head triangle with Möller's test, containment by the
//! generalised winding number in `f64` (an algorithm independent of the
//! backends' ray parity), and, for a positive safety margin, the distance
//! of every triangle pair in `f64` by a formulation of its own (below),
//! independent of the backends' `f32` one. Quadratic; only for small
//! scenes.
//!
//! Distance here: the triangles are moved into the head frame in `f64`;
//! a pair's distance is the smallest of the vertex-to-face distances whose
//! projection lands inside the face (barycentric signs), the 9 edge-to-edge
//! distances (the interior critical point of the two segment parameters
//! when it lies in the unit square, else the four endpoint-to-segment
//! distances with clamped parameters), and 0 when an edge strictly crosses
//! the other triangle's plane inside it.
//!
//! A margin with a slope is each triangle's own: `margin + slope · ρ`,
//! `ρ` its farthest corner's distance from the tip (in `f64`).

use super::{check_finite, Backend, CollideError, Query};
use crate::geometry::point_segment_distance::point_segment_distance;
use crate::geometry::point_triangle_distance::point_triangle_distance;
use crate::geometry::tri_tri::tri_tri_overlap;
use crate::geometry::{Aabb, Mesh, Pose, V3};
use crate::scene::Scene;
use glam::DVec3;
use rayon::prelude::*;

/// A point or vector in `f64`.
pub type D3 = [f64; 3];

/// A triangle in `f64` with its bounding box.
#[derive(Clone, Copy, Debug)]
struct Tri64 {
    v: [D3; 3],
    min: D3,
    max: D3,
}

impl Tri64 {
    fn new(v: [D3; 3]) -> Tri64 {
        let min = std::array::from_fn(|k| v[0][k].min(v[1][k]).min(v[2][k]));
        let max = std::array::from_fn(|k| v[0][k].max(v[1][k]).max(v[2][k]));
        Tri64 { v, min, max }
    }

    /// Boxes closer than `gap` on every axis.
    fn boxes_within(&self, o: &Tri64, gap: f64) -> bool {
        (0..3).all(|k| self.min[k] <= o.max[k] + gap && o.min[k] <= self.max[k] + gap)
    }
}

/// The brute-force evaluator.
pub struct BruteBackend<'a> {
    scene: &'a Scene,
    /// Head triangles in `f64` (head frame).
    head64: Vec<Tri64>,
    /// The head's box (head frame).
    head_box: Aabb,
}

impl<'a> BruteBackend<'a> {
    /// Over `scene`.
    pub fn new(scene: &'a Scene) -> Self {
        let head = &scene.head.mesh;
        let head64 = (0..head.triangles.len())
            .map(|i| Tri64::new(head.corners(i).map(to64)))
            .collect();
        BruteBackend {
            scene,
            head64,
            head_box: Aabb::from_points(&head.vertices),
        }
    }

    fn hits(&self, q: &Query) -> bool {
        let head = &self.scene.head.mesh;
        let tol = self.scene.tol;
        let pose = &q.pose;
        self.scene
            .part_tris
            .iter()
            .filter(|t| t.stamp < q.cutoff)
            .any(|t| {
                let a = pose.to_head(t.v0);
                let b = pose.to_head(t.v1);
                let c = pose.to_head(t.v2);
                let margin = self.triangle_margin(q, t);
                // Exact pruning only: a triangle whose box misses the
                // head's box grown by its margin (and the tolerance) can
                // neither cross, nor be inside, nor come within the margin.
                let tb = Aabb::from_points(&[a, b, c]);
                if !tb.overlaps(&self.head_box_grown(margin)) {
                    return false;
                }
                let crossing_or_inside = (0..head.triangles.len()).any(|i| {
                    let [h0, h1, h2] = head.corners(i);
                    tri_tri_overlap(a, b, c, h0, h1, h2, tol)
                }) || winding_number(head, a) > 0.5;
                crossing_or_inside
                    || (margin > 0.0
                        && self.triangle_distance(pose, t.v0, t.v1, t.v2, margin) < margin)
            })
    }

    /// Distance (f64) from the part triangle `(v0, v1, v2)` (part frame)
    /// to the head's surface at `pose`, or `cap` when nothing is closer.
    fn triangle_distance(&self, pose: &Pose, v0: V3, v1: V3, v2: V3, cap: f64) -> f64 {
        let t = Tri64::new([v0, v1, v2].map(|p| to_head64(pose, p)));
        self.head64
            .iter()
            .filter(|h| t.boxes_within(h, cap))
            .map(|h| tri_tri_distance64(&t.v, &h.v))
            .fold(cap, f64::min)
    }

    /// The head's box (head frame) grown by `by` and the contact
    /// tolerance: a part triangle whose box misses it can neither cross,
    /// nor be inside, nor come within `by` of the head.
    fn head_box_grown(&self, by: f64) -> Aabb {
        let grow = by as f32 + 2.0 * self.scene.tol;
        Aabb {
            min: self.head_box.min.map(|x| x - grow),
            max: self.head_box.max.map(|x| x + grow),
        }
    }

    /// The margin the part triangle `t` must keep at `q` (f64): the
    /// query's margin grown by its slope at `t`'s corner farthest from the
    /// tip.
    pub fn triangle_margin(&self, q: &Query, t: &crate::scene::GpuTriangle) -> f64 {
        let far = [t.v0, t.v1, t.v2]
            .map(|v| {
                let d: D3 = std::array::from_fn(|k| v[k] as f64 - q.pose.tip[k] as f64);
                (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
            })
            .into_iter()
            .fold(0.0, f64::max);
        q.margin as f64 + q.slope as f64 * far
    }

    /// How far (f64) the nearest existing part triangle is from violating
    /// its margin at `q`: the smallest `distance − margin` over triangles
    /// (negative inside the margin; a triangle inside the head counts by
    /// its distance to the surface), or `cap` when every triangle is more
    /// than `cap` beyond its margin. Tests use it to judge whether a
    /// disagreement between backends is a near-contact.
    pub fn margin_slack(&self, q: &Query, cap: f64) -> f64 {
        self.scene
            .part_tris
            .par_iter()
            .filter(|t| t.stamp < q.cutoff)
            .filter_map(|t| {
                let margin = self.triangle_margin(q, t);
                let tb = Aabb::from_points(&[t.v0, t.v1, t.v2].map(|p| q.pose.to_head(p)));
                tb.overlaps(&self.head_box_grown(margin + cap)).then(|| {
                    self.triangle_distance(&q.pose, t.v0, t.v1, t.v2, margin + cap) - margin
                })
            })
            .reduce(|| cap, f64::min)
    }

    /// Distance (f64) between the head's surface at `q.pose` and the
    /// nearest existing part triangle (`stamp < q.cutoff`), or `cap` when
    /// nothing is closer than `cap`. Triangles inside the head count by
    /// their distance to its surface. Tests use it to judge whether a
    /// disagreement between backends is a near-contact.
    pub fn surface_distance(&self, q: &Query, cap: f64) -> f64 {
        let grown = self.head_box_grown(cap);
        self.scene
            .part_tris
            .par_iter()
            .filter(|t| t.stamp < q.cutoff)
            .filter(|t| {
                let tb = Aabb::from_points(&[t.v0, t.v1, t.v2].map(|p| q.pose.to_head(p)));
                tb.overlaps(&grown)
            })
            .map(|t| self.triangle_distance(&q.pose, t.v0, t.v1, t.v2, cap))
            .reduce(|| cap, f64::min)
    }
}

impl Backend for BruteBackend<'_> {
    fn name(&self) -> &'static str {
        "brute"
    }

    fn evaluate(&self, queries: &[Query]) -> Result<Vec<bool>, CollideError> {
        check_finite(queries)?;
        Ok(queries.par_iter().map(|q| self.hits(q)).collect())
    }
}

fn to64(v: V3) -> D3 {
    v.map(|c| c as f64)
}

/// Part frame → head frame in `f64`: `Rᵀ (p − tip)`.
fn to_head64(pose: &Pose, p: V3) -> D3 {
    let d = DVec3::from(std::array::from_fn(|k| p[k] as f64 - pose.tip[k] as f64));
    std::array::from_fn(|i| DVec3::from(to64(pose.cols[i])).dot(d))
}

/// The point at fraction `s` from `a` to `b`.
fn lerp64(a: DVec3, b: DVec3, s: f64) -> DVec3 {
    a + (b - a) * s
}

/// Distance between two triangles in `f64` (0 when they touch or cross),
/// by vertex projections, clamped segment parameters and edge piercings.
pub fn tri_tri_distance64(s: &[D3; 3], t: &[D3; 3]) -> f64 {
    let (s, t) = (&s.map(DVec3::from), &t.map(DVec3::from));
    let mut best = f64::INFINITY;
    for (x, y) in [(s, t), (t, s)] {
        for i in 0..3 {
            // Vertex over the other face.
            if let Some(d) = face_distance(x[i], y) {
                best = best.min(d);
            }
            // Edge piercing the other face.
            if let Some(d) = piercing(x[i], x[(i + 1) % 3], y) {
                best = best.min(d);
            }
        }
    }
    for i in 0..3 {
        for j in 0..3 {
            best = best.min(segment_distance(s[i], s[(i + 1) % 3], t[j], t[(j + 1) % 3]));
        }
    }
    best
}

/// Distance from `p` to the plane of `t` when its projection lies inside
/// `t` (barycentric signs), else `None` (an edge is then closer).
fn face_distance(p: DVec3, t: &[DVec3; 3]) -> Option<f64> {
    let n = (t[1] - t[0]).cross(t[2] - t[0]);
    let nn = n.dot(n);
    if nn == 0.0 {
        return None;
    }
    let inside = (0..3).all(|k| {
        let e = (t[(k + 1) % 3] - t[k]).cross(p - t[k]);
        e.dot(n) >= 0.0
    });
    inside.then(|| n.dot(p - t[0]).abs() / nn.sqrt())
}

/// 0 when segment `(a, b)` strictly crosses the plane of `t` at a point
/// inside `t`, else `None`.
fn piercing(a: DVec3, b: DVec3, t: &[DVec3; 3]) -> Option<f64> {
    let n = (t[1] - t[0]).cross(t[2] - t[0]);
    let sa = n.dot(a - t[0]);
    let sb = n.dot(b - t[0]);
    if !((sa > 0.0 && sb < 0.0) || (sa < 0.0 && sb > 0.0)) {
        return None;
    }
    face_distance(lerp64(a, b, sa / (sa - sb)), t)
}

/// Distance between segments `(p0, p1)` and `(q0, q1)`: the interior
/// critical point of `|p(s) − q(t)|²` when it lies in the unit square, and
/// the four boundary minima (each endpoint against the other segment, its
/// parameter clamped).
pub fn segment_distance64(p0: D3, p1: D3, q0: D3, q1: D3) -> f64 {
    segment_distance(p0.into(), p1.into(), q0.into(), q1.into())
}

/// [`segment_distance64`] of glam vectors.
fn segment_distance(p0: DVec3, p1: DVec3, q0: DVec3, q1: DVec3) -> f64 {
    let (u, v, w) = (p1 - p0, q1 - q0, p0 - q0);
    let (a, b, c) = (u.dot(u), u.dot(v), v.dot(v));
    let (d, e) = (u.dot(w), v.dot(w));
    let mut best = point_segment_distance(p0, q0, q1)
        .min(point_segment_distance(p1, q0, q1))
        .min(point_segment_distance(q0, p0, p1))
        .min(point_segment_distance(q1, p0, p1));
    let det = a * c - b * b;
    if det > 1e-12 * a * c {
        let s = (b * e - c * d) / det;
        let t = (a * e - b * d) / det;
        if (0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&t) {
            best = best.min(lerp64(p0, p1, s).distance(lerp64(q0, q1, t)));
        }
    }
    best
}

/// Distance from `p` to the nearest triangle of `mesh` in `f64`, by a
/// plain loop over them all.
pub fn mesh_distance64(mesh: &Mesh, p: D3) -> f64 {
    (0..mesh.triangles.len())
        .map(|i| {
            let [a, b, c] = mesh.corners(i).map(to64);
            point_triangle_distance(p, a, b, c)
        })
        .fold(f64::INFINITY, f64::min)
}

/// Generalised winding number of a closed mesh at `p` (≈1 inside, ≈0
/// outside), by summing the signed solid angles of its triangles (Van
/// Oosterom & Strackee).
pub fn winding_number(mesh: &Mesh, p: V3) -> f64 {
    let p = DVec3::from(to64(p));
    let mut total = 0.0;
    for i in 0..mesh.triangles.len() {
        let [a, b, c] = mesh.corners(i).map(|v| DVec3::from(to64(v)) - p);
        let (la, lb, lc) = (a.length(), b.length(), c.length());
        let det = a.dot(b.cross(c));
        let den = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
        total += 2.0 * det.atan2(den);
    }
    total / (4.0 * std::f64::consts::PI)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::tri_tri_distance::tri_tri_distance;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The two independent formulations (this f64 one and the backends'
    /// f32 one) agree on random pairs, crossing ones included.
    #[test]
    fn f64_distance_matches_the_f32_one() {
        let mut r = ChaCha8Rng::seed_from_u64(5);
        for i in 0..2000 {
            let tri = |r: &mut ChaCha8Rng, c: f32, s: f32| -> [V3; 3] {
                std::array::from_fn(|_| std::array::from_fn(|_| c + r.random_range(-s..s)))
            };
            let s = tri(&mut r, 0.0, 1.0);
            let (c, size) = (r.random_range(0.0..2.0), r.random_range(0.1..1.5));
            let t = tri(&mut r, c, size);
            let want = tri_tri_distance(s[0], s[1], s[2], t[0], t[1], t[2]) as f64;
            let got = tri_tri_distance64(&s.map(to64), &t.map(to64));
            assert!(
                (got - want).abs() < 1e-5,
                "pair {i}: f64 {got} vs f32 {want}: {s:?} {t:?}"
            );
        }
    }

    #[test]
    fn segments_parallel_and_skew() {
        let d = segment_distance64([0.0; 3], [2.0, 0.0, 0.0], [1.0, 0.5, 0.0], [3.0, 0.5, 0.0]);
        assert!((d - 0.5).abs() < 1e-12);
        let d = segment_distance64([0.0; 3], [2.0, 0.0, 0.0], [1.0, -1.0, 1.0], [1.0, 1.0, 1.0]);
        assert!((d - 1.0).abs() < 1e-12);
    }
}

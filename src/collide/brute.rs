//! Brute force, the ground truth for tests: every existing part triangle
//! against every head triangle with Möller's test, and containment by the
//! generalised winding number in `f64` (an algorithm independent of the
//! backends' ray parity). Quadratic; only for small scenes.

use super::{check_finite, Backend, CollideError, Query};
use crate::geometry::tri_tri::tri_tri_overlap;
use crate::geometry::{Aabb, Mesh, V3};
use crate::scene::Scene;
use rayon::prelude::*;

/// The brute-force evaluator.
pub struct BruteBackend<'a> {
    scene: &'a Scene,
}

impl<'a> BruteBackend<'a> {
    /// Over `scene`.
    pub fn new(scene: &'a Scene) -> Self {
        BruteBackend { scene }
    }

    fn hits(&self, q: &Query) -> bool {
        let head = &self.scene.head.mesh;
        let hb = Aabb::from_points(&head.vertices);
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
                // Exact pruning only: a triangle whose box misses the head's
                // box (grown by the tolerance) can neither cross nor be inside.
                let tb = Aabb::from_points(&[a, b, c]);
                let grown = Aabb {
                    min: hb.min.map(|x| x - 2.0 * tol),
                    max: hb.max.map(|x| x + 2.0 * tol),
                };
                if !tb.overlaps(&grown) {
                    return false;
                }
                (0..head.triangles.len()).any(|i| {
                    let [h0, h1, h2] = head.corners(i);
                    tri_tri_overlap(a, b, c, h0, h1, h2, tol)
                }) || winding_number(head, a) > 0.5
            })
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

/// Generalised winding number of a closed mesh at `p` (≈1 inside, ≈0
/// outside), by summing the signed solid angles of its triangles (Van
/// Oosterom & Strackee).
pub fn winding_number(mesh: &Mesh, p: V3) -> f64 {
    let p = p.map(|c| c as f64);
    let mut total = 0.0;
    for i in 0..mesh.triangles.len() {
        let [a, b, c] = mesh
            .corners(i)
            .map(|v| [v[0] as f64 - p[0], v[1] as f64 - p[1], v[2] as f64 - p[2]]);
        let la = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
        let lb = (b[0] * b[0] + b[1] * b[1] + b[2] * b[2]).sqrt();
        let lc = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
        let det = a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
            + a[2] * (b[0] * c[1] - b[1] * c[0]);
        let dot = |u: [f64; 3], v: [f64; 3]| u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
        let den = la * lb * lc + dot(a, b) * lc + dot(b, c) * la + dot(c, a) * lb;
        total += 2.0 * det.atan2(den);
    }
    total / (4.0 * std::f64::consts::PI)
}

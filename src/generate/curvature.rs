//! Local surface geometry at every vertex of a triangle mesh: a unit normal
//! and the quadric `z = a·u² + b·uv + c·v² + d·u + e·v` fitted by least
//! squares to the vertex's two-ring in its tangent frame `(e1, e2, n)`.
//!
//! The normal starts as the area-weighted mean of the triangle normals (the
//! mesh's winding decides which side is "up") and is refitted twice so the
//! quadric's slope at the vertex is ~0; then `2(a t₁² + b t₁t₂ + c t₂²)` is
//! the normal curvature along the tangent `t`. The quadric space is
//! invariant under in-plane rotations and mirrors, so the result does not
//! depend on how `e1` is picked: a mirror-symmetric mesh gives
//! mirror-symmetric curvatures.

use crate::geometry::Mesh;
use glam::DVec3;

/// The local geometry at one vertex.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalFrame {
    /// Vertex position (mm).
    pub origin: DVec3,
    /// Unit surface normal.
    pub normal: DVec3,
    /// First tangent axis.
    pub e1: DVec3,
    /// Second tangent axis, `normal × e1`.
    pub e2: DVec3,
    /// The fitted quadric's coefficients `[a, b, c, d, e]` (height along
    /// the normal over the tangent axes).
    pub quad: [f64; 5],
}

/// `v` scaled to unit length by dividing by its length (glam's
/// `normalize` multiplies by the reciprocal, which can round differently
/// and would move the generated waypoints); a zero vector stays zero.
pub(crate) fn unit(v: DVec3) -> DVec3 {
    let l = v.length();
    if l > 0.0 {
        v / l
    } else {
        v
    }
}

impl LocalFrame {
    /// Normal curvature along the unit tangent `t` (world frame): positive
    /// where the surface bends away from its normal (convex, like the top
    /// of a dome whose normal points up).
    pub fn convex_curvature(&self, t: DVec3) -> f64 {
        let (x, y) = (t.dot(self.e1), t.dot(self.e2));
        let [a, b, c, ..] = self.quad;
        -2.0 * (a * x * x + b * x * y + c * y * y) / (x * x + y * y).max(1e-300)
    }

    /// The fitted surface's unit normal at the tangent offset `t` (world
    /// frame, mm) from the vertex.
    pub fn normal_at(&self, t: DVec3) -> DVec3 {
        let (x, y) = (t.dot(self.e1), t.dot(self.e2));
        let [a, b, c, d, e] = self.quad;
        let (gx, gy) = (2.0 * a * x + b * y + d, b * x + 2.0 * c * y + e);
        unit(self.normal - self.e1 * gx - self.e2 * gy)
    }
}

/// A mesh vertex in f64.
fn vertex(mesh: &Mesh, i: u32) -> DVec3 {
    DVec3::from(mesh.vertices[i as usize].map(f64::from))
}

/// Area-weighted vertex normals (zero for unused vertices).
pub fn vertex_normals(mesh: &Mesh) -> Vec<DVec3> {
    let mut n = vec![DVec3::ZERO; mesh.vertices.len()];
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| vertex(mesh, i));
        let f = (b - a).cross(c - a);
        for &v in t {
            n[v as usize] += f;
        }
    }
    n.into_iter().map(unit).collect()
}

/// Tangent axes `(e1, e2)` for a unit normal `n`, `e1 × e2 = n`: `e1` is x
/// (or y, where `n` is nearly along x) with its part along `n` removed.
pub fn tangent_axes(n: DVec3) -> (DVec3, DVec3) {
    let e = if n.x.abs() > 0.9 { DVec3::Y } else { DVec3::X };
    let e1 = unit(e - n * e.dot(n));
    (e1, n.cross(e1))
}

/// Solve the small dense system `m x = r` by Gaussian elimination with
/// partial pivoting; `None` when singular.
#[allow(clippy::needless_range_loop)]
fn solve<const N: usize>(mut m: [[f64; N]; N], mut r: [f64; N]) -> Option<[f64; N]> {
    let scale = m.iter().flatten().fold(0.0f64, |s, x| s.max(x.abs()));
    for col in 0..N {
        let piv = (col..N).max_by(|&a, &b| m[a][col].abs().total_cmp(&m[b][col].abs()))?;
        if m[piv][col].abs() <= 1e-12 * scale {
            return None;
        }
        m.swap(col, piv);
        r.swap(col, piv);
        for row in col + 1..N {
            let f = m[row][col] / m[col][col];
            for k in col..N {
                m[row][k] -= f * m[col][k];
            }
            r[row] -= f * r[col];
        }
    }
    let mut x = [0.0; N];
    for row in (0..N).rev() {
        let s: f64 = (row + 1..N).map(|k| m[row][k] * x[k]).sum();
        x[row] = (r[row] - s) / m[row][row];
    }
    Some(x)
}

/// Least-squares quadric through `pts` (offsets from the vertex) in the
/// frame `(e1, e2, n)`; a pure quadratic when the full fit is singular,
/// flat when that is too.
fn fit_quadric(pts: &[DVec3], e1: DVec3, e2: DVec3, n: DVec3) -> [f64; 5] {
    let mut m5 = [[0.0; 5]; 5];
    let mut r5 = [0.0; 5];
    let mut m3 = [[0.0; 3]; 3];
    let mut r3 = [0.0; 3];
    for p in pts {
        let (x, y, z) = (p.dot(e1), p.dot(e2), p.dot(n));
        let row = [x * x, x * y, y * y, x, y];
        for i in 0..5 {
            for j in 0..5 {
                m5[i][j] += row[i] * row[j];
            }
            r5[i] += row[i] * z;
        }
        for i in 0..3 {
            for j in 0..3 {
                m3[i][j] += row[i] * row[j];
            }
            r3[i] += row[i] * z;
        }
    }
    if let Some(q) = solve(m5, r5) {
        return q;
    }
    match solve(m3, r3) {
        Some([a, b, c]) => [a, b, c, 0.0, 0.0],
        None => [0.0; 5],
    }
}

/// The local frame and quadric of every vertex (a welded, manifold mesh).
pub fn local_frames(mesh: &Mesh) -> Vec<LocalFrame> {
    let nv = mesh.vertices.len();
    let mut ring1: Vec<Vec<u32>> = vec![Vec::new(); nv];
    for t in &mesh.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            ring1[a as usize].push(b);
            ring1[b as usize].push(a);
        }
    }
    for r in &mut ring1 {
        r.sort_unstable();
        r.dedup();
    }
    let normals = vertex_normals(mesh);
    (0..nv)
        .map(|v| {
            let o = vertex(mesh, v as u32);
            let mut ring: Vec<u32> = ring1[v]
                .iter()
                .flat_map(|&w| ring1[w as usize].iter().copied().chain([w]))
                .filter(|&w| w as usize != v)
                .collect();
            ring.sort_unstable();
            ring.dedup();
            let pts: Vec<DVec3> = ring.iter().map(|&w| vertex(mesh, w) - o).collect();
            let mut n = normals[v];
            let mut frame = None;
            for _ in 0..3 {
                let (e1, e2) = tangent_axes(n);
                let quad = fit_quadric(&pts, e1, e2, n);
                let f = LocalFrame {
                    origin: o,
                    normal: n,
                    e1,
                    e2,
                    quad,
                };
                n = f.normal_at(DVec3::ZERO);
                frame = Some(f);
            }
            let f = frame.expect("three iterations ran");
            // The last refit's normal, with the quadric of that frame.
            let (e1, e2) = tangent_axes(f.normal);
            LocalFrame { e1, e2, ..f }.refit(&pts)
        })
        .collect()
}

impl LocalFrame {
    fn refit(self, pts: &[DVec3]) -> LocalFrame {
        LocalFrame {
            quad: fit_quadric(pts, self.e1, self.e2, self.normal),
            ..self
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::default_job::height_field as grid;

    #[test]
    fn sphere_cap_and_saddle_curvatures() {
        let r = 20.0f32;
        let cap = grid(20, 5.0, |x, y| (r * r - x * x - y * y).sqrt());
        let frames = local_frames(&cap);
        let centre = frames
            .iter()
            .find(|f| f.origin[0].abs() < 1e-9 && f.origin[1].abs() < 1e-9)
            .unwrap();
        assert!((centre.normal[2] - 1.0).abs() < 1e-9);
        let k = centre.convex_curvature(DVec3::X);
        assert!((k - 0.05).abs() < 1e-3, "{k}");
        let saddle = grid(20, 5.0, |x, y| (x * x - y * y) / (2.0 * r));
        let f = local_frames(&saddle);
        let c = f
            .iter()
            .find(|f| f.origin[0].abs() < 1e-9 && f.origin[1].abs() < 1e-9)
            .unwrap();
        let (kx, ky) = (c.convex_curvature(DVec3::X), c.convex_curvature(DVec3::Y));
        assert!(
            (kx + 0.05).abs() < 1e-3 && (ky - 0.05).abs() < 1e-3,
            "{kx} {ky}"
        );
        let tilted = c.normal_at(DVec3::X);
        assert!((tilted[0] + 0.05).abs() < 2e-3, "{tilted:?}");
    }
}

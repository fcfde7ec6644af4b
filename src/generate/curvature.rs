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

/// The local geometry at one vertex.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LocalFrame {
    /// Vertex position (mm).
    pub origin: [f64; 3],
    /// Unit surface normal.
    pub normal: [f64; 3],
    /// First tangent axis.
    pub e1: [f64; 3],
    /// Second tangent axis, `normal × e1`.
    pub e2: [f64; 3],
    /// The fitted quadric's coefficients `[a, b, c, d, e]` (height along
    /// the normal over the tangent axes).
    pub quad: [f64; 5],
}

pub(crate) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub(crate) fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

pub(crate) fn normalised(a: [f64; 3]) -> [f64; 3] {
    let l = dot(a, a).sqrt();
    if l > 0.0 {
        a.map(|x| x / l)
    } else {
        a
    }
}

impl LocalFrame {
    /// Normal curvature along the unit tangent `t` (world frame): positive
    /// where the surface bends away from its normal (convex, like the top
    /// of a dome whose normal points up).
    pub fn convex_curvature(&self, t: [f64; 3]) -> f64 {
        let (x, y) = (dot(t, self.e1), dot(t, self.e2));
        let [a, b, c, ..] = self.quad;
        -2.0 * (a * x * x + b * x * y + c * y * y) / (x * x + y * y).max(1e-300)
    }

    /// The fitted surface's unit normal at the tangent offset `t` (world
    /// frame, mm) from the vertex.
    pub fn normal_at(&self, t: [f64; 3]) -> [f64; 3] {
        let (x, y) = (dot(t, self.e1), dot(t, self.e2));
        let [a, b, c, d, e] = self.quad;
        let (gx, gy) = (2.0 * a * x + b * y + d, b * x + 2.0 * c * y + e);
        normalised([0, 1, 2].map(|k| self.normal[k] - gx * self.e1[k] - gy * self.e2[k]))
    }
}

/// Area-weighted vertex normals (zero for unused vertices).
pub fn vertex_normals(mesh: &Mesh) -> Vec<[f64; 3]> {
    let mut n = vec![[0.0f64; 3]; mesh.vertices.len()];
    let p = |i: u32| mesh.vertices[i as usize].map(|x| x as f64);
    for t in &mesh.triangles {
        let (a, b, c) = (p(t[0]), p(t[1]), p(t[2]));
        let f = cross(
            [0, 1, 2].map(|k| b[k] - a[k]),
            [0, 1, 2].map(|k| c[k] - a[k]),
        );
        for &v in t {
            for k in 0..3 {
                n[v as usize][k] += f[k];
            }
        }
    }
    n.into_iter().map(normalised).collect()
}

/// Tangent axes for a unit normal.
fn tangents(n: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    let e = if n[0].abs() > 0.9 {
        [0.0, 1.0, 0.0]
    } else {
        [1.0, 0.0, 0.0]
    };
    let en = dot(e, n);
    let e1 = normalised([0, 1, 2].map(|k| e[k] - en * n[k]));
    (e1, cross(n, e1))
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
fn fit_quadric(pts: &[[f64; 3]], e1: [f64; 3], e2: [f64; 3], n: [f64; 3]) -> [f64; 5] {
    let mut m5 = [[0.0; 5]; 5];
    let mut r5 = [0.0; 5];
    let mut m3 = [[0.0; 3]; 3];
    let mut r3 = [0.0; 3];
    for p in pts {
        let (x, y, z) = (dot(*p, e1), dot(*p, e2), dot(*p, n));
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
    let pos = |i: usize| mesh.vertices[i].map(|x| x as f64);
    (0..nv)
        .map(|v| {
            let o = pos(v);
            let mut ring: Vec<u32> = ring1[v]
                .iter()
                .flat_map(|&w| ring1[w as usize].iter().copied().chain([w]))
                .filter(|&w| w as usize != v)
                .collect();
            ring.sort_unstable();
            ring.dedup();
            let pts: Vec<[f64; 3]> = ring
                .iter()
                .map(|&w| {
                    let p = pos(w as usize);
                    [0, 1, 2].map(|k| p[k] - o[k])
                })
                .collect();
            let mut n = normals[v];
            let mut frame = None;
            for _ in 0..3 {
                let (e1, e2) = tangents(n);
                let quad = fit_quadric(&pts, e1, e2, n);
                let f = LocalFrame {
                    origin: o,
                    normal: n,
                    e1,
                    e2,
                    quad,
                };
                n = f.normal_at([0.0; 3]);
                frame = Some(f);
            }
            let f = frame.expect("three iterations ran");
            // The last refit's normal, with the quadric of that frame.
            let (e1, e2) = tangents(f.normal);
            LocalFrame { e1, e2, ..f }.refit(&pts)
        })
        .collect()
}

impl LocalFrame {
    fn refit(self, pts: &[[f64; 3]]) -> LocalFrame {
        LocalFrame {
            quad: fit_quadric(pts, self.e1, self.e2, self.normal),
            ..self
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A grid over [-a, a]² with a centre vertex per cell (4 triangles per
    /// cell: symmetric under both mirrors), heights from `f`.
    pub(crate) fn grid(n: usize, a: f32, f: impl Fn(f32, f32) -> f32) -> Mesh {
        let mut m = Mesh::default();
        let h = 2.0 * a / n as f32;
        for j in 0..=n {
            for i in 0..=n {
                let (x, y) = (-a + i as f32 * h, -a + j as f32 * h);
                m.vertices.push([x, y, f(x, y)]);
            }
        }
        let at = |i: usize, j: usize| (j * (n + 1) + i) as u32;
        for j in 0..n {
            for i in 0..n {
                let (x, y) = (-a + (i as f32 + 0.5) * h, -a + (j as f32 + 0.5) * h);
                let c = m.vertices.len() as u32;
                m.vertices.push([x, y, f(x, y)]);
                let (p00, p10, p11, p01) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
                m.triangles.push([p00, p10, c]);
                m.triangles.push([p10, p11, c]);
                m.triangles.push([p11, p01, c]);
                m.triangles.push([p01, p00, c]);
            }
        }
        m
    }

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
        let k = centre.convex_curvature([1.0, 0.0, 0.0]);
        assert!((k - 0.05).abs() < 1e-3, "{k}");
        let saddle = grid(20, 5.0, |x, y| (x * x - y * y) / (2.0 * r));
        let f = local_frames(&saddle);
        let c = f
            .iter()
            .find(|f| f.origin[0].abs() < 1e-9 && f.origin[1].abs() < 1e-9)
            .unwrap();
        let (kx, ky) = (
            c.convex_curvature([1.0, 0.0, 0.0]),
            c.convex_curvature([0.0, 1.0, 0.0]),
        );
        assert!(
            (kx + 0.05).abs() < 1e-3 && (ky - 0.05).abs() < 1e-3,
            "{kx} {ky}"
        );
        let tilted = c.normal_at([1.0, 0.0, 0.0]);
        assert!((tilted[0] + 0.05).abs() < 2e-3, "{tilted:?}");
    }
}

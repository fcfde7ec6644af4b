//! Is a point inside a closed triangle mesh? Ray parity along a fixed,
//! generic direction, with exact tie-breaking so that a ray through a shared
//! edge or vertex is counted exactly once.
//!
//! The mesh is stored in "ray space": an orthonormal frame whose third axis
//! is the ray direction, so the ray is `(px, py, t > pz)`. A triangle is hit
//! when the three 2-D edge functions `e(a, b) = (a - p) × (b - p)` share a
//! sign. When an edge function is exactly zero its sign is taken from the
//! point perturbed by `(ε, ε²)` (simulation of simplicity): `e` is linear in
//! `p`, so the perturbed sign is `sign(a.y - b.y)`, then `sign(b.x - a.x)`.
//! Each edge is evaluated from its lexicographically smaller vertex, so the
//! two triangles sharing it compute the identical expression and always
//! get opposite signs, however the compiler fuses multiply-adds (lavapipe
//! showed that the plain form is not safe on a GPU). A triangle parallel to the ray is never counted, which is right for
//! parity. `shaders/shared/point_in_mesh.wgsl` mirrors this file.

use super::V3;
use glam::DVec3;

/// The fixed ray direction, chosen to avoid the axis-aligned and 45° features
/// that CAD heads are full of (ties are handled, but rarer is faster).
pub const RAY_DIR: V3 = [0.285_190_6, 0.186_472_3, 0.940_155_6];

/// An orthonormal frame `(a, b, d)` with `d = RAY_DIR`.
pub fn ray_frame() -> [V3; 3] {
    let d = DVec3::from(RAY_DIR.map(|x| x as f64));
    let d = d / d.length();
    // a = normalize(x × d) style construction, in f64 then rounded.
    let a = DVec3::X.cross(d);
    let a = a / a.length();
    let b = d.cross(a);
    [a, b, d].map(|v| v.as_vec3().to_array())
}

/// `p` expressed in the ray frame (`frame` from [`ray_frame`]).
#[inline(always)]
pub fn to_ray_space(frame: &[V3; 3], p: V3) -> V3 {
    [
        frame[0][0] * p[0] + frame[0][1] * p[1] + frame[0][2] * p[2],
        frame[1][0] * p[0] + frame[1][1] * p[1] + frame[1][2] * p[2],
        frame[2][0] * p[0] + frame[2][1] * p[1] + frame[2][2] * p[2],
    ]
}

/// Lexicographic order of vertices, used to evaluate every edge in one
/// canonical direction.
#[inline(always)]
fn less(a: V3, b: V3) -> bool {
    a[0] < b[0] || (a[0] == b[0] && (a[1] < b[1] || (a[1] == b[1] && a[2] < b[2])))
}

/// Sign of the edge function of `a → b` seen from `p`, with the
/// simulation-of-simplicity tie-break. `true` for positive.
#[inline(always)]
fn edge_positive_ordered(a: V3, b: V3, p: V3) -> bool {
    let e = (a[0] - p[0]) * (b[1] - p[1]) - (a[1] - p[1]) * (b[0] - p[0]);
    if e != 0.0 {
        return e > 0.0;
    }
    let s = a[1] - b[1];
    if s != 0.0 {
        return s > 0.0;
    }
    b[0] - a[0] > 0.0
}

/// Edge sign of `a → b`, always computed from the lexicographically smaller
/// vertex: the two triangles sharing an edge then evaluate the very same
/// expression and get exactly opposite signs, even where a compiler (a GPU
/// driver) fuses the multiply-adds differently.
#[inline(always)]
fn edge_positive(a: V3, b: V3, p: V3) -> bool {
    if less(b, a) {
        !edge_positive_ordered(b, a, p)
    } else {
        edge_positive_ordered(a, b, p)
    }
}

/// Does the ray from `p` (ray space) cross triangle `(a, b, c)` (ray space)
/// strictly above `p`?
#[inline(always)]
pub fn ray_crosses(a: V3, b: V3, c: V3, p: V3) -> bool {
    let s0 = edge_positive(a, b, p);
    let s1 = edge_positive(b, c, p);
    let s2 = edge_positive(c, a, p);
    if s0 != s1 || s1 != s2 {
        return false;
    }
    // Barycentric height of the hit; weights are the raw edge functions.
    let w_c = (a[0] - p[0]) * (b[1] - p[1]) - (a[1] - p[1]) * (b[0] - p[0]);
    let w_a = (b[0] - p[0]) * (c[1] - p[1]) - (b[1] - p[1]) * (c[0] - p[0]);
    let w_b = (c[0] - p[0]) * (a[1] - p[1]) - (c[1] - p[1]) * (a[0] - p[0]);
    let sum = w_a + w_b + w_c;
    if sum == 0.0 {
        return false; // Parallel to the ray: never counted.
    }
    let num = w_a * (a[2] - p[2]) + w_b * (b[2] - p[2]) + w_c * (c[2] - p[2]);
    if sum > 0.0 {
        num > 0.0
    } else {
        num < 0.0
    }
}

/// Brute-force parity over all triangles (ray-space vertices and indices).
pub fn contains_brute(verts_ray: &[V3], tris: &[[u32; 3]], p_ray: V3) -> bool {
    let mut inside = false;
    for t in tris {
        let (a, b, c) = (
            verts_ray[t[0] as usize],
            verts_ray[t[1] as usize],
            verts_ray[t[2] as usize],
        );
        if ray_crosses(a, b, c, p_ray) {
            inside = !inside;
        }
    }
    inside
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit cube as 12 triangles, outward-facing.
    fn cube() -> (Vec<V3>, Vec<[u32; 3]>) {
        let m = crate::default_job::box_mesh([0.0; 3], [1.0; 3]);
        (m.vertices, m.triangles)
    }

    #[test]
    fn cube_inside_outside_and_ties() {
        let (v, t) = cube();
        let f = ray_frame();
        let vr: Vec<V3> = v.iter().map(|p| to_ray_space(&f, *p)).collect();
        let inside = |p: V3| contains_brute(&vr, &t, to_ray_space(&f, p));
        assert!(inside([0.5, 0.5, 0.5]));
        assert!(inside([0.1, 0.9, 0.2]));
        assert!(!inside([1.5, 0.5, 0.5]));
        assert!(!inside([-0.5, -0.5, -0.5]));
        // Points whose ray passes along the cube's diagonal edges and corners.
        for k in 0..200 {
            let s = k as f32 / 200.0;
            let p = [s, s, s];
            assert!(inside(p) || s == 0.0, "diagonal point {s}");
        }
    }

    #[test]
    fn frame_is_orthonormal() {
        let f = ray_frame();
        for i in 0..3 {
            for j in 0..3 {
                let d: f32 = (0..3).map(|k| f[i][k] * f[j][k]).sum();
                let want = if i == j { 1.0 } else { 0.0 };
                assert!((d - want).abs() < 1e-6);
            }
        }
    }
}

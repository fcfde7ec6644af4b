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

/// [`contains_brute`]'s answer from only the triangles whose shadow
/// (their box in the ray frame's `x, y`) covers the point's: the
/// triangles are binned by shadow once, and a point's ray can only cross
/// those of its bin. For the many points a head build asks.
pub struct RayParity<'a> {
    verts_ray: &'a [V3],
    tris: &'a [[u32; 3]],
    /// The bins' corner, size and counts along `x` and `y`.
    origin: [f32; 2],
    bin: f32,
    dims: [usize; 2],
    /// `first[k]..first[k + 1]`: bin `k`'s triangles in `members`.
    first: Vec<u32>,
    members: Vec<u32>,
}

/// Bins along the longer side of the mesh's shadow.
const PARITY_BINS: f32 = 64.0;

impl<'a> RayParity<'a> {
    /// The bins for the mesh `tris` over `verts_ray` (ray space).
    pub fn new(verts_ray: &'a [V3], tris: &'a [[u32; 3]]) -> Self {
        let (mut lo, mut hi) = ([f32::MAX; 2], [f32::MIN; 2]);
        for v in verts_ray {
            for k in 0..2 {
                lo[k] = lo[k].min(v[k]);
                hi[k] = hi[k].max(v[k]);
            }
        }
        let side = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(f32::MIN_POSITIVE);
        let bin = side / PARITY_BINS;
        let dims = [0, 1].map(|k| (((hi[k] - lo[k]) / bin) as usize + 1).max(1));
        let mut parity = RayParity {
            verts_ray,
            tris,
            origin: lo,
            bin,
            dims,
            first: Vec::new(),
            members: Vec::new(),
        };
        // A shadow is grown by a bin's thousandth, so that rounding at its
        // edge never leaves out a triangle the ray may cross.
        let grow = 1e-3 * bin;
        let spans: Vec<[[usize; 2]; 2]> = tris
            .iter()
            .map(|t| {
                let c = t.map(|i| verts_ray[i as usize]);
                std::array::from_fn(|k| {
                    let lo = c[0][k].min(c[1][k]).min(c[2][k]) - grow;
                    let hi = c[0][k].max(c[1][k]).max(c[2][k]) + grow;
                    [parity.cell(lo, k), parity.cell(hi, k)]
                })
            })
            .collect();
        let mut bins: Vec<Vec<u32>> = vec![Vec::new(); dims[0] * dims[1]];
        for (t, [x, y]) in spans.iter().enumerate() {
            for j in y[0]..=y[1] {
                for i in x[0]..=x[1] {
                    bins[j * dims[0] + i].push(t as u32);
                }
            }
        }
        parity.first.push(0);
        for bin in bins {
            parity.members.extend(bin);
            parity.first.push(parity.members.len() as u32);
        }
        parity
    }

    /// The bin holding coordinate `x` along axis `k` (clamped to the bins).
    fn cell(&self, x: f32, k: usize) -> usize {
        let i = ((x - self.origin[k]) / self.bin).floor();
        i.clamp(0.0, (self.dims[k] - 1) as f32) as usize
    }

    /// Is `p_ray` (ray space) inside the mesh? The same answer as
    /// [`contains_brute`].
    pub fn contains(&self, p_ray: V3) -> bool {
        let k = self.cell(p_ray[1], 1) * self.dims[0] + self.cell(p_ray[0], 0);
        let mut inside = false;
        for &t in &self.members[self.first[k] as usize..self.first[k + 1] as usize] {
            let [a, b, c] = self.tris[t as usize].map(|i| self.verts_ray[i as usize]);
            if ray_crosses(a, b, c, p_ray) {
                inside = !inside;
            }
        }
        inside
    }
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

    /// The binned parity answers as the brute force does, at random
    /// points around and inside a non-convex head and at its vertices
    /// (rays through edges and corners).
    #[test]
    fn binned_parity_is_the_brute_forces() {
        let radii: Vec<f32> = (0..48).map(|j| [20.0, 14.0, 18.0][j % 3]).collect();
        let mesh = crate::default_job::star_head(&radii, 20.0, 30.0, [1.5, -2.0]);
        let f = ray_frame();
        let vr: Vec<V3> = mesh.vertices.iter().map(|p| to_ray_space(&f, *p)).collect();
        let parity = RayParity::new(&vr, &mesh.triangles);
        let (lo, hi) = ([-20.0, -22.0, 0.0], [22.0, 18.0, 30.0]);
        let mut uniform = crate::geometry::xorshift(0x9a41_7e55_0c3d_2b11);
        let mut points: Vec<V3> = (0..20_000)
            .map(|_| {
                std::array::from_fn(|k| {
                    let t = 1.2 * uniform() as f32 - 0.1;
                    lo[k] + t * (hi[k] - lo[k])
                })
            })
            .collect();
        points.extend(mesh.vertices.iter().copied());
        let mut inside = 0;
        for p in points {
            let p = to_ray_space(&f, p);
            let want = contains_brute(&vr, &mesh.triangles, p);
            assert_eq!(parity.contains(p), want, "at {p:?}");
            inside += want as usize;
        }
        assert!(inside > 1000, "{inside} points inside");
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

//! Hull planes: a third bound, for material beside the head's flank.
//!
//! The distance grid bounds a triangle by its bounding sphere: a part
//! triangle 1.4 mm across, 0.7 mm from the flank of a tilted head, has a
//! sphere that reaches into the head, so it would go to the exact tests
//! (each a walk of the head BVH and several triangle–triangle distances),
//! and beside a tilted head there are many such triangles. A plane
//! settles it with three dot products: for any unit `n`, every point `x`
//! lies at least `n · x − h(n)` from the head's convex hull, `h(n) =
//! max_v n · v` over the head's vertices, and so at least that far from
//! the head (which the hull contains). A triangle is as far as its
//! nearest corner, because `n · x` is linear.
//!
//! The bound is tightest for `n` pointing from the hull's nearest point
//! towards `x`, so the table keeps, per cell of a grid [`COARSE`] times
//! coarser than the distance grid (same origin and reach), the plane
//! facing that cell's centre: `n` from the head surface's nearest point
//! to the centre, and `h(n)` exact over every head vertex, rounded up.
//! Any `n` gives a valid bound, so a triangle uses the plane of the cell
//! holding its centroid however far it reaches from that centre, and a
//! cell whose centre lies inside the head takes the tangent plane of its
//! nearest surface point (such cells straddle the surface: material in
//! them lies just outside). On a convex head (the data set's cone) the bound is
//! the exact distance at the cell's centre and off by the surface's
//! curvature elsewhere; on a non-convex head it is the hull's distance,
//! weaker in the head's recesses, never wrong.
//!
//! Stored in the grid buffer after the support map
//! ([`super::GpuHeadParams::plane_offset`]), four floats per cell:
//! `n.x, n.y, n.z, h` (no plane: `0, 0, 0, NO_PLANE`).

use super::nearest::{nearest_on, HeadBvh};
use glam::DVec3;
use rayon::prelude::*;

/// Distance-grid cells per plane cell along each axis. Coarser cells
/// cost less to build and to cache; finer ones fit a curved head better
/// and leave fewer exact tests. Every 2 cells saved no time over every 4;
/// every 8 left enough exact tests to cost more.
pub const COARSE: u32 = 4;

/// `h` of a cell without a plane: no triangle is ever this far beyond it.
pub const NO_PLANE: f32 = 1.0e30;

/// The plane table's grid: its corner, cell size and cell counts, for a
/// distance grid with corner `origin`, cell `cell` and `dims` cells.
pub fn plane_grid(origin: [f32; 3], cell: f32, dims: [u32; 3]) -> ([f32; 3], f32, [u32; 3]) {
    (
        origin,
        cell * COARSE as f32,
        dims.map(|d| d.div_ceil(COARSE)),
    )
}

/// The table (four floats per cell, x fastest) for the head under its
/// BVH `bvh`, with `vertices` its vertices and `inside` telling whether a
/// point lies inside it (a guess is enough: it only steers the normal):
/// per cell, the supporting plane of the hull facing the cell's centre,
/// the centre computed in f32 as the evaluators compute cell positions.
pub fn hull_planes(
    bvh: HeadBvh,
    vertices: &[[f32; 3]],
    (origin, cell, dims): ([f32; 3], f32, [u32; 3]),
    inside: impl Fn([f32; 3]) -> bool + Sync,
) -> Vec<f32> {
    let [nx, ny, nz] = dims.map(|d| d as usize);
    let verts: Vec<[f64; 3]> = vertices.iter().map(|v| v.map(|x| x as f64)).collect();
    (0..nx * ny * nz)
        .into_par_iter()
        .flat_map_iter(|idx| {
            let ijk = [idx % nx, (idx / nx) % ny, idx / (nx * ny)];
            let c: [f32; 3] = std::array::from_fn(|a| origin[a] + (ijk[a] as f32 + 0.5) * cell);
            plane_facing(bvh, &verts, c.map(|x| x as f64), inside(c))
        })
        .collect()
}

/// The hull's supporting plane facing `c` as stored, `[n, h]`: `n` the
/// direction from the nearest point of the head's surface to `c` (the
/// other way when `c` lies inside, so a cell straddling the surface gets
/// the tangent plane there; the face's normal when `c` lies on it), `h`
/// exact. No plane when even that leaves `c`'s own bound negative by
/// more than the cell could use.
fn plane_facing(bvh: HeadBvh, verts: &[[f64; 3]], c: [f64; 3], inside: bool) -> [f32; 4] {
    let (d, q, t) = nearest_on(bvh, c);
    let dir = if d > 1e-6 {
        let s = if inside { -1.0 } else { 1.0 };
        (DVec3::from(c) - DVec3::from(q)) * s / d
    } else {
        let t = &bvh.1[t];
        let [a, b, e] = [t.v0, t.v1, t.v2].map(|v| DVec3::from(v.map(|x| x as f64)));
        let n = (b - a).cross(e - a);
        n / n.length()
    };
    if !dir.is_finite() {
        return [0.0, 0.0, 0.0, NO_PLANE];
    }
    // The direction as stored (f32) is the one every reader uses, so
    // `h` is that direction's support, in f64 (f32 products are exact
    // there), rounded up to the next f32.
    let n = dir.to_array().map(|x| x as f32);
    let nd = DVec3::from(n.map(|x| x as f64));
    let h = verts
        .iter()
        .map(|v| nd.dot(DVec3::from(*v)))
        .fold(f64::NEG_INFINITY, f64::max);
    [n[0], n[1], n[2], round_up(h)]
}

/// The smallest f32 not below `x`.
fn round_up(x: f64) -> f32 {
    let f = x as f32;
    if (f as f64) >= x {
        f
    } else {
        f.next_up()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::head::{Head, HeadConfig};

    /// The data set's head in form: a 45° cone to 20 mm, a cylinder of
    /// radius 20 mm to 30 mm (convex).
    fn cone_head() -> Head {
        let mesh = crate::default_job::cone_head(20.0, 20.0, 30.0, 64);
        Head::build(&mesh, &HeadConfig::default(), 3e-4).unwrap()
    }

    fn planes(head: &Head) -> Vec<[f32; 4]> {
        let p = &head.params;
        let start = p.plane_offset as usize;
        let n = (p.plane_dims[0] * p.plane_dims[1] * p.plane_dims[2]) as usize;
        head.grid[start..start + 4 * n]
            .chunks_exact(4)
            .map(|c| [c[0], c[1], c[2], c[3]])
            .collect()
    }

    /// Every plane has the whole head below it: no head vertex lies
    /// beyond `h` along `n` (in exact arithmetic on the stored floats).
    /// This is what makes the bound safe; it fails when `h` is rounded
    /// to nearest instead of up.
    #[test]
    fn every_head_vertex_lies_under_every_plane() {
        for head in [cone_head(), star_head()] {
            let table = planes(&head);
            let with = table.iter().filter(|p| p[3] < NO_PLANE).count();
            assert!(with == table.len(), "{with} of {} cells", table.len());
            for p in table.iter().filter(|p| p[3] < NO_PLANE) {
                let n = [p[0], p[1], p[2]].map(|x| x as f64);
                let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
                assert!((len - 1.0).abs() < 1e-6, "unit normal, {len}");
                for v in &head.mesh.vertices {
                    let d = n[0] * v[0] as f64 + n[1] * v[1] as f64 + n[2] * v[2] as f64;
                    assert!(
                        d <= p[3] as f64,
                        "vertex {v:?} beyond {p:?} by {}",
                        d - p[3] as f64
                    );
                }
            }
        }
    }

    /// On a convex head (the data set's cone and cylinder) the plane of a
    /// cell is the head's tangent plane nearest its centre: at the centre
    /// the bound is the exact distance to the head (within rounding) when
    /// the centre lies outside, minus that distance when inside, so it
    /// settles whatever the exact tests would.
    #[test]
    fn on_a_convex_head_the_bound_at_each_centre_is_the_distance() {
        let head = cone_head();
        let p = &head.params;
        let table = planes(&head);
        let [nx, ny, _] = p.plane_dims.map(|d| d as usize);
        let (mut outside, mut worst) = (0usize, 0f64);
        for (idx, pl) in table.iter().enumerate() {
            assert!(pl[3] < NO_PLANE, "every cell has a plane on this head");
            let ijk = [idx % nx, (idx / nx) % ny, idx / (nx * ny)];
            let c: [f64; 3] = std::array::from_fn(|a| {
                (p.plane_origin[a] + (ijk[a] as f32 + 0.5) * p.plane_cell) as f64
            });
            let bound =
                pl[0] as f64 * c[0] + pl[1] as f64 * c[1] + pl[2] as f64 * c[2] - pl[3] as f64;
            let d = crate::scene::nearest::nearest_distance((&head.nodes, &head.triangles), c);
            // The stored normal is unit within f32 rounding: the bound may
            // exceed the distance by that relative amount, which the
            // evaluators' `grid_slack` covers many times over.
            assert!(
                bound <= d * (1.0 + 1e-7),
                "a bound above the distance: {bound} > {d}"
            );
            worst = worst.max(d - bound.abs());
            outside += (bound > 0.0) as usize;
        }
        assert!(outside > 1000, "{outside} cells outside");
        assert!(worst < 1e-3, "the bound falls {worst} mm short at a centre");
    }

    /// A star-shaped, non-convex head: cells in its recesses lie inside
    /// its hull and get no plane; the others must still keep the whole
    /// head under theirs.
    fn star_head() -> Head {
        let mut vertices = vec![[0.0f32, 0.0, 0.0], [0.0, 0.0, 20.0]];
        let k = 10usize;
        for i in 0..k {
            let a = i as f32 * std::f32::consts::TAU / k as f32;
            let r = if i % 2 == 0 { 12.0 } else { 4.0 };
            vertices.push([r * a.cos(), r * a.sin(), 8.0]);
        }
        let mut triangles = Vec::new();
        for i in 0..k as u32 {
            let (a, b) = (2 + i, 2 + (i + 1) % k as u32);
            triangles.push([0, b, a]);
            triangles.push([1, a, b]);
        }
        let mesh = crate::geometry::Mesh {
            vertices,
            triangles,
        };
        Head::build(&mesh, &HeadConfig::default(), 1e-4).unwrap()
    }
}

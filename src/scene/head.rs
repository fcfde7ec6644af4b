//! The print head as the evaluators see it: its triangles and a small BVH in
//! its own frame, the same triangles in "ray space" for containment parity,
//! and a signed-distance grid that settles most part nodes and triangles
//! without a single triangle test.
//!
//! Grid semantics: each cell stores a signed lower bound `v` on the distance
//! from its centre to the head surface (negative inside): exact in a band
//! of width `W` around the surface (from every nearby triangle), beyond it
//! `max(W, D − s)` where `D` is the exact distance at the centre of the
//! enclosing cell of a 4× coarser grid and `s` the distance between the two
//! centres. For any point `p` in the cell, `|v| − |p − centre|` bounds the
//! distance from `p` to the surface, so a sphere of radius `r` around `p`
//! with `|v| − |p − centre| > r + grid_slack` lies wholly on `v`'s side
//! (`grid_slack` covers rounding); wholly outside *and* more than a query's
//! safety margin away when the bound exceeds `r + grid_slack + margin`.
//!
//! Around the fine grid a far grid, 8× coarser and one head extent wider
//! on every side, holds the exact distance from each cell centre (all of
//! them outside the head) and settles points the fine grid does not reach
//! the same way; beyond both, the distance to the head's box. Without it,
//! big part nodes below a cone-shaped head are bounded only by the box's
//! flat bottom at the tip's height and are never culled.

use super::bvh::{self, StampedBvh};
use super::gpu_types::{GpuHeadParams, GpuNode, GpuTriangle};
use super::hull_plane;
use super::nearest::{nearest_distance, HeadBvh};
use super::SceneError;
use crate::geometry::aabb::point_box_distance;
use crate::geometry::point_in_mesh::{ray_frame, to_ray_space, RayParity};
use crate::geometry::point_triangle_distance::point_triangle_distance;
use crate::geometry::{Aabb, Mesh, V3};
use glam::DVec3;
use rayon::prelude::*;

/// The head, ready for every backend.
#[derive(Clone, Debug)]
pub struct Head {
    /// Welded, closed mesh in the head frame with the tip clearance applied.
    pub mesh: Mesh,
    /// Scalars shared with the shaders.
    pub params: GpuHeadParams,
    /// Head BVH nodes (stamps unused).
    pub nodes: Vec<GpuNode>,
    /// Head triangles in BVH leaf order (head frame).
    pub triangles: Vec<GpuTriangle>,
    /// The same triangles in ray space.
    pub ray_triangles: Vec<GpuTriangle>,
    /// Signed distance per grid cell, x fastest; then the far grid's
    /// cells, the support map's and the hull planes'
    /// ([`GpuHeadParams::far_offset`], [`GpuHeadParams::support_offset`],
    /// [`GpuHeadParams::plane_offset`]).
    pub grid: Vec<f32>,
    /// The support map's words decoded, the bounds of `h(u)` and `h(−u)`
    /// per cell, for the cpu walk (`decoded_support`; not cached: it is
    /// the grid's words read).
    pub support: Vec<[f32; 2]>,
}

/// How finely to build the head's data.
#[derive(Clone, Copy, Debug)]
pub struct HeadConfig {
    /// Contact closer than this to the nozzle tip is ignored: the head is
    /// lifted by this much along its axis (mm).
    pub tip_clearance: f32,
    /// Grid cells along the head's longest side: finer cells bound part
    /// triangles closer (fewer exact tests) at the cube of the cost to
    /// build and hold (ARCHITECTURE.md, "The head").
    pub grid_resolution: u32,
}

impl Default for HeadConfig {
    fn default() -> Self {
        HeadConfig {
            tip_clearance: 0.3,
            grid_resolution: 160,
        }
    }
}

impl Head {
    /// Build from a closed mesh in the head frame (tip at origin, axis +z).
    /// `tol` is the scene's contact tolerance (mm).
    pub fn build(mesh: &Mesh, cfg: &HeadConfig, tol: f32) -> Result<Head, SceneError> {
        let mesh = closed_and_lifted(mesh, cfg.tip_clearance)?;
        let StampedBvh { nodes, triangles } = bvh::build(&head_triangles(&mesh), 4, 0.0)?;
        let frame = ray_frame();
        let ray_triangles = triangles
            .iter()
            .map(|t| GpuTriangle {
                v0: to_ray_space(&frame, t.v0),
                v1: to_ray_space(&frame, t.v1),
                v2: to_ray_space(&frame, t.v2),
                ..*t
            })
            .collect();
        let aabb = Aabb::from_points(&mesh.vertices);
        let (grid, layout) = grid_buffer(&mesh, (&nodes[..], &triangles[..]), &aabb, &frame, cfg);
        let params = head_params(&aabb, &frame, &layout, triangles.len() as u32);
        let mut head = Head {
            mesh,
            params,
            nodes,
            triangles,
            ray_triangles,
            support: decoded_support(&grid, &params)
                .expect("the grid buffer holds the support map"),
            grid,
        };
        head.set_tol(tol);
        Ok(head)
    }

    /// Apply the scene's contact tolerance `tol` (mm): the only part of
    /// the head's data that depends on it, so a head built once serves
    /// every scene ([`super::head_cache`]).
    pub fn set_tol(&mut self, tol: f32) {
        self.params.tol = tol;
        self.params.grid_slack = 2.0 * tol;
    }

    /// The head's bounding box in its own frame.
    pub fn aabb(&self) -> Aabb {
        Aabb {
            min: self.params.aabb_min,
            max: self.params.aabb_max,
        }
    }
}

/// `mesh` welded and without degenerate triangles, checked closed and
/// outwards facing, and lifted by the tip clearance `lift` along its
/// axis.
fn closed_and_lifted(mesh: &Mesh, lift: f32) -> Result<Mesh, SceneError> {
    let (mesh, _) = mesh.welded().without_degenerate();
    if mesh.triangles.is_empty() {
        return Err(SceneError::Empty("the head mesh has no triangles".into()));
    }
    let open = mesh.open_edges();
    if open > 0 {
        return Err(SceneError::HeadNotClosed(open));
    }
    if mesh.signed_volume() < 0.0 {
        return Err(SceneError::HeadInsideOut);
    }
    Ok(mesh.map_vertices(|v| [v[0], v[1], v[2] + lift]))
}

/// The head's triangles for its BVH (stamp 0, no layer).
fn head_triangles(mesh: &Mesh) -> Vec<GpuTriangle> {
    (0..mesh.triangles.len())
        .map(|i| {
            let [v0, v1, v2] = mesh.corners(i);
            GpuTriangle {
                v0,
                stamp: 0,
                v1,
                layer: u32::MAX,
                v2,
                source: i as u32,
            }
        })
        .collect()
}

/// A grid of cells: its corner, cell size and cell counts.
#[derive(Clone, Copy, Debug)]
struct GridLayout {
    origin: V3,
    cell: f32,
    dims: [u32; 3],
}

impl GridLayout {
    /// The fine grid around the head's box `aabb`, `resolution` cells
    /// along its longest side, reaching `band` beyond it on every side.
    fn fine(aabb: &Aabb, resolution: u32, band: f32) -> Self {
        let cell = aabb.extent() / resolution.max(4) as f32;
        let origin = [aabb.min[0] - band, aabb.min[1] - band, aabb.min[2] - band];
        let dims: [u32; 3] = std::array::from_fn(|k| {
            (((aabb.max[k] - aabb.min[k]) + 2.0 * band) / cell).ceil() as u32 + 1
        });
        GridLayout { origin, cell, dims }
    }

    /// The far grid: [`FAR_COARSE`] times coarser than `self`, reaching
    /// `reach` beyond it on every side.
    fn far(&self, reach: f32) -> Self {
        let cell = self.cell * FAR_COARSE;
        let origin = self.origin.map(|o| o - reach);
        let dims: [u32; 3] = std::array::from_fn(|k| {
            ((self.dims[k] as f32 * self.cell + 2.0 * reach) / cell).ceil() as u32
        });
        GridLayout { origin, cell, dims }
    }

    /// The centre of cell `i` along axis `k`, in f64.
    fn centre(&self, i: usize, k: usize) -> f64 {
        self.origin[k] as f64 + (i as f64 + 0.5) * self.cell as f64
    }
}

/// How much coarser the far grid is than the fine one. It reaches one
/// head extent beyond the fine grid on every side, so big part nodes
/// below and beside the head are culled by distance, not by the head's
/// box.
const FAR_COARSE: f32 = 8.0;

/// Where each table of the grid buffer lies and how its grid is laid out.
struct GridBufferLayout {
    fine: GridLayout,
    far: GridLayout,
    far_offset: u32,
    support_offset: u32,
    planes: GridLayout,
    plane_offset: u32,
}

/// The grid buffer the evaluators read: the fine distance grid, the far
/// grid, the support map and the hull planes, one after another
/// ([`Head::grid`]); and where each lies.
fn grid_buffer(
    mesh: &Mesh,
    bvh: HeadBvh,
    aabb: &Aabb,
    frame: &[V3; 3],
    cfg: &HeadConfig,
) -> (Vec<f32>, GridBufferLayout) {
    let band = 8.0 * (aabb.extent() / cfg.grid_resolution.max(4) as f32);
    let fine = GridLayout::fine(aabb, cfg.grid_resolution, band);
    let far = fine.far(aabb.extent());
    let mut grid = distance_grid(mesh, bvh, &fine, band);
    let far_offset = grid.len() as u32;
    grid.extend(far_grid(bvh, aabb, &far));
    let support_offset = grid.len() as u32;
    grid.extend(super::slab::support_pairs(&mesh.vertices));
    // The planes start on a 16-byte boundary and the grid ends on one:
    // the kernels read a plane as one vec4 (`grid4`).
    grid.resize(grid.len().next_multiple_of(4), 0.0);
    let plane_offset = grid.len() as u32;
    let (origin, cell, dims) = hull_plane::plane_grid(fine.origin, fine.cell, fine.dims);
    let planes = GridLayout { origin, cell, dims };
    // Exact containment (ray parity, as the evaluators decide it).
    let ray_verts: Vec<V3> = mesh
        .vertices
        .iter()
        .map(|v| to_ray_space(frame, *v))
        .collect();
    let parity = RayParity::new(&ray_verts, &mesh.triangles);
    let inside = |p: [f32; 3]| parity.contains(to_ray_space(frame, p));
    grid.extend(hull_plane::hull_planes(
        bvh,
        &mesh.vertices,
        (origin, cell, dims),
        inside,
    ));
    grid.resize(grid.len().next_multiple_of(4), 0.0);
    let layout = GridBufferLayout {
        fine,
        far,
        far_offset,
        support_offset,
        planes,
        plane_offset,
    };
    (grid, layout)
}

/// The support map's words in `grid` ([`super::slab::support_pairs`],
/// from `params.support_offset`) as the kernels unpack them
/// ([`super::slab::support_pair`]): the walk reads a decoded pair
/// instead of converting two halves a slab test. `None` when the grid is
/// too short to hold the map (a damaged cache entry).
pub(super) fn decoded_support(grid: &[f32], params: &GpuHeadParams) -> Option<Vec<[f32; 2]>> {
    let start = params.support_offset as usize;
    let cells = (6 * super::slab::SUPPORT_SIDE * super::slab::SUPPORT_SIDE) as usize;
    let words = grid.get(start..start.checked_add(cells)?)?;
    Some(
        words
            .iter()
            .map(|&w| super::slab::support_pair(w))
            .collect(),
    )
}

/// The head's scalars for the kernels, the tolerance not yet set
/// ([`Head::set_tol`]).
fn head_params(
    aabb: &Aabb,
    frame: &[V3; 3],
    layout: &GridBufferLayout,
    tri_count: u32,
) -> GpuHeadParams {
    let GridBufferLayout {
        fine, far, planes, ..
    } = layout;
    GpuHeadParams {
        aabb_min: aabb.min,
        tol: 0.0,
        aabb_max: aabb.max,
        grid_slack: 0.0,
        grid_origin: fine.origin,
        cell: fine.cell,
        grid_dims: fine.dims,
        tri_count,
        ray_a: [frame[0][0], frame[0][1], frame[0][2], 0.0],
        ray_b: [frame[1][0], frame[1][1], frame[1][2], 0.0],
        ray_d: [frame[2][0], frame[2][1], frame[2][2], 0.0],
        inv_cell: 1.0 / fine.cell,
        inv_ray: [1.0 / frame[2][0], 1.0 / frame[2][1], 1.0 / frame[2][2]],
        far_origin: far.origin,
        far_cell: far.cell,
        far_dims: far.dims,
        far_offset: layout.far_offset,
        far_inv_cell: 1.0 / far.cell,
        support_offset: layout.support_offset,
        plane_offset: layout.plane_offset,
        plane_inv_cell: 1.0 / planes.cell,
        plane_origin: planes.origin,
        plane_cell: planes.cell,
        plane_dims: planes.dims,
        _pad: 0,
    }
}

/// Signed distances at the fine grid's cell centres, capped at `band`:
/// exact distances in a band around each triangle, signs from vertical
/// ray parity per column, then the capped cells lifted to the coarse
/// grid's bound ([`lift_capped_cells`]).
fn distance_grid(mesh: &Mesh, bvh: HeadBvh, layout: &GridLayout, band: f32) -> Vec<f32> {
    let [nx, ny, nz] = layout.dims.map(|d| d as usize);
    let tris: Vec<[[f64; 3]; 3]> = (0..mesh.triangles.len())
        .map(|i| mesh.corners(i).map(|v| v.map(|c| c as f64)))
        .collect();
    let planes = triangle_planes(&tris);
    // One z-column (fixed x, y) per task: unsigned distance, then the sign.
    let columns: Vec<Vec<f32>> = (0..nx * ny)
        .into_par_iter()
        .map(|col| {
            let (x, y) = (layout.centre(col % nx, 0), layout.centre(col / nx, 1));
            let (dist, crossings) = column(&tris, &planes, layout, band as f64, (x, y));
            signed_column(layout, band as f64, &dist, crossings)
        })
        .collect();
    let mut grid = vec![0.0f32; nx * ny * nz];
    for (col, values) in columns.into_iter().enumerate() {
        for (k, v) in values.into_iter().enumerate() {
            grid[k * nx * ny + col] = v;
        }
    }
    lift_capped_cells(&mut grid, bvh, layout, band as f64);
    grid
}

/// Unit normal and offset per triangle: a column meets the band around a
/// triangle only where it meets the slab `|n·p − d| ≤ band`.
fn triangle_planes(tris: &[[[f64; 3]; 3]]) -> Vec<(DVec3, f64)> {
    tris.iter()
        .map(|t| {
            let [a, b, c] = t.map(DVec3::from);
            let n = (b - a).cross(c - a);
            let n = n / n.length();
            (n, n.dot(a))
        })
        .collect()
}

/// The column of cells at `(x, y)`: each cell's distance to the nearest
/// triangle within `band` (`band` where none is), and the heights where
/// the vertical line crosses the head, unsorted.
fn column(
    tris: &[[[f64; 3]; 3]],
    planes: &[(DVec3, f64)],
    layout: &GridLayout,
    band: f64,
    (x, y): (f64, f64),
) -> (Vec<f64>, Vec<f64>) {
    let nz = layout.dims[2] as usize;
    let (oz, cell) = (layout.origin[2] as f64, layout.cell as f64);
    let mut dist = vec![band; nz];
    let mut crossings: Vec<f64> = Vec::new();
    for (t, (n, d)) in tris.iter().zip(planes) {
        let lo = [0, 1, 2].map(|k| t[0][k].min(t[1][k]).min(t[2][k]));
        let hi = [0, 1, 2].map(|k| t[0][k].max(t[1][k]).max(t[2][k]));
        if x >= lo[0] - band && x <= hi[0] + band && y >= lo[1] - band && y <= hi[1] + band {
            // The slab's z range on this column (one cell wider each
            // way for rounding), within the box's.
            let (mut z0, mut z1) = (lo[2] - band, hi[2] + band);
            let off = d - n[0] * x - n[1] * y;
            if n[2].abs() > 1e-9 {
                let (a, b) = ((off - band) / n[2], (off + band) / n[2]);
                z0 = z0.max(a.min(b) - cell);
                z1 = z1.min(a.max(b) + cell);
            } else if off.abs() > band + cell {
                z1 = z0 - 1.0;
            }
            let k0 = (((z0 - oz) / cell).floor().max(0.0)) as usize;
            let k1 = ((((z1 - oz) / cell).ceil()).max(0.0) as usize).min(nz);
            for (k, d) in dist.iter_mut().enumerate().take(k1).skip(k0) {
                let z = layout.centre(k, 2);
                // The plane's distance bounds the triangle's from below: a
                // triangle that cannot beat the nearest so far is not
                // measured (with room for rounding, so the minimum is the
                // one measuring all would give).
                if (off - n[2] * z).abs() > *d + 1e-9 {
                    continue;
                }
                *d = d.min(point_triangle_distance([x, y, z], t[0], t[1], t[2]));
            }
        }
        if let Some(z) = vertical_crossing(t, x, y) {
            crossings.push(z);
        }
    }
    (dist, crossings)
}

/// A column's cells as stored: each distance capped at `band`, negative
/// where an odd number of `crossings` lie above the cell's centre.
fn signed_column(
    layout: &GridLayout,
    band: f64,
    dist: &[f64],
    mut crossings: Vec<f64>,
) -> Vec<f32> {
    crossings.sort_by(f64::total_cmp);
    (0..layout.dims[2] as usize)
        .map(|k| {
            let z = layout.centre(k, 2);
            let above = crossings.len() - crossings.partition_point(|&c| c <= z);
            let d = dist[k].min(band) as f32;
            if above % 2 == 1 {
                -d
            } else {
                d
            }
        })
        .collect()
}

/// Beyond the band the cap would stop big part nodes from ever being
/// culled. Exact distances on a grid [`LIFT_COARSE`] times coarser (brute
/// force, cheap at that size) lift every capped cell to the valid lower
/// bound `coarse distance − distance between the two cell centres`.
fn lift_capped_cells(grid: &mut [f32], bvh: HeadBvh, layout: &GridLayout, band: f64) {
    let [nx, ny, nz] = layout.dims.map(|d| d as usize);
    let cdims = [nx, ny, nz].map(|n| n.div_ceil(LIFT_COARSE));
    let ccell = layout.cell as f64 * LIFT_COARSE as f64;
    let ccentre = |i: usize, k: usize| layout.origin[k] as f64 + (i as f64 + 0.5) * ccell;
    // Only coarse cells holding a capped fine cell are read.
    let mut capped = vec![false; cdims[0] * cdims[1] * cdims[2]];
    for (idx, v) in grid.iter().enumerate() {
        if v.abs() as f64 >= band {
            let (i, j, k) = (idx % nx, (idx / nx) % ny, idx / (nx * ny));
            let (ci, cj, ck) = (i / LIFT_COARSE, j / LIFT_COARSE, k / LIFT_COARSE);
            capped[(ck * cdims[1] + cj) * cdims[0] + ci] = true;
        }
    }
    let coarse: Vec<f64> = (0..cdims[0] * cdims[1] * cdims[2])
        .into_par_iter()
        .map(|c| {
            if !capped[c] {
                return 0.0;
            }
            let (i, j, k) = (
                c % cdims[0],
                (c / cdims[0]) % cdims[1],
                c / (cdims[0] * cdims[1]),
            );
            nearest_distance(bvh, [ccentre(i, 0), ccentre(j, 1), ccentre(k, 2)])
        })
        .collect();
    grid.par_iter_mut().enumerate().for_each(|(idx, v)| {
        let (i, j, k) = (idx % nx, (idx / nx) % ny, idx / (nx * ny));
        let mut d = v.abs() as f64;
        if d >= band {
            let (ci, cj, ck) = (i / LIFT_COARSE, j / LIFT_COARSE, k / LIFT_COARSE);
            let off = DVec3::new(
                layout.centre(i, 0) - ccentre(ci, 0),
                layout.centre(j, 1) - ccentre(cj, 1),
                layout.centre(k, 2) - ccentre(ck, 2),
            );
            d = (coarse[(ck * cdims[1] + cj) * cdims[0] + ci] - off.length()).max(band);
        }
        let m = d as f32;
        *v = if *v < 0.0 { -m } else { m };
    });
}

/// How much coarser the grid of exact distances that lifts capped cells
/// is than the fine grid.
const LIFT_COARSE: usize = 4;

/// Unsigned distances from the far grid's cell centres to the head; 0 (a
/// bound that settles nothing) for centres inside the head's box, which
/// lie in the fine grid's reach and are never read.
fn far_grid(bvh: HeadBvh, aabb: &Aabb, layout: &GridLayout) -> Vec<f32> {
    let GridLayout { origin, cell, dims } = *layout;
    let [nx, ny, nz] = dims.map(|d| d as usize);
    (0..nx * ny * nz)
        .into_par_iter()
        .map(|idx| {
            // The centre as `classify` measures from it (`clears_centre`).
            let ijk = [idx % nx, (idx / nx) % ny, idx / (nx * ny)];
            let p: V3 = std::array::from_fn(|a| origin[a] + (ijk[a] as f32 + 0.5) * cell);
            if point_box_distance(p, aabb.min, aabb.max) == 0.0 {
                return 0.0;
            }
            nearest_distance(bvh, p.map(|x| x as f64)) as f32
        })
        .collect()
}

/// Height where the vertical line through `(x, y)` crosses triangle `t`,
/// with the same simulation-of-simplicity tie-break as
/// [`crate::geometry::point_in_mesh`] (vertical triangles never count).
fn vertical_crossing(t: &[[f64; 3]; 3], x: f64, y: f64) -> Option<f64> {
    let e = |a: [f64; 3], b: [f64; 3]| -> (f64, bool) {
        let e = (a[0] - x) * (b[1] - y) - (a[1] - y) * (b[0] - x);
        let pos = if e != 0.0 {
            e > 0.0
        } else if a[1] != b[1] {
            a[1] - b[1] > 0.0
        } else {
            b[0] - a[0] > 0.0
        };
        (e, pos)
    };
    let (wc, s0) = e(t[0], t[1]);
    let (wa, s1) = e(t[1], t[2]);
    let (wb, s2) = e(t[2], t[0]);
    if s0 != s1 || s1 != s2 {
        return None;
    }
    let sum = wa + wb + wc;
    if sum == 0.0 {
        return None;
    }
    Some((wa * t[0][2] + wb * t[1][2] + wc * t[2][2]) / sum)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::collide::brute::mesh_distance64;
    use crate::collide::cpu::classify;
    use crate::default_job::cone_head;

    /// The decoded support map is every word of the grid's map as the
    /// kernels unpack it (`support_pair`, their twin), bit for bit, in
    /// cell order; a grid too short to hold the map has none.
    #[test]
    fn the_decoded_support_map_is_the_kernels_reading_of_each_word() {
        let mut head =
            Head::build(&cone_head(5.0, 5.0, 12.0, 24), &HeadConfig::default(), 1e-5).unwrap();
        let start = head.params.support_offset as usize;
        let cells = (6 * super::super::slab::SUPPORT_SIDE.pow(2)) as usize;
        assert_eq!(head.support.len(), cells);
        let mut sides_differ = 0;
        for (i, pair) in head.support.iter().enumerate() {
            let word = crate::collide::cpu::support_pair(head.grid[start + i]);
            assert_eq!(pair.map(f32::to_bits), word.map(f32::to_bits), "cell {i}");
            sides_differ += (pair[0] != pair[1]) as usize;
        }
        assert!(
            sides_differ > cells / 2,
            "{sides_differ} cells with h(u) ≠ h(−u)"
        );
        head.grid.truncate(start + cells - 1);
        assert!(decoded_support(&head.grid, &head.params).is_none());
    }

    /// Every far cell outside the head's box holds the exact distance from
    /// its centre (the BVH search against a plain loop), so the bound
    /// `v − |p − centre|` holds for every point of the cell.
    #[test]
    fn far_grid_holds_exact_distances() {
        let head =
            Head::build(&cone_head(5.0, 5.0, 12.0, 24), &HeadConfig::default(), 1e-5).unwrap();
        let h = &head.params;
        let [nx, ny, nz] = h.far_dims;
        let mut checked = 0;
        for idx in (0..nx * ny * nz).step_by(7) {
            let ijk = [idx % nx, (idx / nx) % ny, idx / (nx * ny)];
            let p: V3 =
                std::array::from_fn(|a| h.far_origin[a] + (ijk[a] as f32 + 0.5) * h.far_cell);
            let v = head.grid[(h.far_offset + idx) as usize] as f64;
            if point_box_distance(p, h.aabb_min, h.aabb_max) == 0.0 {
                assert_eq!(v, 0.0);
                continue;
            }
            let d = mesh_distance64(&head.mesh, p.map(f64::from));
            assert!(
                (v - d).abs() <= 1e-5 * d.max(1.0),
                "cell {ijk:?}: far {v}, brute {d}"
            );
            checked += 1;
        }
        assert!(checked > 1000, "{checked} cells");
    }

    /// Every fine cell within the band holds the nearest triangle's
    /// distance from its centre, exactly as a plain loop over all
    /// triangles measures it (f64, rounded once): skipping triangles whose
    /// plane is already farther than the nearest found changes no cell.
    #[test]
    fn band_cells_hold_the_plain_loops_distance() {
        let cfg = HeadConfig {
            grid_resolution: 40,
            ..HeadConfig::default()
        };
        let head = Head::build(&cone_head(5.0, 5.0, 12.0, 24), &cfg, 1e-5).unwrap();
        let h = &head.params;
        let [nx, ny, nz] = h.grid_dims;
        let band = 8.0 * h.cell as f64;
        let mut inside_band = 0;
        for idx in 0..nx * ny * nz {
            let ijk = [idx % nx, (idx / nx) % ny, idx / (nx * ny)];
            let p: [f64; 3] = std::array::from_fn(|a| {
                h.grid_origin[a] as f64 + (ijk[a] as f64 + 0.5) * h.cell as f64
            });
            let d = mesh_distance64(&head.mesh, p);
            if d < band {
                assert_eq!(head.grid[idx as usize].abs(), d as f32, "cell {ijk:?}");
                inside_band += 1;
            }
        }
        assert!(inside_band > 10_000, "{inside_band} cells");
    }

    /// Beside the cone, out of the fine grid's reach, a sphere
    /// well clear of the cone is culled by the far grid, where the head's
    /// box alone would leave it undecided.
    #[test]
    fn far_grid_culls_nodes_beside_the_cone() {
        let head =
            Head::build(&cone_head(5.0, 5.0, 12.0, 24), &HeadConfig::default(), 1e-5).unwrap();
        let h = &head.params;
        let extent = head.aabb().extent();
        let c = [h.aabb_max[0] + 0.3 * extent, 0.0, h.aabb_min[2]];
        let fine_hi = h.grid_origin[0] + h.grid_dims[0] as f32 * h.cell;
        assert!(c[0] > fine_hi, "the centre lies beside the fine grid");
        let d = mesh_distance64(&head.mesh, c.map(f64::from)) as f32;
        let r = d - 2.0 * h.far_cell;
        let box_d = point_box_distance(c, h.aabb_min, h.aabb_max);
        assert!(
            r > box_d,
            "the head's box alone cannot cull: box {box_d}, r {r}"
        );
        assert_eq!(classify(h, &head.grid, c, r, 0.05), 1);
        // And never culls a sphere that reaches the head.
        assert_eq!(classify(h, &head.grid, c, d + 0.01, 0.0), 0);
    }
}

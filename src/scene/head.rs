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

use super::bvh::{self, StampedBvh};
use super::gpu_types::{GpuHeadParams, GpuNode, GpuTriangle};
use super::SceneError;
use crate::geometry::point_in_mesh::{ray_frame, to_ray_space};
use crate::geometry::point_triangle_distance::point_triangle_distance;
use crate::geometry::{Aabb, Mesh, V3};
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
    /// Signed distance per grid cell, x fastest.
    pub grid: Vec<f32>,
}

/// How finely to build the head's data.
#[derive(Clone, Copy, Debug)]
pub struct HeadConfig {
    /// Contact closer than this to the nozzle tip is ignored: the head is
    /// lifted by this much along its axis (mm).
    pub tip_clearance: f32,
    /// Grid cells along the head's longest side.
    pub grid_resolution: u32,
}

impl Default for HeadConfig {
    fn default() -> Self {
        HeadConfig {
            tip_clearance: 0.3,
            grid_resolution: 96,
        }
    }
}

impl Head {
    /// Build from a closed mesh in the head frame (tip at origin, axis +z).
    /// `tol` is the scene's contact tolerance (mm).
    pub fn build(mesh: &Mesh, cfg: &HeadConfig, tol: f32) -> Result<Head, SceneError> {
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
        let lift = cfg.tip_clearance;
        let mesh = mesh.map_vertices(|v| [v[0], v[1], v[2] + lift]);

        let tris: Vec<GpuTriangle> = (0..mesh.triangles.len())
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
            .collect();
        let StampedBvh { nodes, triangles } = bvh::build(&tris, 4)?;
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
        let cell = aabb.extent() / cfg.grid_resolution.max(4) as f32;
        let band = 8.0 * cell;
        let origin = [aabb.min[0] - band, aabb.min[1] - band, aabb.min[2] - band];
        let dims: [u32; 3] = std::array::from_fn(|k| {
            (((aabb.max[k] - aabb.min[k]) + 2.0 * band) / cell).ceil() as u32 + 1
        });
        let grid = distance_grid(&mesh, origin, cell, dims, band);

        let params = GpuHeadParams {
            aabb_min: aabb.min,
            tol,
            aabb_max: aabb.max,
            grid_slack: 2.0 * tol,
            grid_origin: origin,
            cell,
            grid_dims: dims,
            tri_count: triangles.len() as u32,
            ray_a: [frame[0][0], frame[0][1], frame[0][2], 0.0],
            ray_b: [frame[1][0], frame[1][1], frame[1][2], 0.0],
            ray_d: [frame[2][0], frame[2][1], frame[2][2], 0.0],
            inv_cell: 1.0 / cell,
            inv_ray: [1.0 / frame[2][0], 1.0 / frame[2][1], 1.0 / frame[2][2]],
        };
        Ok(Head {
            mesh,
            params,
            nodes,
            triangles,
            ray_triangles,
            grid,
        })
    }

    /// The head's bounding box in its own frame.
    pub fn aabb(&self) -> Aabb {
        Aabb {
            min: self.params.aabb_min,
            max: self.params.aabb_max,
        }
    }
}

/// Signed distances at cell centres, capped at `band`: exact distances in a
/// band around each triangle, signs from vertical ray parity per column.
fn distance_grid(mesh: &Mesh, origin: V3, cell: f32, dims: [u32; 3], band: f32) -> Vec<f32> {
    let [nx, ny, nz] = dims.map(|d| d as usize);
    let centre = |i: usize, k: usize| origin[k] as f64 + (i as f64 + 0.5) * cell as f64;
    let tris: Vec<[[f64; 3]; 3]> = (0..mesh.triangles.len())
        .map(|i| mesh.corners(i).map(|v| v.map(|c| c as f64)))
        .collect();
    let band64 = band as f64;

    // One z-column (fixed x, y) per task: unsigned distance, then the sign.
    let columns: Vec<Vec<f32>> = (0..nx * ny)
        .into_par_iter()
        .map(|col| {
            let (ix, iy) = (col % nx, col / nx);
            let (x, y) = (centre(ix, 0), centre(iy, 1));
            let mut dist = vec![band64; nz];
            let mut crossings: Vec<f64> = Vec::new();
            for t in &tris {
                let lo = [0, 1, 2].map(|k| t[0][k].min(t[1][k]).min(t[2][k]));
                let hi = [0, 1, 2].map(|k| t[0][k].max(t[1][k]).max(t[2][k]));
                if x >= lo[0] - band64
                    && x <= hi[0] + band64
                    && y >= lo[1] - band64
                    && y <= hi[1] + band64
                {
                    let k0 = (((lo[2] - band64 - origin[2] as f64) / cell as f64)
                        .floor()
                        .max(0.0)) as usize;
                    let k1 = ((((hi[2] + band64 - origin[2] as f64) / cell as f64).ceil())
                        as usize)
                        .min(nz);
                    for (k, d) in dist.iter_mut().enumerate().take(k1).skip(k0) {
                        let p = [x, y, centre(k, 2)];
                        *d = d.min(point_triangle_distance(p, t[0], t[1], t[2]));
                    }
                }
                if let Some(z) = vertical_crossing(t, x, y) {
                    crossings.push(z);
                }
            }
            crossings.sort_by(f64::total_cmp);
            (0..nz)
                .map(|k| {
                    let z = centre(k, 2);
                    let above = crossings.len() - crossings.partition_point(|&c| c <= z);
                    let d = dist[k].min(band64) as f32;
                    if above % 2 == 1 {
                        -d
                    } else {
                        d
                    }
                })
                .collect()
        })
        .collect();
    let mut grid = vec![0.0f32; nx * ny * nz];
    for (col, values) in columns.into_iter().enumerate() {
        for (k, v) in values.into_iter().enumerate() {
            grid[k * nx * ny + col] = v;
        }
    }

    // Beyond the band the cap W would stop big part nodes from ever being
    // culled. Exact distances on a grid COARSE times coarser (brute force,
    // cheap at that size) lift every capped cell to the valid lower bound
    // `coarse distance − distance between the two cell centres`.
    const COARSE: usize = 4;
    let cdims = [nx, ny, nz].map(|n| n.div_ceil(COARSE));
    let ccell = cell as f64 * COARSE as f64;
    let ccentre = |i: usize, k: usize| origin[k] as f64 + (i as f64 + 0.5) * ccell;
    let coarse: Vec<f64> = (0..cdims[0] * cdims[1] * cdims[2])
        .into_par_iter()
        .map(|c| {
            let (i, j, k) = (
                c % cdims[0],
                (c / cdims[0]) % cdims[1],
                c / (cdims[0] * cdims[1]),
            );
            let p = [ccentre(i, 0), ccentre(j, 1), ccentre(k, 2)];
            tris.iter()
                .map(|t| point_triangle_distance(p, t[0], t[1], t[2]))
                .fold(f64::INFINITY, f64::min)
        })
        .collect();
    grid.par_iter_mut().enumerate().for_each(|(idx, v)| {
        let (i, j, k) = (idx % nx, (idx / nx) % ny, idx / (nx * ny));
        let mut d = v.abs() as f64;
        if d >= band64 {
            let (ci, cj, ck) = (i / COARSE, j / COARSE, k / COARSE);
            let off = [
                centre(i, 0) - ccentre(ci, 0),
                centre(j, 1) - ccentre(cj, 1),
                centre(k, 2) - ccentre(ck, 2),
            ];
            let off = (off[0] * off[0] + off[1] * off[1] + off[2] * off[2]).sqrt();
            d = (coarse[(ck * cdims[1] + cj) * cdims[0] + ci] - off).max(band64);
        }
        let m = d as f32;
        *v = if *v < 0.0 { -m } else { m };
    });
    grid
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

//! Print stamps: each layer-surface triangle takes the global index + 1 of
//! the nearest waypoint of its own layer (nearest to the triangle's
//! centroid; ties go to the earlier waypoint, so stamps are deterministic).
//!
//! The nearest waypoint is found in a uniform grid over the layer's
//! waypoints ([`WaypointGrid`]), searched in growing blocks of cells
//! around the centroid until no cell outside the block can hold anything
//! nearer. A layer's waypoints lie on its surface, so the cell size comes
//! from the surface's area (a few waypoints a cell) and most centroids are
//! settled by the cells next to them, where rstar's nearest-neighbour
//! iterator walks its tree for each. rstar remains the fallback for
//! centroids far from every waypoint, where the grid would scan many empty
//! cells.
//! Distances are the same f32 sums of squares in both, so the stamps are
//! identical.

use crate::geometry::{Mesh, V3};
use crate::toolpath::Waypoint;
use rayon::prelude::*;
use rstar::primitives::GeomWithData;
use rstar::RTree;
use std::sync::OnceLock;

type Site = GeomWithData<[f32; 3], u32>;

/// The stamp of what waypoint `g` (global print index) deposits: its
/// index + 1, the platform being stamp 0.
pub fn stamp_of(g: usize) -> u32 {
    g as u32 + 1
}

/// The cutoff of a pose at waypoint `g`: the material of every earlier
/// waypoint exists (stamps below `cutoff(g)`), its own bead not yet.
pub fn cutoff(g: usize) -> u32 {
    stamp_of(g)
}

/// Stamp per triangle of `mesh`, for a layer whose first waypoint has global
/// index `offset`.
pub fn nearest_waypoint_stamps(mesh: &Mesh, waypoints: &[Waypoint], offset: usize) -> Vec<u32> {
    let sites: Vec<V3> = waypoints.iter().map(|w| w.pos).collect();
    let grid = WaypointGrid::new(&sites, mesh.area());
    (0..mesh.triangles.len())
        .into_par_iter()
        .map(|i| {
            let j = grid.nearest(centroid(mesh.corners(i)));
            stamp_of(offset + j as usize)
        })
        .collect()
}

/// The centroid as stamps measure it (f32, divided by 3).
fn centroid([a, b, c]: [V3; 3]) -> V3 {
    [
        (a[0] + b[0] + c[0]) / 3.0,
        (a[1] + b[1] + c[1]) / 3.0,
        (a[2] + b[2] + c[2]) / 3.0,
    ]
}

/// Squared distance exactly as rstar measures it (f32, x then y then z), so
/// that both searches see the same ties.
#[inline(always)]
fn distance_2(a: V3, b: V3) -> f32 {
    let d = [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
}

/// Blocks of cells searched around a centroid before the rstar fallback.
/// Nearly every centroid is settled by the first block around its cell;
/// beyond three, the empty cells a block adds would cost more than
/// rstar.
const MAX_RING: i64 = 3;

/// Cells at most, per waypoint, however small the cell size wants to be.
const CELLS_PER_SITE: f64 = 8.0;

/// Waypoints bucketed by a uniform grid of cubic cells.
pub struct WaypointGrid<'a> {
    sites: &'a [V3],
    origin: [f64; 3],
    cell: f64,
    dims: [i64; 3],
    /// `start[c]..start[c + 1]` indexes `order` for cell `c`.
    start: Vec<u32>,
    /// Waypoint indices, cell by cell, ascending within a cell.
    order: Vec<u32>,
    fallback: OnceLock<RTree<Site>>,
}

impl<'a> WaypointGrid<'a> {
    /// A grid over `sites` that lie on a surface of about `area` mm²: cells
    /// hold about two waypoints each on that surface, and there are at
    /// most [`CELLS_PER_SITE`] cells per waypoint.
    pub fn new(sites: &'a [V3], area: f64) -> Self {
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        for p in sites {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k] as f64);
                hi[k] = hi[k].max(p[k] as f64);
            }
        }
        let n = sites.len().max(1) as f64;
        let extent: [f64; 3] = std::array::from_fn(|k| (hi[k] - lo[k]).max(0.0));
        let largest = extent.iter().fold(0.0f64, |a, &b| a.max(b));
        // Two waypoints a cell on the surface; never so small that the
        // box holds more than CELLS_PER_SITE cells per waypoint.
        let mut cell = (2.0 * area / n).sqrt();
        let volume_cell = ((extent[0] + largest * 1e-3)
            * (extent[1] + largest * 1e-3)
            * (extent[2] + largest * 1e-3)
            / (CELLS_PER_SITE * n))
            .cbrt();
        if !(cell.is_finite() && cell > 0.0) || cell < volume_cell {
            cell = volume_cell;
        }
        if !(cell.is_finite() && cell > 0.0) {
            cell = 1.0; // All waypoints at one point.
        }
        let dims: [i64; 3] = std::array::from_fn(|k| (extent[k] / cell).floor() as i64 + 1);
        let mut grid = WaypointGrid {
            sites,
            origin: lo,
            cell,
            dims,
            start: Vec::new(),
            order: Vec::new(),
            fallback: OnceLock::new(),
        };
        if sites.is_empty() {
            grid.dims = [0; 3];
            return grid;
        }
        // Counting sort of the waypoints into their cells.
        let cells = (dims[0] * dims[1] * dims[2]) as usize;
        let index: Vec<usize> = sites
            .iter()
            .map(|p| {
                let c = grid.cell_of(*p);
                grid.linear(std::array::from_fn(|k| c[k].clamp(0, dims[k] - 1)))
            })
            .collect();
        let mut start = vec![0u32; cells + 1];
        for &c in &index {
            start[c + 1] += 1;
        }
        for c in 0..cells {
            start[c + 1] += start[c];
        }
        let mut fill = start.clone();
        let mut order = vec![0u32; sites.len()];
        for (j, &c) in index.iter().enumerate() {
            order[fill[c] as usize] = j as u32;
            fill[c] += 1;
        }
        grid.start = start;
        grid.order = order;
        grid
    }

    /// The cell holding `p`, in grid coordinates (outside the grid for
    /// points beyond it).
    fn cell_of(&self, p: V3) -> [i64; 3] {
        std::array::from_fn(|k| {
            let f = ((p[k] as f64 - self.origin[k]) / self.cell).floor();
            f.clamp(-1e12, 1e12) as i64
        })
    }

    fn linear(&self, c: [i64; 3]) -> usize {
        ((c[2] * self.dims[1] + c[1]) * self.dims[0] + c[0]) as usize
    }

    /// The index of the waypoint nearest to `p` (ties: the lowest index).
    /// `0` when there are no waypoints.
    pub fn nearest(&self, p: V3) -> u32 {
        if self.sites.is_empty() {
            return 0;
        }
        let c = self.cell_of(p);
        let mut best: Option<(f32, u32)> = None;
        for r in 0..=MAX_RING {
            self.visit_ring(c, r, |j| {
                let d2 = distance_2(self.sites[j as usize], p);
                let better = match best {
                    None => true,
                    Some((bd, bj)) => d2 < bd || (d2 == bd && j < bj),
                };
                if better {
                    best = Some((d2, j));
                }
            });
            if let Some((bd, bj)) = best {
                // Everything outside the block of cells c ± r lies at least
                // `clear` from p; a strictly nearer waypoint there is
                // impossible, and so is a tie (kept strict, with room for
                // f32 rounding of the squared distances).
                let clear = self.block_clearance(p, c, r);
                let bd = (bd as f64).sqrt();
                if bd * (1.0 + 1e-5) + 1e-9 < clear {
                    return bj;
                }
            }
        }
        self.nearest_by_tree(p)
    }

    /// The distance from `p` to the outside of the block of cells `c ± r`.
    fn block_clearance(&self, p: V3, c: [i64; 3], r: i64) -> f64 {
        (0..3)
            .map(|k| {
                let lo = self.origin[k] + (c[k] - r) as f64 * self.cell;
                let hi = self.origin[k] + (c[k] + r + 1) as f64 * self.cell;
                let x = p[k] as f64;
                (x - lo).min(hi - x)
            })
            .fold(f64::INFINITY, f64::min)
    }

    /// Call `f` with every waypoint in the cells at Chebyshev distance
    /// exactly `r` from cell `c` (inside the grid).
    fn visit_ring(&self, c: [i64; 3], r: i64, mut f: impl FnMut(u32)) {
        let range = |k: usize| (c[k] - r).max(0)..=(c[k] + r).min(self.dims[k] - 1);
        for z in range(2) {
            for y in range(1) {
                let on_shell = (z - c[2]).abs() == r || (y - c[1]).abs() == r;
                for x in range(0) {
                    if !on_shell && (x - c[0]).abs() != r {
                        continue;
                    }
                    let l = self.linear([x, y, z]);
                    for &j in &self.order[self.start[l] as usize..self.start[l + 1] as usize] {
                        f(j);
                    }
                }
            }
        }
    }

    /// rstar's nearest-neighbour iterator, for centroids far from every
    /// waypoint (built on first use).
    fn nearest_by_tree(&self, p: V3) -> u32 {
        let tree = self.fallback.get_or_init(|| {
            RTree::bulk_load(
                self.sites
                    .iter()
                    .enumerate()
                    .map(|(j, w)| Site::new(*w, j as u32))
                    .collect(),
            )
        });
        let mut best: Option<(f32, u32)> = None;
        for (site, d2) in tree.nearest_neighbor_iter_with_distance_2(p) {
            if let Some((bd, bj)) = best {
                if d2 > bd {
                    break;
                }
                if site.data >= bj {
                    continue;
                }
            }
            best = Some((d2, site.data));
        }
        best.map_or(0, |(_, j)| j)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The plain loop: smallest (squared distance, index).
    fn nearest_by_loop(sites: &[V3], p: V3) -> u32 {
        let mut best = (f32::INFINITY, 0u32);
        for (j, s) in sites.iter().enumerate() {
            let d2 = distance_2(*s, p);
            if d2 < best.0 {
                best = (d2, j as u32);
            }
        }
        best.1
    }

    fn lcg(seed: &mut u64) -> f32 {
        *seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*seed >> 40) as f32) / (1u64 << 24) as f32
    }

    #[test]
    fn grid_finds_the_plain_loops_nearest_waypoint_ties_included() {
        let mut seed = 7u64;
        // A wavy strip of waypoints 0.5 mm apart in rows, some repeated
        // (exact ties), and queries near the strip, on cell corners of
        // the grid, and far away (the rstar fallback).
        let mut sites = Vec::new();
        for row in 0..40 {
            for k in 0..120 {
                let x = k as f32 * 0.5;
                let y = row as f32 * 0.5;
                sites.push([x, y, (x * 0.2).sin() * 3.0]);
            }
        }
        let copies: Vec<V3> = sites.iter().step_by(37).copied().collect();
        sites.extend(copies);
        let grid = WaypointGrid::new(&sites, 60.0 * 20.0);
        let mut queries: Vec<V3> = (0..20_000)
            .map(|_| {
                let s = sites[(lcg(&mut seed) * sites.len() as f32) as usize % sites.len()];
                [
                    s[0] + (lcg(&mut seed) - 0.5) * 2.0,
                    s[1] + (lcg(&mut seed) - 0.5) * 2.0,
                    s[2] + (lcg(&mut seed) - 0.5),
                ]
            })
            .collect();
        // Midpoints of neighbours: equidistant from two waypoints.
        queries.extend(sites.windows(2).map(|w| {
            [
                (w[0][0] + w[1][0]) / 2.0,
                (w[0][1] + w[1][1]) / 2.0,
                (w[0][2] + w[1][2]) / 2.0,
            ]
        }));
        queries.extend([
            [500.0, -300.0, 20.0],
            [-40.0, 10.0, 0.0],
            [30.0, 10.0, 90.0],
        ]);
        for p in queries {
            assert_eq!(grid.nearest(p), nearest_by_loop(&sites, p), "at {p:?}");
        }
    }

    #[test]
    fn grid_handles_one_point_and_flat_sets() {
        let one = [[1.0, 2.0, 3.0]];
        assert_eq!(WaypointGrid::new(&one, 0.0).nearest([9.0, 9.0, 9.0]), 0);
        let line: Vec<V3> = (0..50).map(|k| [k as f32, 0.0, 0.0]).collect();
        let grid = WaypointGrid::new(&line, 0.0);
        for p in [
            [3.4, 1.0, 0.0],
            [3.5, 0.0, 0.0],
            [-5.0, 0.0, 0.0],
            [60.0, 2.0, 1.0],
        ] {
            assert_eq!(grid.nearest(p), nearest_by_loop(&line, p), "at {p:?}");
        }
    }
}

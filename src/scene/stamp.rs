//! Print stamps: each layer-surface triangle takes the global index + 1 of
//! the nearest waypoint of its own layer (nearest to the triangle's
//! centroid; ties go to the earlier waypoint, so stamps are deterministic).

use crate::geometry::Mesh;
use crate::toolpath::Waypoint;
use rayon::prelude::*;
use rstar::primitives::GeomWithData;
use rstar::RTree;

type Site = GeomWithData<[f32; 3], u32>;

/// Stamp per triangle of `mesh`, for a layer whose first waypoint has global
/// index `offset`.
pub fn nearest_waypoint_stamps(mesh: &Mesh, waypoints: &[Waypoint], offset: usize) -> Vec<u32> {
    let tree = RTree::bulk_load(
        waypoints
            .iter()
            .enumerate()
            .map(|(j, w)| Site::new(w.pos, j as u32))
            .collect(),
    );
    (0..mesh.triangles.len())
        .into_par_iter()
        .map(|i| {
            let [a, b, c] = mesh.corners(i);
            let centroid = [
                (a[0] + b[0] + c[0]) / 3.0,
                (a[1] + b[1] + c[1]) / 3.0,
                (a[2] + b[2] + c[2]) / 3.0,
            ];
            let mut best: Option<(f32, u32)> = None;
            for (site, d2) in tree.nearest_neighbor_iter_with_distance_2(centroid) {
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
            let j = best.map_or(0, |(_, j)| j);
            (offset + j as usize + 1) as u32
        })
        .collect()
}

//! How much to extrude (paper 000, Eq. 1: `ΔE = k · H · W · L`), with the
//! layer height `H` measured per waypoint the way the data set's original
//! software does: the distance from the waypoint to the platform and to
//! the surfaces of the previous [`LOOKBACK`] layers, whichever is nearest.
//! Where support and model layers interleave, the layer printed just
//! before is often elsewhere; the surfaces below are what the bead rests
//! on.
//!
//! The distance is a nearest-triangle search over the scene's part BVH
//! (bounding spheres), skipping subtrees printed after the layer starts
//! and triangles of layers outside the look-back window, starting from
//! the triangle nearest to the previous waypoint.

use crate::geometry::point_triangle_distance::point_triangle_distance;
use crate::scene::{GpuPartNode, Scene};
use rayon::prelude::*;

/// Layers looked back for the surface a waypoint rests on.
pub const LOOKBACK: usize = 25;

/// A waypoint's layer height and whether the clamp decided it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Height {
    /// Layer height (mm), within the clamp.
    pub h: f64,
    /// Nothing below was within the clamp's range (or it was closer than
    /// its floor): the height is the clamp's bound, not a measurement.
    pub clamped: bool,
}

/// Layer heights of every waypoint (`pos` in print order, `layer_of` its
/// layer, `layer_start` the global index of each layer's first waypoint),
/// clamped to `[lo, hi]`.
pub fn layer_heights(
    scene: &Scene,
    pos: &[[f64; 3]],
    layer_of: &[usize],
    layer_start: &[usize],
    [lo, hi]: [f64; 2],
) -> Vec<Height> {
    pos.par_iter()
        .zip(layer_of.par_iter())
        .map_init(
            || None,
            |last: &mut Option<u32>, (&p, &k)| {
                let (d, t) = nearest_below(scene, p, k, layer_start[k] as u32 + 1, hi, *last);
                *last = t.or(*last);
                if d >= hi {
                    Height {
                        h: hi,
                        clamped: true,
                    }
                } else if d < lo {
                    Height {
                        h: lo,
                        clamped: true,
                    }
                } else {
                    Height {
                        h: d,
                        clamped: false,
                    }
                }
            },
        )
        .collect()
}

/// Distance from `p` to the nearest triangle of the platform or of layers
/// `layer − LOOKBACK .. layer` (stamps below `cutoff`), or `limit` if none
/// is closer.
/// The distance from `p` to the nearest triangle of the platform or of
/// layers `layer − LOOKBACK .. layer` with a stamp below `cutoff`, if
/// below `limit` (else `limit`), and that triangle. The search starts from
/// the distance to `hint` (the triangle nearest to the previous waypoint a
/// worker measured: neighbours rest on the same surface), so the walk is
/// pruned by their bounding spheres from its first node (dome_cut's
/// stage 0.48 → 0.45 s). The minimum is the one a search from `limit`
/// finds, whatever the hint.
fn nearest_below(
    scene: &Scene,
    p: [f64; 3],
    layer: usize,
    cutoff: u32,
    limit: f64,
    hint: Option<u32>,
) -> (f64, Option<u32>) {
    let first = layer.saturating_sub(LOOKBACK) as u32;
    let wanted = |l: u32| l == u32::MAX || (l >= first && (l as usize) < layer);
    let pf = p.map(|x| x as f32);
    let bound = |node: &GpuPartNode| {
        let c = node.center;
        let d = ((c[0] - pf[0]).powi(2) + (c[1] - pf[1]).powi(2) + (c[2] - pf[2]).powi(2)).sqrt();
        (d - node.radius) as f64
    };
    let v = |a: [f32; 3]| a.map(|x| x as f64);
    let mut best = (limit, None);
    if let Some(t) = hint.map(|t| &scene.part_tris[t as usize]) {
        if t.stamp < cutoff && wanted(t.layer) {
            let d = point_triangle_distance(p, v(t.v0), v(t.v1), v(t.v2));
            if d < best.0 {
                best = (d, hint);
            }
        }
    }
    let mut stack: Vec<u32> = vec![0];
    while let Some(i) = stack.pop() {
        let node = &scene.part_nodes[i as usize];
        if node.min_stamp >= cutoff || bound(node) >= best.0 {
            continue;
        }
        match node.leaf_range() {
            Some((start, count)) => {
                for k in start..start + count {
                    let t = &scene.part_tris[k as usize];
                    if t.stamp >= cutoff || !wanted(t.layer) {
                        continue;
                    }
                    let d = point_triangle_distance(p, v(t.v0), v(t.v1), v(t.v2));
                    if d < best.0 {
                        best = (d, Some(k));
                    }
                }
            }
            None => {
                let (l, r) = (node.packed, node.packed + 1);
                let (nl, nr) = (&scene.part_nodes[l as usize], &scene.part_nodes[r as usize]);
                if bound(nl) < bound(nr) {
                    stack.extend([r, l]);
                } else {
                    stack.extend([l, r]);
                }
            }
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::default_job::{box_mesh, cone_head};
    use crate::geometry::Mesh;
    use crate::scene::SceneConfig;
    use crate::toolpath::{Layer, Toolpath, Waypoint};

    fn plate(z: f32) -> Mesh {
        Mesh {
            vertices: vec![
                [-20.0, -20.0, z],
                [20.0, -20.0, z],
                [20.0, 20.0, z],
                [-20.0, 20.0, z],
            ],
            triangles: vec![[0, 1, 2], [0, 2, 3]],
        }
    }

    fn layer(name: &str, z: f32, x0: f32) -> Layer {
        Layer {
            name: name.into(),
            waypoints: (0..5)
                .map(|i| Waypoint {
                    pos: [x0 + i as f32, 0.0, z],
                    dir: [0.0, 0.0, 1.0],
                })
                .collect(),
            surface: Some(plate(z).map_vertices(|v| [v[0] * 0.5 + x0, v[1] * 0.5, v[2]])),
        }
    }

    /// Heights come from the surfaces below, not from the previous layer's
    /// waypoints: a support layer printed in between, elsewhere, does not
    /// matter.
    #[test]
    fn heights_measure_the_surface_below() {
        let tp = Toolpath {
            layers: vec![
                layer("0", 0.6, 0.0),
                // Support, far to the side and higher.
                layer("1S", 5.0, 40.0),
                layer("2", 1.1, 0.0),
            ],
        };
        let scene = Scene::build(
            &tp,
            &cone_head(5.0, 5.0, 10.0, 16),
            &box_mesh([-50.0, -50.0, -1.0], [80.0, 50.0, 0.0]),
            &SceneConfig::default(),
        )
        .unwrap();
        let pos: Vec<[f64; 3]> = tp.iter().map(|(_, w)| w.pos.map(|x| x as f64)).collect();
        let layer_of: Vec<usize> = tp.iter().map(|(k, _)| k).collect();
        let h = layer_heights(&scene, &pos, &layer_of, &tp.layer_offsets(), [0.025, 2.0]);
        // Layer 0 rests on the platform (0.6 mm), layer 2 on layer 0 (0.5 mm).
        assert!((h[0].h - 0.6).abs() < 1e-4 && !h[0].clamped);
        assert!((h[12].h - 0.5).abs() < 1e-4 && !h[12].clamped);
        // The support layer 5 mm up in the air has nothing within 2 mm.
        assert!(h[7].clamped && h[7].h == 2.0);
    }

    /// Whatever triangle the search starts from (one of another layer,
    /// one printed later, one far away, none), it ends at the same
    /// minimum and names a triangle at that distance.
    #[test]
    fn any_hint_gives_the_same_minimum() {
        let job = crate::default_job::job();
        let scene = crate::default_job::scene();
        let starts = job.toolpath.layer_offsets();
        let n = scene.part_tris.len() as u32;
        let mut checked = 0;
        for (g, (k, w)) in job.toolpath.iter().enumerate().step_by(7) {
            let p = w.pos.map(|x| x as f64);
            let cutoff = starts[k] as u32 + 1;
            let (plain, _) = nearest_below(&scene, p, k, cutoff, 4.0, None);
            for hint in [0, (g as u32 * 7919) % n, n - 1] {
                let (d, t) = nearest_below(&scene, p, k, cutoff, 4.0, Some(hint));
                assert_eq!(d, plain, "waypoint {g}, hint {hint}");
                if let Some(t) = t {
                    let t = &scene.part_tris[t as usize];
                    let v = |a: [f32; 3]| a.map(|x| x as f64);
                    assert_eq!(point_triangle_distance(p, v(t.v0), v(t.v1), v(t.v2)), d);
                }
            }
            checked += (plain < 4.0) as usize;
        }
        assert!(checked > 100, "{checked} waypoints over a surface");
    }
}

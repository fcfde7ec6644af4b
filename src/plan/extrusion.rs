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
use crate::scene::slab::{oct_decode, unpack_snorm2x16};
use crate::scene::{bvh, GpuPartNode, Scene};
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
    let below = Below::new(scene, layer_start, LOOKBACK);
    pos.par_iter()
        .zip(layer_of.par_iter())
        .map_init(
            || None,
            |last: &mut Option<u32>, (&p, &k)| {
                let (d, t) = below.nearest(p, k, hi, *last);
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

/// The surfaces a waypoint may rest on: the platform and the layers in
/// the look-back window before its own.
struct Below<'a> {
    scene: &'a Scene,
    /// The global index of each layer's first waypoint.
    layer_start: &'a [usize],
    lookback: usize,
    /// Each node's largest stamp ([`bvh::max_stamps`]): a subtree wholly
    /// older than the window (and without platform, stamp 0) is skipped
    /// at once. The tree keeps each layer's patches apart
    /// ([`crate::scene::bvh`]), so the layers under a waypoint are
    /// subtrees of their own and those past the window cost one visit.
    max_stamp: Vec<u32>,
    /// Each node's slab, decoded once ([`Slab`]).
    slabs: Vec<Slab>,
}

/// A node's slab as [`distance_bound`] reads it: the unit normal and the
/// interval (in units of the node's radius), decoded from the node's
/// words once for the stage instead of at every visit (the decode's
/// square root and division were the walk's slowest steps).
#[derive(Clone, Copy)]
struct Slab {
    normal: [f32; 3],
    range: [f32; 2],
}

impl Slab {
    fn of(node: &GpuPartNode) -> Slab {
        Slab {
            normal: oct_decode(unpack_snorm2x16(node.slab_normal)),
            range: unpack_snorm2x16(node.slab_range),
        }
    }
}

impl<'a> Below<'a> {
    fn new(scene: &'a Scene, layer_start: &'a [usize], lookback: usize) -> Self {
        Below {
            scene,
            layer_start,
            lookback,
            max_stamp: bvh::max_stamps(&scene.part_nodes, &scene.part_tris),
            slabs: scene.part_nodes.par_iter().map(Slab::of).collect(),
        }
    }

    /// The distance from `p` to the nearest triangle of the platform or
    /// of the layers `layer − lookback .. layer` printed before `layer`
    /// starts, if below `limit` (else `limit`), and that triangle. The
    /// search starts from the distance to `hint` (the triangle nearest to
    /// the previous waypoint a worker measured: neighbours rest on the
    /// same surface), so the walk is pruned by their bounds from
    /// its first node (dome_cut's stage 0.48 → 0.45 s). The minimum is the
    /// one a search from `limit` finds, whatever the hint.
    fn nearest(
        &self,
        p: [f64; 3],
        layer: usize,
        limit: f64,
        hint: Option<u32>,
    ) -> (f64, Option<u32>) {
        let scene = self.scene;
        let first = layer.saturating_sub(self.lookback);
        let cutoff = self.layer_start[layer] as u32 + 1;
        // Stamps of layers before the window are at most this.
        let older = self.layer_start[first] as u32;
        let wanted = |l: u32| l == u32::MAX || (l as usize >= first && (l as usize) < layer);
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
        // A node worth a visit: printed before the layer, not wholly
        // older than the window, and nearer than the best so far by its
        // bound (returned, so it is computed once).
        let open = |i: u32, best: f64| {
            let node = &scene.part_nodes[i as usize];
            let too_old = node.min_stamp > 0 && self.max_stamp[i as usize] <= older;
            if node.min_stamp >= cutoff || too_old {
                return None;
            }
            let b = distance_bound(p, node, &self.slabs[i as usize], best);
            (b < best).then_some(b)
        };
        // Nodes with their bounds, nearer child popped first.
        let mut stack: Vec<(u32, f64)> = open(0, best.0).map(|b| (0, b)).into_iter().collect();
        while let Some((i, b)) = stack.pop() {
            if b >= best.0 {
                continue;
            }
            let node = &scene.part_nodes[i as usize];
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
                    let (bl, br) = (open(l, best.0), open(r, best.0));
                    let (near, far) = match (bl, br) {
                        (Some(x), Some(y)) if y < x => ((r, y), Some((l, x))),
                        (Some(x), y) => ((l, x), y.map(|y| (r, y))),
                        (None, Some(y)) => ((r, y), None),
                        (None, None) => continue,
                    };
                    stack.extend(far);
                    stack.push(near);
                }
            }
        }
        best
    }
}

/// A lower bound on the distance from `p` to anything below `node`: the
/// larger of its sphere's and its slab's (every vertex below lies in the
/// sphere and in the slab `lo ≤ n · (x − c) ≤ hi`, so every point of its
/// triangles does); the slab only when the sphere does not already reach
/// `best`, and `best` itself when the sphere clearly does. A waypoint
/// sits a layer height above the patch it rests on and more above the
/// patches of the layers before; the spheres of those patches reach it,
/// their slabs do not.
fn distance_bound(p: [f64; 3], node: &GpuPartNode, slab: &Slab, best: f64) -> f64 {
    let c = node.center.map(|x| x as f64);
    let d = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
    let r = node.radius as f64;
    let d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    // Clearly beyond `best` by the sphere (a relative 1e-9 more than
    // rounding can move the comparison): no square root.
    let reach = best + r;
    if reach >= 0.0 && d2 > reach * reach * (1.0 + 1e-9) {
        return best;
    }
    let sphere = d2.sqrt() - r;
    if sphere >= best {
        return sphere;
    }
    let [lo, hi] = slab.range;
    let n = slab.normal.map(|x| x as f64);
    // `n` is unit up to f32 rounding, and a millionth of the node's reach
    // covers that and the rounding here.
    let along = n[0] * d[0] + n[1] * d[1] + n[2] * d[2];
    let slab = (along - hi as f64 * r).max(lo as f64 * r - along);
    sphere.max(slab - 1e-6 * (r + sphere.abs()))
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
    /// one printed later, one far away, none), it ends at the minimum a
    /// plain loop finds over every triangle of the platform and of the
    /// window's layers printed before the waypoint's layer starts, and
    /// names a triangle at that distance; also with windows short enough
    /// to leave layers out (the subtrees older than the window skipped).
    #[test]
    fn any_hint_gives_the_plain_minimum() {
        let job = crate::default_job::job();
        let scene = crate::default_job::scene();
        let starts = job.toolpath.layer_offsets();
        let layers = job.toolpath.layers.len();
        assert!(layers > 3, "{layers} layers");
        let n = scene.part_tris.len() as u32;
        let v = |a: [f32; 3]| a.map(|x| x as f64);
        let (mut checked, mut skipped) = (0, 0);
        for lookback in [1, 2, LOOKBACK] {
            let below = Below::new(&scene, &starts, lookback);
            for (g, (k, w)) in job.toolpath.iter().enumerate().step_by(37) {
                let p = w.pos.map(|x| x as f64);
                let first = k.saturating_sub(lookback);
                let cutoff = starts[k] as u32 + 1;
                let plain = scene
                    .part_tris
                    .iter()
                    .filter(|t| {
                        t.stamp < cutoff
                            && (t.layer == u32::MAX || (first..k).contains(&(t.layer as usize)))
                    })
                    .map(|t| point_triangle_distance(p, v(t.v0), v(t.v1), v(t.v2)))
                    .fold(4.0, f64::min);
                for hint in [None, Some(0), Some((g as u32 * 7919) % n), Some(n - 1)] {
                    let (d, t) = below.nearest(p, k, 4.0, hint);
                    assert_eq!(
                        d, plain,
                        "waypoint {g}, look-back {lookback}, hint {hint:?}"
                    );
                    if let Some(t) = t {
                        let t = &scene.part_tris[t as usize];
                        assert_eq!(point_triangle_distance(p, v(t.v0), v(t.v1), v(t.v2)), d);
                    }
                }
                checked += (plain < 4.0) as usize;
                skipped += (k > lookback) as usize;
            }
        }
        assert!(
            checked > 30 && skipped > 30,
            "{checked} over a surface, {skipped} with layers left out"
        );
    }
}

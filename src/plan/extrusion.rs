//! Stage 5, extrusion: how much to extrude (paper 000, Eq. 1:
//! `ΔE = k · H · W · L`), summed along each layer's beads, with the
//! layer height `H` measured per waypoint the way the data set's original
//! software does: the distance from the waypoint to the platform and to
//! the surfaces of the previous [`LOOKBACK`] layers, whichever is nearest.
//! Where support and model layers interleave, the layer printed just
//! before is often elsewhere; the surfaces below are what the bead rests
//! on.
//!
//! The distance is a nearest-triangle search over the scene's part BVH
//! (bounding spheres and slabs), skipping subtrees printed after the
//! layer starts and triangles of layers outside the look-back window,
//! started from where the search for the previous waypoint ended (its
//! nearest triangle, and the cut of the tree it stopped at, with bounds
//! that hold a bead away: `Carry`).

use super::graph::Section;
use super::setup::{distance, Setup};
use crate::geometry::point_triangle_distance::point_triangle_distance;
use crate::kinematics::round_written;
use crate::scene::slab::Slab;
use crate::scene::{bvh, cutoff, GpuPartNode, Scene};
use glam::{DVec3, Vec3};
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

/// Stage 5's result: per waypoint, its layer height and its E.
pub(super) struct Extrusion {
    /// Layer height of each waypoint.
    pub heights: Vec<Height>,
    /// Extruder position at each waypoint (mm of filament, absolute within
    /// the layer, as written); 0 where no section visits it.
    pub e: Vec<f64>,
}

/// Stage 5: every waypoint's layer height, within 0.05 to 4 times the
/// machine's default, and E along the beads the `sections` print
/// (paper 000, Eq. 1), from 0 at the start of each layer.
pub(super) fn extrude(setup: &Setup, sections: &[Section]) -> Extrusion {
    let (m, toolpath) = (setup.machine, setup.toolpath);
    let ex = &m.extrusion;
    let d = ex.default_height;
    let heights = layer_heights(
        setup.scene,
        &toolpath.pos,
        &toolpath.layer_of,
        &toolpath.layer_start,
        crate::scene::beads::height_range(d),
    );
    let mut e_at = vec![0.0; toolpath.pos.len()];
    let mut e = 0.0;
    let mut layer = usize::MAX;
    for sec in sections {
        let r = &sec.waypoints;
        let tool = m.tool_for(toolpath.layer_is_support[toolpath.layer_of[r.start]]);
        for (k, g) in r.clone().enumerate() {
            if toolpath.layer_of[g] != layer {
                layer = toolpath.layer_of[g];
                e = 0.0;
            } else if k > 0 && !sec.breaks[k] {
                let h = 0.5 * (heights[g - 1].h + heights[g].h);
                let len = distance(toolpath.pos[g - 1], toolpath.pos[g]);
                e += tool.extrusion * ex.k * h * ex.width * len;
            }
            e_at[g] = round_written(e);
        }
    }
    Extrusion { heights, e: e_at }
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
        .map_init(Carry::default, |carry, (&p, &k)| {
            let d = below.nearest_carried(p, k, hi, carry);
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
        })
        .collect()
}

/// What a worker keeps from its last search ([`Below::nearest_carried`]):
/// the point and layer it measured, the triangle nearest to it, and the
/// *cut* of the tree the search ended at — the subtrees it skipped by
/// their bounds and the leaves it read, each with a lower bound on its
/// distance from that point. Subtrees of no interest to the layer (printed
/// after it starts, or older than its window) are left out, so every
/// triangle the layer may rest on lies below exactly one cut node.
#[derive(Default)]
struct Carry {
    last: Option<([f64; 3], usize)>,
    hint: Option<u32>,
    cut: Vec<(u32, f64)>,
    next: Vec<(u32, f64)>,
    stack: Vec<(u32, f64)>,
    /// The size of the last cut found from the root.
    from_root: usize,
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
}

impl<'a> Below<'a> {
    fn new(scene: &'a Scene, layer_start: &'a [usize], lookback: usize) -> Self {
        Below {
            scene,
            layer_start,
            lookback,
            max_stamp: bvh::max_stamps(&scene.part_nodes, &scene.part_tris),
        }
    }
}

impl Below<'_> {
    /// The distance from `p` (a waypoint of layer `layer`) to the nearest
    /// surface it may rest on, at most `limit`, searched from the cut
    /// `carry` kept of the worker's last search when it was of the same
    /// layer. Distances to a point are 1-Lipschitz, so a bound `b` found
    /// at the last point `q` is at least `b − |p − q|` here: a cut node
    /// whose carried bound still reaches the best distance so far costs a
    /// comparison, and only the others are searched again, each from where
    /// the last search left it (a layer's waypoints follow each other a
    /// bead apart, and the patches under them are the same few leaves).
    /// The minimum is the one a search from the root finds. As in the cpu
    /// collision walk ([`crate::collide::cpu::frontier`]), a cut only gets
    /// finer, so once it has grown by half over the last cut found from
    /// the root, the search starts from the root again.
    fn nearest_carried(&self, p: [f64; 3], layer: usize, limit: f64, carry: &mut Carry) -> f64 {
        let walk = Walk::new(self, p, layer);
        let mut nearest = Nearest {
            distance: limit,
            triangle: None,
        };
        if let Some(k) = carry.hint {
            walk.try_triangle(k, &mut nearest);
        }
        let moved = carry.moved_to(p, layer);
        let Carry {
            cut, next, stack, ..
        } = carry;
        next.clear();
        let roots: &[(u32, f64)] = if moved.is_some() { cut } else { &[(0, 0.0)] };
        for &(root, carried) in roots {
            if let Some(moved) = moved {
                let b = carried - moved;
                if b >= nearest.distance {
                    next.push((root, b));
                    continue;
                }
            }
            let Some(b) = walk.bound(root, nearest.distance) else {
                continue;
            };
            walk.descend((root, b), &mut nearest, stack, next);
        }
        if moved.is_none() {
            carry.from_root = carry.next.len();
        }
        std::mem::swap(&mut carry.cut, &mut carry.next);
        carry.last = Some((p, layer));
        carry.hint = nearest.triangle.or(carry.hint);
        nearest.distance
    }
}

impl Carry {
    /// How far the last search's point lies from `p` (rounded up), when
    /// its cut can start the search for `p` of `layer`: the same layer,
    /// and a cut not grown by half over the last one found from the root.
    fn moved_to(&self, p: [f64; 3], layer: usize) -> Option<f64> {
        match self.last {
            Some((q, l)) if l == layer && 2 * self.cut.len() <= 3 * self.from_root + 32 => {
                let d = DVec3::from(p).distance(DVec3::from(q));
                // (Rounded up for the sums and the square root.)
                Some(d * (1.0 + 1e-12) + 1e-12)
            }
            _ => None,
        }
    }
}

/// The triangle nearest to the point searched so far, and its distance.
struct Nearest {
    distance: f64,
    triangle: Option<u32>,
}

/// One search of [`Below::nearest_carried`]: the point, and which of the
/// scene's material its layer may rest on.
struct Walk<'b> {
    below: &'b Below<'b>,
    p: [f64; 3],
    /// Material printed before the layer starts has stamps below this.
    cutoff: u32,
    /// Subtrees whose stamps all lie at or below this are older than the
    /// look-back window.
    older: u32,
    /// The window's layers: `first..layer`.
    first: usize,
    layer: usize,
}

impl<'b> Walk<'b> {
    fn new(below: &'b Below<'b>, p: [f64; 3], layer: usize) -> Self {
        let first = layer.saturating_sub(below.lookback);
        Walk {
            below,
            p,
            cutoff: cutoff(below.layer_start[layer]),
            older: below.layer_start[first] as u32,
            first,
            layer,
        }
    }

    /// Triangle `k`'s distance from the point, when the layer may rest on
    /// it: the platform (layer `u32::MAX`) or a layer of the window,
    /// printed before the layer starts.
    fn triangle(&self, k: u32) -> Option<f64> {
        let t = &self.below.scene.part_tris[k as usize];
        let in_window = t.layer == u32::MAX
            || (t.layer as usize >= self.first && (t.layer as usize) < self.layer);
        if t.stamp >= self.cutoff || !in_window {
            return None;
        }
        let v = |a: [f32; 3]| a.map(|x| x as f64);
        Some(point_triangle_distance(self.p, v(t.v0), v(t.v1), v(t.v2)))
    }

    /// Triangle `k`, taken as the nearest when it is nearer.
    fn try_triangle(&self, k: u32, nearest: &mut Nearest) -> Option<f64> {
        let d = self.triangle(k)?;
        if d < nearest.distance {
            *nearest = Nearest {
                distance: d,
                triangle: Some(k),
            };
        }
        Some(d)
    }

    /// Node `i`'s bound at the point ([`distance_bound`]), `None` when
    /// nothing below it is of interest to the layer.
    fn bound(&self, i: u32, best: f64) -> Option<f64> {
        let below = self.below;
        let node = &below.scene.part_nodes[i as usize];
        let too_old = node.min_stamp > 0 && below.max_stamp[i as usize] <= self.older;
        if node.min_stamp >= self.cutoff || too_old {
            return None;
        }
        Some(distance_bound(
            self.p,
            node,
            &below.scene.part_slabs[i as usize],
            best,
        ))
    }

    /// Search the subtree `(root, its bound)`, nearer child first, for a
    /// triangle nearer than `nearest`; every node left behind goes into
    /// `cut` with its bound. `stack` is the search's scratch.
    fn descend(
        &self,
        root: (u32, f64),
        nearest: &mut Nearest,
        stack: &mut Vec<(u32, f64)>,
        cut: &mut Vec<(u32, f64)>,
    ) {
        let nodes = &self.below.scene.part_nodes;
        stack.push(root);
        while let Some((i, b)) = stack.pop() {
            if b >= nearest.distance {
                cut.push((i, b));
                continue;
            }
            let node = &nodes[i as usize];
            match node.leaf_range() {
                Some((start, count)) => {
                    let mut leaf = f64::INFINITY;
                    for k in start..start + count {
                        if let Some(d) = self.try_triangle(k, nearest) {
                            leaf = leaf.min(d);
                        }
                    }
                    if leaf < f64::INFINITY {
                        cut.push((i, leaf));
                    }
                }
                None => {
                    let best = nearest.distance;
                    let (l, r) = (node.packed, node.packed + 1);
                    match (self.bound(l, best), self.bound(r, best)) {
                        (Some(x), Some(y)) if y < x => stack.extend([(l, x), (r, y)]),
                        (Some(x), Some(y)) => stack.extend([(r, y), (l, x)]),
                        (Some(x), None) => stack.push((l, x)),
                        (None, Some(y)) => stack.push((r, y)),
                        (None, None) => {}
                    }
                }
            }
        }
    }
}

/// A lower bound on the distance from `p` to anything below `node`: the
/// larger of its sphere's and its slab's (every vertex below lies in the
/// sphere and in the slab `lo ≤ n · (x − c) ≤ hi`, so every point of its
/// triangles does); the slab only when the sphere does not already reach
/// `best`. A waypoint
/// sits a layer height above the patch it rests on and more above the
/// patches of the layers before; the spheres of those patches reach it,
/// their slabs do not.
fn distance_bound(p: [f64; 3], node: &GpuPartNode, slab: &Slab, best: f64) -> f64 {
    let d = DVec3::from(p) - Vec3::from(node.center).as_dvec3();
    let r = node.radius as f64;
    // (No shortcut past the square root when the sphere clearly lies
    // beyond `best`: the bound is carried to the next waypoint, where
    // the true one saves a search.)
    let sphere = d.length() - r;
    if sphere >= best {
        return sphere;
    }
    let [lo, hi] = slab.range;
    let n = Vec3::from(slab.normal).as_dvec3();
    // `n` is unit up to f32 rounding, and a millionth of the node's reach
    // covers that and the rounding here.
    let along = n.dot(d);
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

    /// Whatever the search starts from — the cut of the waypoint before
    /// (of the same layer or of another), of a waypoint far away, or
    /// nothing, with any triangle as the hint (one of another layer, one
    /// printed later, one far away, none) — it ends at the minimum a plain
    /// loop finds over every triangle of the platform and of the window's
    /// layers printed before the waypoint's layer starts; also with
    /// windows short enough to leave layers out (the subtrees older than
    /// the window skipped), and across the resets of a growing cut.
    #[test]
    fn carried_searches_give_the_plain_minimum() {
        let job = crate::default_job::job();
        let scene = crate::default_job::scene();
        let starts = job.toolpath.layer_offsets();
        let layers = job.toolpath.layers.len();
        assert!(layers > 3, "{layers} layers");
        let n = scene.part_tris.len() as u32;
        let v = |a: [f32; 3]| a.map(|x| x as f64);
        let points: Vec<(usize, [f64; 3])> = job
            .toolpath
            .iter()
            .map(|(k, w)| (k, w.pos.map(|x| x as f64)))
            .collect();
        let plain = |k: usize, p: [f64; 3], lookback: usize| {
            let first = k.saturating_sub(lookback);
            let cutoff = cutoff(starts[k]);
            scene
                .part_tris
                .iter()
                .filter(|t| {
                    t.stamp < cutoff
                        && (t.layer == u32::MAX || (first..k).contains(&(t.layer as usize)))
                })
                .map(|t| point_triangle_distance(p, v(t.v0), v(t.v1), v(t.v2)))
                .fold(4.0, f64::min)
        };
        let (mut checked, mut skipped, mut carried, mut resets) = (0, 0, 0, 0);
        for lookback in [1, 2, LOOKBACK] {
            let below = Below::new(&scene, &starts, lookback);
            // In print order, one carry throughout; then in strides, so
            // that each search starts from a cut found far away.
            for stride in [1, 37] {
                let mut carry = Carry::default();
                for (g, &(k, p)) in points.iter().enumerate().step_by(stride) {
                    let want = plain(k, p, lookback);
                    let from_root = carry.from_root;
                    let same_layer = carry.last.is_some_and(|(_, l)| l == k);
                    assert_eq!(
                        below.nearest_carried(p, k, 4.0, &mut carry),
                        want,
                        "waypoint {g}, look-back {lookback}, stride {stride}"
                    );
                    carried += same_layer as usize;
                    resets += (same_layer && carry.from_root != from_root) as usize;
                    checked += (want < 4.0) as usize;
                    skipped += (k > lookback) as usize;
                }
            }
            for (g, &(k, p)) in points.iter().enumerate().step_by(37) {
                let want = plain(k, p, lookback);
                for hint in [None, Some(0), Some((g as u32 * 7919) % n), Some(n - 1)] {
                    let mut carry = Carry {
                        hint,
                        ..Carry::default()
                    };
                    assert_eq!(
                        below.nearest_carried(p, k, 4.0, &mut carry),
                        want,
                        "waypoint {g}, look-back {lookback}, hint {hint:?}"
                    );
                    if let Some(t) = carry.hint.filter(|_| want < 4.0) {
                        let t = &scene.part_tris[t as usize];
                        assert_eq!(point_triangle_distance(p, v(t.v0), v(t.v1), v(t.v2)), want);
                    }
                }
            }
        }
        assert!(
            checked > 1000 && skipped > 1000 && carried > 1000 && resets > 3,
            "{checked} over a surface, {skipped} with layers left out, \
             {carried} from the last cut, {resets} cuts reset"
        );
    }
}

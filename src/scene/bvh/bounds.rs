//! What each node of a laid-out tree bounds, from the triangles below it:
//! its box, its smallest and largest stamp, its span of triangles, and the
//! bounding sphere the part's walk tests.

use super::super::gpu_types::{GpuNode, GpuPartNode, GpuTriangle};
use super::StampedBvh;
use rayon::prelude::*;

/// A value per node from the leaves up: `leaf(first, count)` for a leaf,
/// `join` of its children's for an inner node; `packed(i)` is node `i`'s
/// [`GpuNode`] word (child index or leaf range). The depth-first layout
/// ([`super::layout::lay_out`]) stores every child after its parent, so one sweep
/// back from the last node meets the children first.
fn bottom_up<T: Copy + Default>(
    n: usize,
    packed: impl Fn(usize) -> u32,
    leaf: impl Fn(u32, u32) -> T,
    join: impl Fn(T, T) -> T,
) -> Vec<T> {
    let mut out = vec![T::default(); n];
    for i in (0..n).rev() {
        let node = GpuNode {
            packed: packed(i),
            ..GpuNode::default()
        };
        out[i] = match node.leaf_range() {
            Some((first, count)) => leaf(first, count),
            None => {
                let l = node.packed as usize;
                join(out[l], out[l + 1])
            }
        };
    }
    out
}

/// Every node's box: the smallest that holds the triangles below it (the
/// build's boxes are those of the lifted triangles).
pub(super) fn fit_boxes(nodes: &mut [GpuNode], tris: &[GpuTriangle]) {
    type Box3 = ([f32; 3], [f32; 3]);
    let union = |(a, b): Box3, (c, d): Box3| -> Box3 {
        (
            [0, 1, 2].map(|k| a[k].min(c[k])),
            [0, 1, 2].map(|k| b[k].max(d[k])),
        )
    };
    let leaf = |first: u32, count: u32| {
        tris[first as usize..(first + count) as usize]
            .iter()
            .flat_map(|t| [t.v0, t.v1, t.v2])
            .fold(([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]), |b, v| {
                union(b, (v, v))
            })
    };
    let boxes = bottom_up(nodes.len(), |i| nodes[i].packed, leaf, union);
    for (n, (min, max)) in nodes.iter_mut().zip(boxes) {
        n.min = min;
        n.max = max;
    }
}

/// Every node's smallest stamp below it, for `n` nodes given by their
/// `packed` words over `tris`.
pub(super) fn min_stamps(
    n: usize,
    packed: impl Fn(usize) -> u32,
    tris: &[GpuTriangle],
) -> Vec<u32> {
    let leaf = |first: u32, count: u32| {
        (first..first + count)
            .map(|t| tris[t as usize].stamp)
            .min()
            .unwrap_or(u32::MAX)
    };
    bottom_up(n, packed, leaf, u32::min)
}

/// Every node's largest stamp below it: a subtree whose stamps all lie
/// before some point of the print holds nothing printed after it.
pub fn max_stamps(nodes: &[GpuPartNode], tris: &[GpuTriangle]) -> Vec<u32> {
    let leaf = |first: u32, count: u32| {
        (first..first + count)
            .map(|t| tris[t as usize].stamp)
            .max()
            .unwrap_or(0)
    };
    bottom_up(nodes.len(), |i| nodes[i].packed, leaf, u32::max)
}

/// Recompute every node's minimum stamp from `tris` (after the
/// triangles' stamps changed; the tree itself is kept).
pub fn refresh_min_stamps(nodes: &mut [GpuPartNode], tris: &[GpuTriangle]) {
    let mins = min_stamps(nodes.len(), |i| nodes[i].packed, tris);
    for (n, m) in nodes.iter_mut().zip(mins) {
        n.min_stamp = m;
    }
}

/// Each node's triangles as `(first, end)` in [`StampedBvh::triangles`]:
/// the depth-first layout ([`super::layout::lay_out`]) numbers a subtree's leaves
/// one after another, so a subtree's triangles are one contiguous run.
pub(crate) fn triangle_spans(nodes: &[GpuNode]) -> Vec<(u32, u32)> {
    bottom_up(
        nodes.len(),
        |i| nodes[i].packed,
        |first, count| (first, first + count),
        |a, b| (a.0.min(b.0), a.1.max(b.1)),
    )
}

/// Every triangle vertex of a span ([`triangle_spans`]).
pub(crate) fn vertices_in(
    bvh: &StampedBvh,
    (first, end): (u32, u32),
) -> impl Iterator<Item = [f32; 3]> + '_ {
    bvh.triangles[first as usize..end as usize]
        .iter()
        .flat_map(|t| [t.v0, t.v1, t.v2])
}

/// Subtrees of at most this many triangles get the exact radius; above,
/// a node's radius is the tighter of its box's and its children's spheres'
/// bound (every node's span would cost O(n log n) vertex visits).
const EXACT_SPHERE_TRIS: u32 = 64;

/// The same tree as bounding spheres: centre = box centre, radius = the
/// farthest vertex below (exact for subtrees of at most
/// `EXACT_SPHERE_TRIS` triangles, a bound from the children's spheres
/// and the box above), computed in `f64` and rounded up so the sphere
/// always contains every triangle.
pub fn sphere_nodes(bvh: &StampedBvh) -> Vec<GpuPartNode> {
    let nodes = &bvh.nodes;
    let mut out: Vec<GpuPartNode> = nodes
        .iter()
        .map(|n| GpuPartNode {
            center: [
                (n.min[0] + n.max[0]) * 0.5,
                (n.min[1] + n.max[1]) * 0.5,
                (n.min[2] + n.max[2]) * 0.5,
            ],
            packed: n.packed,
            radius: 0.0,
            min_stamp: n.min_stamp,
            slab_normal: 0,
            slab_range: 0,
        })
        .collect();
    let spans = triangle_spans(nodes);
    let round_up = |r2: f64| (r2.sqrt() as f32).next_up();
    // Exact radii of the small subtrees, over their vertices.
    let exact: Vec<Option<f32>> = (0..nodes.len())
        .into_par_iter()
        .map(|i| {
            let (first, end) = spans[i];
            if end - first > EXACT_SPHERE_TRIS {
                return None;
            }
            let c = out[i].center.map(|x| x as f64);
            let r2 = vertices_in(bvh, spans[i])
                .map(|v| (0..3).map(|k| (v[k] as f64 - c[k]).powi(2)).sum::<f64>())
                .fold(0.0f64, f64::max);
            Some(round_up(r2))
        })
        .collect();
    // The large ones, children first: every vertex below lies in the box
    // and in a child's sphere.
    for i in (0..nodes.len()).rev() {
        out[i].radius = match exact[i] {
            Some(r) => r,
            None => {
                let c = out[i].center.map(|x| x as f64);
                let n = &nodes[i];
                let corner: f64 = (0..3)
                    .map(|k| {
                        let lo = (n.min[k] as f64 - c[k]).abs();
                        let hi = (n.max[k] as f64 - c[k]).abs();
                        lo.max(hi).powi(2)
                    })
                    .sum();
                let l = n.packed as usize;
                let via = |j: usize| {
                    let d: f64 = (0..3)
                        .map(|k| (out[j].center[k] as f64 - c[k]).powi(2))
                        .sum();
                    d.sqrt() + out[j].radius as f64
                };
                let child = via(l).max(via(l + 1));
                round_up(corner.min(child * child))
            }
        };
    }
    out
}

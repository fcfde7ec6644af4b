//! Builds the GPU-ready BVH over stamped triangles with `obvhs` (PLOC), then
//! re-lays it out as [`GpuNode`]s whose `min_stamp` lets a query skip every
//! subtree printed after its cutoff.

use super::gpu_types::STACK_SIZE;
use super::gpu_types::{GpuNode, GpuPartNode, GpuTriangle, MAX_LEAF_TRIS, MAX_TRIS};
use super::SceneError;
use obvhs::bvh2::builder::build_bvh2_from_tris;
use obvhs::triangle::Triangle;
use obvhs::BvhBuildParams;
use std::time::Duration;

/// A BVH and its triangles, reordered so each leaf's triangles are contiguous.
#[derive(Clone, Debug)]
pub struct StampedBvh {
    /// Nodes; the root is node 0.
    pub nodes: Vec<GpuNode>,
    /// Triangles in leaf order.
    pub triangles: Vec<GpuTriangle>,
}

/// Build over `tris` (any order). `max_leaf` ≤ 16 triangles per leaf.
pub fn build(tris: &[GpuTriangle], max_leaf: u32) -> Result<StampedBvh, SceneError> {
    if tris.is_empty() {
        return Err(SceneError::Empty("the scene has no triangles".into()));
    }
    if tris.len() as u64 >= MAX_TRIS as u64 {
        return Err(SceneError::TooLarge(tris.len()));
    }
    let obv: Vec<Triangle> = tris
        .iter()
        .map(|t| Triangle {
            v0: t.v0.into(),
            v1: t.v1.into(),
            v2: t.v2.into(),
        })
        .collect();
    // obvhs's fast preset: against medium_build, dome_cut's build 2.5 →
    // 1.9 s, and whole plans 5–10 % faster on every shared model (paired
    // runs, BENCHMARKS.md); very_fast_build's tree costs the queries more
    // than its build saves.
    let mut params = BvhBuildParams::fast_build();
    params.max_prims_per_leaf = max_leaf.min(MAX_LEAF_TRIS);
    let bvh = build_bvh2_from_tris(&obv, params, &mut Duration::default());
    drop(obv);

    let mut nodes = Vec::with_capacity(bvh.nodes.len());
    for n in &bvh.nodes {
        let packed = if n.prim_count > 0 {
            if n.prim_count > MAX_LEAF_TRIS {
                return Err(SceneError::Internal(format!(
                    "BVH leaf with {} triangles (max {MAX_LEAF_TRIS})",
                    n.prim_count
                )));
            }
            GpuNode::pack_leaf(n.first_index, n.prim_count)
        } else {
            n.first_index
        };
        nodes.push(GpuNode {
            min: n.aabb.min.into(),
            packed,
            max: n.aabb.max.into(),
            min_stamp: u32::MAX,
        });
    }
    // Leaf ranges index `primitive_indices`; laid out depth first they
    // index the triangles, gathered once in that order.
    let (mut nodes, order) = depth_first(&nodes);
    let triangles: Vec<GpuTriangle> = order
        .iter()
        .map(|&k| tris[bvh.primitive_indices[k as usize] as usize])
        .collect();
    drop(bvh);
    let packed: Vec<u32> = nodes.iter().map(|n| n.packed).collect();
    for (n, m) in nodes.iter_mut().zip(min_stamps(&packed, &triangles)) {
        n.min_stamp = m;
    }
    // Traversal keeps at most depth + 1 entries on its fixed-size stack.
    let mut depth = vec![0u32; nodes.len()];
    let mut max_depth = 0;
    let mut stack = vec![0usize];
    while let Some(i) = stack.pop() {
        max_depth = max_depth.max(depth[i]);
        if nodes[i].leaf_range().is_none() {
            let l = nodes[i].packed as usize;
            depth[l] = depth[i] + 1;
            depth[l + 1] = depth[i] + 1;
            stack.extend([l, l + 1]);
        }
    }
    if max_depth as usize + 2 > STACK_SIZE {
        return Err(SceneError::Internal(format!(
            "BVH depth {max_depth} exceeds the traversal stack ({STACK_SIZE})"
        )));
    }
    Ok(StampedBvh { nodes, triangles })
}

/// The same tree laid out depth first: each pair of children stored after
/// the subtree of the pair before it, so a walk down the tree reads memory
/// forward, and leaves renumbered in the order the walk meets them.
/// Returns the nodes and, for each new leaf slot, the old one (the caller
/// gathers the triangles in that order). PLOC and reinsertion leave the
/// nodes in build order, where a parent and its children can lie
/// megabytes apart; a query's few hundred node visits were cache misses.
/// The tree (and so every traversal's sequence of nodes) is unchanged.
fn depth_first(nodes: &[GpuNode]) -> (Vec<GpuNode>, Vec<u32>) {
    let mut out = vec![GpuNode::default(); nodes.len()];
    let mut order = Vec::new();
    out[0] = nodes[0];
    let mut next = 1usize;
    // (old index, new index), left children popped first.
    let mut stack = vec![(0usize, 0usize)];
    while let Some((old, new)) = stack.pop() {
        match nodes[old].leaf_range() {
            Some((first, count)) => {
                let start = order.len() as u32;
                order.extend(first..first + count);
                out[new].packed = GpuNode::pack_leaf(start, count);
            }
            None => {
                let l = nodes[old].packed as usize;
                out[next] = nodes[l];
                out[next + 1] = nodes[l + 1];
                out[new].packed = next as u32;
                stack.extend([(l + 1, next + 1), (l, next)]);
                next += 2;
            }
        }
    }
    out.truncate(next);
    (out, order)
}

/// Every node's smallest stamp below it, for nodes given by their
/// `packed` words ([`GpuNode`] layout: child index or leaf range) over
/// `tris`: one sweep from the last node back, since the depth-first layout
/// ([`depth_first`]) stores every child after its parent.
fn min_stamps(packed: &[u32], tris: &[GpuTriangle]) -> Vec<u32> {
    let mut out = vec![u32::MAX; packed.len()];
    for i in (0..packed.len()).rev() {
        let node = GpuNode {
            packed: packed[i],
            ..GpuNode::default()
        };
        out[i] = match node.leaf_range() {
            Some((first, count)) => (first..first + count)
                .map(|t| tris[t as usize].stamp)
                .min()
                .unwrap_or(u32::MAX),
            None => {
                let l = packed[i] as usize;
                out[l].min(out[l + 1])
            }
        };
    }
    out
}

/// Recompute every node's minimum stamp from `tris` (after the
/// triangles' stamps changed; the tree itself is kept).
pub fn refresh_min_stamps(nodes: &mut [GpuPartNode], tris: &[GpuTriangle]) {
    let packed: Vec<u32> = nodes.iter().map(|n| n.packed).collect();
    for (n, m) in nodes.iter_mut().zip(min_stamps(&packed, tris)) {
        n.min_stamp = m;
    }
}

/// Triangles below each node, children first: walking back from the
/// last node, since the depth-first layout ([`depth_first`]) stores every
/// child after its parent.
pub(crate) fn subtree_counts(nodes: &[GpuNode]) -> Vec<u32> {
    let mut count = vec![0u32; nodes.len()];
    for i in (0..nodes.len()).rev() {
        count[i] = match nodes[i].leaf_range() {
            Some((_, c)) => c,
            None => {
                let l = nodes[i].packed as usize;
                count[l] + count[l + 1]
            }
        };
    }
    count
}

/// `f` of every triangle vertex below node `i` (by descent).
pub(crate) fn for_each_vertex_below(bvh: &StampedBvh, i: usize, mut f: impl FnMut([f32; 3])) {
    let mut stack = vec![i];
    while let Some(j) = stack.pop() {
        match bvh.nodes[j].leaf_range() {
            Some((first, count)) => {
                for t in &bvh.triangles[first as usize..(first + count) as usize] {
                    f(t.v0);
                    f(t.v1);
                    f(t.v2);
                }
            }
            None => {
                let l = bvh.nodes[j].packed as usize;
                stack.extend([l, l + 1]);
            }
        }
    }
}

/// Subtrees of at most this many triangles get the exact radius; above,
/// a node's radius is the tighter of its box's and its children's spheres'
/// bound (a descent from every node would cost O(n log n) vertex visits).
const EXACT_SPHERE_TRIS: u32 = 64;

/// The same tree as bounding spheres: centre = box centre, radius = the
/// farthest vertex below (exact for subtrees of at most
/// [`EXACT_SPHERE_TRIS`] triangles, a bound from the children's spheres
/// and the box above), computed in `f64` and rounded up so the sphere
/// always contains every triangle.
pub fn sphere_nodes(bvh: &StampedBvh) -> Vec<GpuPartNode> {
    use rayon::prelude::*;
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
    let count = subtree_counts(nodes);
    let round_up = |r2: f64| (r2.sqrt() as f32).next_up();
    // Exact radii of the small subtrees, by descent.
    let exact: Vec<Option<f32>> = (0..nodes.len())
        .into_par_iter()
        .map(|i| {
            if count[i] > EXACT_SPHERE_TRIS {
                return None;
            }
            let c = out[i].center.map(|x| x as f64);
            let mut r2: f64 = 0.0;
            for_each_vertex_below(bvh, i, |v| {
                let d: f64 = (0..3).map(|k| (v[k] as f64 - c[k]).powi(2)).sum();
                r2 = r2.max(d);
            });
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A soup of small triangles scattered over a box, stamps in a
    /// different order than space.
    fn soup(n: u32) -> Vec<GpuTriangle> {
        let mut h = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            h ^= h << 13;
            h ^= h >> 7;
            h ^= h << 17;
            (h >> 11) as f32 / (1u64 << 53) as f32
        };
        (0..n)
            .map(|i| {
                let c = [next() * 80.0, next() * 80.0, next() * 20.0];
                let mut v = |k: f32| [c[0] + k * next(), c[1] + k * next(), c[2] + k * next()];
                GpuTriangle {
                    v0: v(1.0),
                    stamp: (i * 7919) % n + 1,
                    v1: v(1.5),
                    layer: 0,
                    v2: v(2.0),
                    source: i,
                }
            })
            .collect()
    }

    /// Walking the tree depth first (left child first) meets the pairs of
    /// children at increasing indices, one after another, and the leaves'
    /// triangles in storage order; every triangle is in exactly one leaf,
    /// and every node's stamp is the smallest below it.
    #[test]
    fn nodes_and_triangles_are_laid_out_depth_first() {
        let tris = soup(5000);
        let bvh = build(&tris, 4).unwrap();
        let (mut pairs, mut leaf_tris) = (Vec::new(), Vec::new());
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            let n = bvh.nodes[i];
            match n.leaf_range() {
                Some((first, count)) => {
                    leaf_tris.extend(first..first + count);
                    let below = bvh.triangles[first as usize..(first + count) as usize]
                        .iter()
                        .map(|t| t.stamp)
                        .min();
                    assert_eq!(Some(n.min_stamp), below);
                }
                None => {
                    let l = n.packed as usize;
                    pairs.push(l);
                    assert_eq!(
                        n.min_stamp,
                        bvh.nodes[l].min_stamp.min(bvh.nodes[l + 1].min_stamp)
                    );
                    stack.extend([l + 1, l]);
                }
            }
        }
        let expected: Vec<usize> = (0..pairs.len()).map(|k| 1 + 2 * k).collect();
        assert_eq!(pairs, expected, "pairs of children in walk order");
        assert_eq!(bvh.nodes.len(), 1 + 2 * pairs.len());
        let order: Vec<u32> = (0..tris.len() as u32).collect();
        assert_eq!(leaf_tris, order, "triangles in the order leaves are met");
        let mut sources: Vec<u32> = bvh.triangles.iter().map(|t| t.source).collect();
        sources.sort();
        assert_eq!(sources, order);
    }
}

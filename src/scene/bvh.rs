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
    let mut params = BvhBuildParams::medium_build();
    params.max_prims_per_leaf = max_leaf.min(MAX_LEAF_TRIS);
    let bvh = build_bvh2_from_tris(&obv, params, &mut Duration::default());

    let triangles: Vec<GpuTriangle> = bvh
        .primitive_indices
        .iter()
        .map(|&i| tris[i as usize])
        .collect();
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

/// Every node's smallest stamp below it, for nodes given by their
/// `packed` words ([`GpuNode`] layout: child index or leaf range) over
/// `tris`: a post-order sweep (explicit stack: obvhs' reinsertion may
/// place a child before its parent).
fn min_stamps(packed: &[u32], tris: &[GpuTriangle]) -> Vec<u32> {
    let leaf = |i: usize| {
        GpuNode {
            packed: packed[i],
            ..GpuNode::default()
        }
        .leaf_range()
    };
    let mut out = vec![u32::MAX; packed.len()];
    let mut stack = vec![(0usize, false)];
    while let Some((i, children_done)) = stack.pop() {
        match leaf(i) {
            Some((first, count)) => {
                out[i] = (first..first + count)
                    .map(|t| tris[t as usize].stamp)
                    .min()
                    .unwrap_or(u32::MAX);
            }
            None => {
                let l = packed[i] as usize;
                if children_done {
                    out[i] = out[l].min(out[l + 1]);
                } else {
                    stack.extend([(i, true), (l, false), (l + 1, false)]);
                }
            }
        }
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
            _pad: [0; 2],
        })
        .collect();
    // Children before parents (obvhs may store a child before its parent).
    let mut post = Vec::with_capacity(nodes.len());
    let mut stack = vec![(0usize, false)];
    while let Some((i, done)) = stack.pop() {
        match nodes[i].leaf_range() {
            Some(_) => post.push(i),
            None if done => post.push(i),
            None => {
                let l = nodes[i].packed as usize;
                stack.extend([(i, true), (l, false), (l + 1, false)]);
            }
        }
    }
    let mut count = vec![0u32; nodes.len()];
    for &i in &post {
        count[i] = match nodes[i].leaf_range() {
            Some((_, c)) => c,
            None => {
                let l = nodes[i].packed as usize;
                count[l] + count[l + 1]
            }
        };
    }
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
            let mut stack = vec![i];
            while let Some(j) = stack.pop() {
                match nodes[j].leaf_range() {
                    Some((first, count)) => {
                        for t in &bvh.triangles[first as usize..(first + count) as usize] {
                            for v in [t.v0, t.v1, t.v2] {
                                let d: f64 = (0..3).map(|k| (v[k] as f64 - c[k]).powi(2)).sum();
                                r2 = r2.max(d);
                            }
                        }
                    }
                    None => {
                        let l = nodes[j].packed as usize;
                        stack.extend([l, l + 1]);
                    }
                }
            }
            Some(round_up(r2))
        })
        .collect();
    // The large ones, children first: every vertex below lies in the box
    // and in a child's sphere.
    for &i in &post {
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

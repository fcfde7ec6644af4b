//! Builds the GPU-ready BVH over stamped triangles with `obvhs` (PLOC), then
//! re-lays it out as [`GpuNode`]s whose `min_stamp` lets a query skip every
//! subtree printed after its cutoff.
//!
//! The tree is built over the triangles *lifted by their layer*: layer `k`
//! raised `k · layer_lift` along z (the platform one step below layer 0)
//! for the build only; every node's box is then fitted to the true
//! triangles below it. Built in true space, PLOC pairs each triangle with
//! its neighbours in the layers just above and below, so the nodes around
//! the nozzle mix what is printed with what is not (the next layers cross
//! the head): a query descends them to the leaves to tell the two apart.
//! Lifted, the small nodes hold one layer each — a thin patch, which
//! their slabs settle, and whose stamps a cutoff skips at once — while
//! nodes larger than the lift still group stacked layers, so material far
//! from the head is culled as before. The verdicts do not depend on the
//! tree, only the work does (paired runs in BENCHMARKS.md).

use super::gpu_types::STACK_SIZE;
use super::gpu_types::{GpuNode, GpuPartNode, GpuTriangle, MAX_LEAF_TRIS, MAX_TRIS};
use super::SceneError;
use obvhs::bvh2::reinsertion::ReinsertionOptimizer;
use obvhs::bvh2::Bvh2;
use obvhs::ploc::PlocBuilder;
use obvhs::triangle::Triangle;
use obvhs::BvhBuildParams;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

/// A BVH and its triangles, reordered so each leaf's triangles are contiguous.
#[derive(Clone, Debug)]
pub struct StampedBvh {
    /// Nodes; the root is node 0.
    pub nodes: Vec<GpuNode>,
    /// Triangles in leaf order.
    pub triangles: Vec<GpuTriangle>,
}

/// How far each layer is lifted above the last for the build (module
/// comment), as a fraction of the head's extent: the scale at which the
/// walk culls material is the head's. On dome_cut (head 40 mm) lifts from
/// 2 to 40 mm all took the query stages' CPU time down by 15–25 %, 1000
/// mm (layers wholly apart) by none; an eighth of the head, the
/// subdivision length, sits inside that range.
pub const LAYER_LIFT_PER_HEAD: f32 = 1.0 / 8.0;

/// Build over `tris` (any order), layer `k` lifted by `k · layer_lift`
/// (mm) for the build only (module comment; 0 builds in true space).
/// `max_leaf` ≤ 16 triangles per leaf.
pub fn build(
    tris: &[GpuTriangle],
    max_leaf: u32,
    layer_lift: f32,
) -> Result<StampedBvh, SceneError> {
    if tris.is_empty() {
        return Err(SceneError::Empty("the scene has no triangles".into()));
    }
    if tris.len() as u64 >= MAX_TRIS as u64 {
        return Err(SceneError::TooLarge(tris.len()));
    }
    // obvhs's fast preset: against medium_build, dome_cut's build 2.5 →
    // 1.9 s, and whole plans 5–10 % faster on every shared model (paired
    // runs, BENCHMARKS.md); very_fast_build's tree costs the queries more
    // than its build saves.
    let mut params = BvhBuildParams::fast_build();
    params.max_prims_per_leaf = max_leaf.min(MAX_LEAF_TRIS);
    let bvh = uncollapsed(tris, layer_lift, &params);
    let collapse = Collapse {
        max_prims: params.max_prims_per_leaf,
        traversal_cost: params.collapse_traversal_cost,
    };
    // Leaf ranges index `primitive_indices`; laid out depth first they
    // index the triangles, gathered once in that order.
    let (mut nodes, order, max_depth) = lay_out(&bvh, collapse)?;
    let triangles: Vec<GpuTriangle> = order
        .par_iter()
        .map(|&k| tris[bvh.primitive_indices[k as usize] as usize])
        .collect();
    drop(bvh);
    fit_boxes(&mut nodes, &triangles);
    let mins = min_stamps(nodes.len(), |i| nodes[i].packed, &triangles);
    for (n, m) in nodes.iter_mut().zip(mins) {
        n.min_stamp = m;
    }
    // Traversal keeps at most depth + 1 entries on its fixed-size stack.
    if max_depth + 2 > STACK_SIZE {
        return Err(too_deep(max_depth));
    }
    Ok(StampedBvh { nodes, triangles })
}

/// obvhs's tree over `tris`, layer `k` lifted by `k · layer_lift` (the
/// platform one step below layer 0), built as obvhs's
/// `build_bvh2_from_tris` builds it with `params` but for the leaf
/// collapse, which the layout does on its way ([`lay_out`]): PLOC, then
/// reinsertion (the second reinsertion pass, after the collapse, has a
/// batch of 0 in the fast preset: none).
fn uncollapsed(tris: &[GpuTriangle], layer_lift: f32, params: &BvhBuildParams) -> Bvh2 {
    let obv: Vec<Triangle> = tris
        .par_iter()
        .map(|t| {
            let lift = match t.layer {
                u32::MAX => -layer_lift,
                k => k as f32 * layer_lift,
            };
            let up = |v: [f32; 3]| [v[0], v[1], v[2] + lift].into();
            Triangle {
                v0: up(t.v0),
                v1: up(t.v1),
                v2: up(t.v2),
            }
        })
        .collect();
    let mut bvh = PlocBuilder::with_capacity(obv.len()).build(
        params.ploc_search_distance,
        &obv,
        (0..obv.len() as u32).collect(),
        params.sort_precision,
        params.search_depth_threshold,
    );
    drop(obv);
    ReinsertionOptimizer::default().run(&mut bvh, params.reinsertion_batch_ratio, None);
    bvh
}

/// obvhs's SAH leaf collapse (`obvhs::bvh2::leaf_collapser::collapse`,
/// its rule and arithmetic in version 0.4): from the leaves up, a node
/// whose children are both leaves of together at most `max_prims`
/// triangles becomes one leaf when its box's half area times
/// (`count − traversal_cost`) is no more than its children's half areas
/// times their counts. (obvhs also joins two leaves holding the same
/// primitive, which only its spatial splits make.)
#[derive(Clone, Copy, Debug)]
struct Collapse {
    max_prims: u32,
    traversal_cost: f32,
}

impl Collapse {
    /// Does it leave `bvh` as it is (obvhs's early returns: trees too
    /// small to collapse)?
    fn skips(&self, bvh: &Bvh2) -> bool {
        self.max_prims <= 1
            || bvh.nodes.len() as u32 <= self.max_prims * 2 + 1
            || bvh.primitive_indices.len() as u32 <= self.max_prims
            || bvh.nodes[0].is_leaf()
    }

    /// The triangles inner node `i` holds as a leaf once collapsed, its
    /// children holding `lc` and `rc` as leaves (0: inner); 0 if it
    /// stays inner.
    fn count(&self, bvh: &Bvh2, i: usize, lc: u32, rc: u32) -> u32 {
        let total = lc + rc;
        if lc == 0 || rc == 0 || total > self.max_prims {
            return 0;
        }
        let node = &bvh.nodes[i];
        let l = node.first_index as usize;
        let (left, right) = (&bvh.nodes[l], &bvh.nodes[l + 1]);
        let collapse_cost = node.aabb.half_area() * (total as f32 - self.traversal_cost);
        let base_cost = left.aabb.half_area() * lc as f32 + right.aabb.half_area() * rc as f32;
        if collapse_cost <= base_cost {
            total
        } else {
            0
        }
    }
}

/// What the layout needs of a subtree of the collapsed tree: the
/// triangles its root holds as a leaf (0: inner), its leaves and its
/// triangles — packed in one word per node of obvhs's tree (8, 27 and 27
/// bits: [`MAX_TRIS`] is 2²⁷).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Subtree {
    count: u32,
    leaves: u32,
    prims: u32,
}

impl Subtree {
    fn pack(self) -> u64 {
        (self.count as u64) << 54 | (self.leaves as u64) << 27 | self.prims as u64
    }

    fn unpack(w: u64) -> Subtree {
        let field = (1u64 << 27) - 1;
        Subtree {
            count: (w >> 54) as u32,
            leaves: ((w >> 27) & field) as u32,
            prims: (w & field) as u32,
        }
    }

    /// Nodes below its root in the laid-out tree (`2 · leaves − 1` in
    /// all).
    fn descendants(&self) -> usize {
        2 * self.leaves as usize - 2
    }
}

/// The measuring walk splits between threads down to this depth (sizes
/// are known only on the way back up); the writing walk splits subtrees
/// of more than [`PARALLEL_PRIMS`] triangles.
const PARALLEL_DEPTH: usize = 8;

/// See [`PARALLEL_DEPTH`].
const PARALLEL_PRIMS: u32 = 1 << 14;

/// obvhs's tree `bvh`, collapsed ([`Collapse`]) and laid out depth first:
/// each pair of children stored after the subtree of the pair before it,
/// so a walk down the tree reads memory forward, and leaves renumbered in
/// the order the walk meets them. Returns the nodes (boxes as built, no
/// stamps yet), for each new leaf slot the slot of
/// `bvh.primitive_indices` it holds (the caller gathers the triangles in
/// that order), and the deepest node's depth. PLOC and reinsertion leave
/// the nodes in build order, where a parent and its children can lie
/// megabytes apart: a query's few hundred node visits were cache misses.
///
/// Two walks over obvhs's nodes, each with large subtrees' halves on
/// different threads: the first measures every subtree from the leaves
/// up ([`measure`], the collapse included), the second writes each
/// subtree into the slots the first found for it ([`write`]). obvhs's
/// own collapse rebuilds its node array and parent links, and with the
/// copy and walk this replaces took longer (dome_cut's 2.2 M-triangle
/// build on two cores: 0.60 → 0.35 s); the tree, and so the layout, are
/// the same (test `the_layout_walks_obvhs_collapsed_tree`).
fn lay_out(bvh: &Bvh2, collapse: Collapse) -> Result<(Vec<GpuNode>, Vec<u32>, usize), SceneError> {
    let measured: Vec<AtomicU64> = (0..bvh.nodes.len()).map(|_| AtomicU64::new(0)).collect();
    let rule = (!collapse.skips(bvh)).then_some(collapse);
    let root = measure(bvh, 0, 0, rule, &measured)?;
    let mut nodes = vec![GpuNode::default(); 1 + root.descendants()];
    let mut order = vec![0u32; root.prims as usize];
    let (slot, below) = nodes.split_at_mut(1);
    let depth = write(
        bvh,
        &measured,
        0,
        0,
        &mut slot[0],
        (below, 1),
        (&mut order, 0),
    )?;
    Ok((nodes, order, depth))
}

/// [`Subtree`] of node `i` (at `depth`), stored for it and every node
/// below it into `out`; leaves collapsed by `rule` (none: kept). A tree
/// too deep for the traversal stack is refused here, before the walk
/// could recurse that deep: a collapse lifts leaves by at most
/// [`MAX_LEAF_TRIS`] levels.
fn measure(
    bvh: &Bvh2,
    i: usize,
    depth: usize,
    rule: Option<Collapse>,
    out: &[AtomicU64],
) -> Result<Subtree, SceneError> {
    if depth > STACK_SIZE + MAX_LEAF_TRIS as usize {
        return Err(too_deep(depth));
    }
    let node = &bvh.nodes[i];
    let sub = if node.is_leaf() {
        Subtree {
            count: node.prim_count,
            leaves: 1,
            prims: node.prim_count,
        }
    } else {
        let l = node.first_index as usize;
        let half = |j| measure(bvh, j, depth + 1, rule, out);
        let (left, right) = if depth < PARALLEL_DEPTH {
            rayon::join(|| half(l), || half(l + 1))
        } else {
            (half(l), half(l + 1))
        };
        let (left, right) = (left?, right?);
        let count = rule.map_or(0, |r| r.count(bvh, i, left.count, right.count));
        Subtree {
            count,
            leaves: if count > 0 {
                1
            } else {
                left.leaves + right.leaves
            },
            prims: left.prims + right.prims,
        }
    };
    out[i].store(sub.pack(), Ordering::Relaxed);
    Ok(sub)
}

/// The error for a tree deeper than the traversal stack.
fn too_deep(depth: usize) -> SceneError {
    SceneError::Internal(format!(
        "BVH depth {depth} exceeds the traversal stack ({STACK_SIZE})"
    ))
}

/// Lay out the subtree of node `i` (at `depth`; its [`Subtree`]s as
/// [`measure`] stored them in `measured`): its own node into `slot`, the
/// nodes below it into `below` (whose first slot is node `base` of the
/// whole layout), its triangles' slots into `order` (whose first is leaf
/// slot `first`). Returns the deepest depth below.
fn write(
    bvh: &Bvh2,
    measured: &[AtomicU64],
    i: usize,
    depth: usize,
    slot: &mut GpuNode,
    (below, base): (&mut [GpuNode], usize),
    (order, first): (&mut [u32], u32),
) -> Result<usize, SceneError> {
    let node = &bvh.nodes[i];
    *slot = GpuNode {
        min: node.aabb.min.into(),
        packed: 0,
        max: node.aabb.max.into(),
        min_stamp: u32::MAX,
    };
    let at = |i: usize| Subtree::unpack(measured[i].load(Ordering::Relaxed));
    let sub = at(i);
    if sub.count > 0 {
        if sub.count > MAX_LEAF_TRIS {
            return Err(SceneError::Internal(format!(
                "BVH leaf with {} triangles (max {MAX_LEAF_TRIS})",
                sub.count
            )));
        }
        // The triangles of the leaves below, left first, as obvhs's
        // collapse gathers them. Every subtree on the stack holds a leaf
        // not met yet, and there are at most MAX_LEAF_TRIS of those.
        let mut k = 0;
        let mut stack = [0usize; MAX_LEAF_TRIS as usize];
        stack[0] = i;
        let mut sp = 1;
        while sp > 0 {
            sp -= 1;
            let n = &bvh.nodes[stack[sp]];
            if n.is_leaf() {
                for p in n.first_index..n.first_index + n.prim_count {
                    order[k] = p;
                    k += 1;
                }
            } else {
                let l = n.first_index as usize;
                stack[sp] = l + 1;
                stack[sp + 1] = l;
                sp += 2;
            }
        }
        slot.packed = GpuNode::pack_leaf(first, sub.count);
        return Ok(depth);
    }
    let l = node.first_index as usize;
    let left = at(l);
    slot.packed = base as u32;
    let (pair, rest) = below.split_at_mut(2);
    let (ls, rs) = pair.split_at_mut(1);
    let (lb, rb) = rest.split_at_mut(left.descendants());
    let (lo, ro) = order.split_at_mut(left.prims as usize);
    let right_base = base + 2 + lb.len();
    let right_first = first + left.prims;
    let mut left_half = || {
        write(
            bvh,
            measured,
            l,
            depth + 1,
            &mut ls[0],
            (lb, base + 2),
            (lo, first),
        )
    };
    let mut right_half = || {
        write(
            bvh,
            measured,
            l + 1,
            depth + 1,
            &mut rs[0],
            (rb, right_base),
            (ro, right_first),
        )
    };
    let (a, b) = if sub.prims > PARALLEL_PRIMS {
        rayon::join(left_half, right_half)
    } else {
        (left_half(), right_half())
    };
    Ok(a?.max(b?))
}

/// A value per node from the leaves up: `leaf(first, count)` for a leaf,
/// `join` of its children's for an inner node; `packed(i)` is node `i`'s
/// [`GpuNode`] word (child index or leaf range). The depth-first layout
/// ([`lay_out`]) stores every child after its parent, so one sweep
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
fn fit_boxes(nodes: &mut [GpuNode], tris: &[GpuTriangle]) {
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
fn min_stamps(n: usize, packed: impl Fn(usize) -> u32, tris: &[GpuTriangle]) -> Vec<u32> {
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
/// the depth-first layout ([`lay_out`]) numbers a subtree's leaves
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
/// [`EXACT_SPHERE_TRIS`] triangles, a bound from the children's spheres
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The plain walk [`lay_out`] must match: obvhs's own collapse, then
    /// its tree walked depth first with a stack, left child first; the
    /// nodes, and the triangles (input indices) in leaf order.
    fn collapsed_by_obvhs_and_walked(mut bvh: Bvh2, max_leaf: u32) -> (Vec<GpuNode>, Vec<u32>) {
        let p = BvhBuildParams::fast_build();
        obvhs::bvh2::leaf_collapser::collapse(&mut bvh, max_leaf, p.collapse_traversal_cost);
        let boxed = |i: usize| GpuNode {
            min: bvh.nodes[i].aabb.min.into(),
            packed: 0,
            max: bvh.nodes[i].aabb.max.into(),
            min_stamp: u32::MAX,
        };
        let (mut out, mut order) = (vec![boxed(0)], Vec::new());
        let mut stack = vec![(0usize, 0usize)];
        while let Some((old, new)) = stack.pop() {
            let n = bvh.nodes[old];
            if n.is_leaf() {
                out[new].packed = GpuNode::pack_leaf(order.len() as u32, n.prim_count);
                let slots = n.first_index as usize..(n.first_index + n.prim_count) as usize;
                order.extend(&bvh.primitive_indices[slots]);
            } else {
                let l = n.first_index as usize;
                out[new].packed = out.len() as u32;
                stack.extend([(l + 1, out.len() + 1), (l, out.len())]);
                out.extend([boxed(l), boxed(l + 1)]);
            }
        }
        (out, order)
    }

    /// The layout's collapse is obvhs's, node for node: on scattered
    /// soups and stacked layers, with leaves of up to 2, 4 and 8
    /// triangles (the rule's ties, counts and half areas all matter),
    /// the laid-out nodes (boxes and links) and the triangle order are
    /// those of obvhs's collapsed tree walked depth first.
    #[test]
    fn the_layout_walks_obvhs_collapsed_tree() {
        let bits = |n: &[GpuNode]| -> Vec<[u32; 7]> {
            n.iter()
                .map(|n| {
                    [
                        n.min[0].to_bits(),
                        n.min[1].to_bits(),
                        n.min[2].to_bits(),
                        n.packed,
                        n.max[0].to_bits(),
                        n.max[1].to_bits(),
                        n.max[2].to_bits(),
                    ]
                })
                .collect()
        };
        for (tris, lift) in [(soup(40_000), 0.0), (stacked(12), 5.0), (soup(7), 0.0)] {
            let bvh = uncollapsed(&tris, lift, &BvhBuildParams::fast_build());
            for max_leaf in [2, 4, 8] {
                let rule = Collapse {
                    max_prims: max_leaf,
                    traversal_cost: BvhBuildParams::fast_build().collapse_traversal_cost,
                };
                let (nodes, order, _) = lay_out(&bvh, rule).unwrap();
                let order: Vec<u32> = order
                    .iter()
                    .map(|&k| bvh.primitive_indices[k as usize])
                    .collect();
                let (want, want_order) = collapsed_by_obvhs_and_walked(bvh.clone(), max_leaf);
                let case = format!("{} triangles, leaves ≤ {max_leaf}", tris.len());
                assert_eq!(bits(&nodes), bits(&want), "{case}");
                assert!(order == want_order, "{case}: triangles in another order");
            }
        }
    }

    /// A tree deeper than the traversal stack (a chain: every inner
    /// node's right child is the next inner node) is refused with an
    /// error before the walks recurse down it.
    #[test]
    fn a_chain_too_deep_for_the_stack_is_refused() {
        let depth = 100_000;
        let mut bvh = Bvh2::default();
        // Node 2k is inner with children 2k + 1 (a leaf) and 2k + 2.
        let node = |z0: usize, z1: usize, prims: u32, first: usize| {
            let aabb = obvhs::aabb::Aabb {
                min: [0.0, 0.0, z0 as f32].into(),
                max: [1.0, 1.0, z1 as f32].into(),
            };
            obvhs::bvh2::node::Bvh2Node::new(aabb, prims, first as u32)
        };
        for k in 0..depth {
            bvh.nodes.push(node(k, depth + 1, 0, 2 * k + 1));
            bvh.nodes.push(node(k, k + 1, 1, k));
        }
        bvh.nodes.push(node(depth, depth + 1, 1, depth));
        bvh.primitive_indices = (0..=depth as u32).collect();
        let rule = Collapse {
            max_prims: 4,
            traversal_cost: 3.0,
        };
        let err = lay_out(&bvh, rule).unwrap_err().to_string();
        assert!(err.contains("exceeds the traversal stack"), "{err}");
    }

    /// A subtree's measures survive their packing into one word.
    #[test]
    fn subtrees_pack_into_one_word() {
        for sub in [
            Subtree {
                count: 0,
                leaves: 1,
                prims: 1,
            },
            Subtree {
                count: MAX_LEAF_TRIS,
                leaves: MAX_TRIS - 1,
                prims: MAX_TRIS - 1,
            },
            Subtree {
                count: 3,
                leaves: 12_345,
                prims: 67_890,
            },
        ] {
            assert_eq!(Subtree::unpack(sub.pack()), sub);
        }
    }

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
        let bvh = build(&tris, 4, 0.0).unwrap();
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

    /// `layers` wavy sheets 0.4 mm apart, as printed layers lie, each a
    /// grid of right triangles with 1 mm legs over 30 × 30 mm; stamps in
    /// print order.
    fn stacked(layers: u32) -> Vec<GpuTriangle> {
        let mut out = Vec::new();
        for k in 0..layers {
            let z = |x: f32, y: f32| 0.4 * k as f32 + 0.8 * (0.2 * x).sin() * (0.15 * y).cos();
            for i in 0..30 {
                for j in 0..30 {
                    let (x, y) = (i as f32, j as f32);
                    for (a, b, c) in [
                        ((x, y), (x + 1.0, y), (x, y + 1.0)),
                        ((x + 1.0, y), (x + 1.0, y + 1.0), (x, y + 1.0)),
                    ] {
                        let v = |(x, y): (f32, f32)| [x, y, z(x, y)];
                        out.push(GpuTriangle {
                            v0: v(a),
                            stamp: out.len() as u32 + 1,
                            v1: v(b),
                            layer: k,
                            v2: v(c),
                            source: out.len() as u32,
                        });
                    }
                }
            }
        }
        out
    }

    /// Triangles below each node, by descent: the plain loop the spans
    /// are checked against.
    fn for_each_triangle_below(bvh: &StampedBvh, i: usize, mut f: impl FnMut(&GpuTriangle)) {
        let mut stack = vec![i];
        while let Some(j) = stack.pop() {
            match bvh.nodes[j].leaf_range() {
                Some((first, count)) => {
                    bvh.triangles[first as usize..(first + count) as usize]
                        .iter()
                        .for_each(&mut f);
                }
                None => {
                    let l = bvh.nodes[j].packed as usize;
                    stack.extend([l, l + 1]);
                }
            }
        }
    }

    /// Every subtree's triangles are the contiguous span the layout gives
    /// it: the same triangles as a descent finds, each once.
    #[test]
    fn every_subtree_is_one_span_of_triangles() {
        let bvh = build(&soup(3000), 4, 0.0).unwrap();
        let spans = triangle_spans(&bvh.nodes);
        for (i, &(first, end)) in spans.iter().enumerate() {
            let mut below = Vec::new();
            for_each_triangle_below(&bvh, i, |t| below.push(t.source));
            below.sort_unstable();
            let mut span: Vec<u32> = bvh.triangles[first as usize..end as usize]
                .iter()
                .map(|t| t.source)
                .collect();
            span.sort_unstable();
            assert_eq!(span, below, "node {i}");
        }
    }

    /// Lifted by layer, the nodes of 17 to 64 triangles (patches of a few
    /// mm) hold one layer each, where in a tree built in true space most
    /// of them mix layers stacked 0.4 mm apart (on this sheet: 1 in 4 of
    /// the 17–32 ones, 1 in 30 of the 33–64 ones hold one layer); either
    /// way every node's box is the tightest around the true triangles
    /// below it.
    #[test]
    fn lifted_builds_keep_layers_apart_in_true_boxes() {
        let tris = stacked(6);
        let one_layer = |b: &StampedBvh| {
            let spans = triangle_spans(&b.nodes);
            let (mut nodes, mut single) = (0, 0);
            for i in (0..b.nodes.len()).filter(|&i| (17..=64).contains(&(spans[i].1 - spans[i].0)))
            {
                let mut layers = Vec::new();
                for_each_triangle_below(b, i, |t| layers.push(t.layer));
                nodes += 1;
                single += layers.iter().all(|&k| k == layers[0]) as usize;
            }
            single as f64 / nodes as f64
        };
        let flat = build(&tris, 4, 0.0).unwrap();
        let lifted = build(&tris, 4, 5.0).unwrap();
        let (f, l) = (one_layer(&flat), one_layer(&lifted));
        assert!(l > 0.95, "lifted: {l} of the nodes hold one layer");
        assert!(f < 0.5, "true space: {f} of the nodes hold one layer");
        for bvh in [&flat, &lifted] {
            for (i, n) in bvh.nodes.iter().enumerate() {
                let mut lo = [f32::INFINITY; 3];
                let mut hi = [f32::NEG_INFINITY; 3];
                for_each_triangle_below(bvh, i, |t| {
                    for v in [t.v0, t.v1, t.v2] {
                        for k in 0..3 {
                            lo[k] = lo[k].min(v[k]);
                            hi[k] = hi[k].max(v[k]);
                        }
                    }
                });
                assert_eq!((n.min, n.max), (lo, hi), "node {i}");
            }
        }
    }
}

//! obvhs's tree collapsed and laid out as [`GpuNode`]s, depth first
//! (every child after its parent, the left child next): each subtree
//! measured bottom up, then written in parallel where subtrees are large.

use super::super::gpu_types::{GpuNode, MAX_LEAF_TRIS, STACK_SIZE};
use super::super::SceneError;
use obvhs::bvh2::Bvh2;
use std::sync::atomic::{AtomicU64, Ordering};

/// obvhs's SAH leaf collapse (`obvhs::bvh2::leaf_collapser::collapse`,
/// its rule and arithmetic in version 0.4): from the leaves up, a node
/// whose children are both leaves of together at most `max_prims`
/// triangles becomes one leaf when its box's half area times
/// (`count − traversal_cost`) is no more than its children's half areas
/// times their counts. (obvhs also joins two leaves holding the same
/// primitive, which only its spatial splits make.)
#[derive(Clone, Copy, Debug)]
pub(super) struct Collapse {
    pub max_prims: u32,
    pub traversal_cost: f32,
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
/// bits: [`MAX_TRIS`](crate::scene::gpu_types::MAX_TRIS) is 2²⁷).
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
/// subtree into the slots the first found for it ([`write()`]). obvhs's
/// own collapse rebuilds its node array and parent links, which with a
/// copy and a walk of its own costs more than these two; the tree, and so
/// the layout, are the same (test `the_layout_walks_obvhs_collapsed_tree`).
pub(super) fn lay_out(
    bvh: &Bvh2,
    collapse: Collapse,
) -> Result<(Vec<GpuNode>, Vec<u32>, usize), SceneError> {
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
pub(super) fn too_deep(depth: usize) -> SceneError {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::gpu_types::MAX_TRIS;

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
}

//! CPU mirror of `shaders/collide_traverse.wgsl`: one query's walk of the
//! part BVH as the kernel makes it, settling what the distance grid, the
//! slabs and the hull planes can and listing the undecided (query,
//! triangle) pairs in the order the walk meets them. The kernel appends
//! that list to the batch's shared candidate list (a query whose pairs do
//! not all fit hands over the rest in a resumed pass); here it is returned
//! whole. The entry points (`traverse_lane.wgsl`: one query an
//! invocation; `traverse_persistent.wgsl`: lanes that take the next query)
//! and the resumed passes only change which invocation walks a query and
//! how many of its pairs a pass hands over, not the walk or its order, so
//! this one function mirrors them all.
//!
//! The cpu backend itself does not use it (its walk,
//! [`super::frontier`], tests each undecided triangle on the spot and
//! stops at the first hit): it is the twin the kernel is tested against,
//! pair by pair, and it stays a walk of its own because it follows the
//! kernel step for step (children tested before they are pushed, the
//! deeper one on top; pairs listed, not tested).

use super::common::{
    classify_sample, grid_sample, head_tri, node_hull_clear, slab_clear, sphere_margin, to_head,
    SceneView, STACK_SIZE,
};
use crate::collide::gpu::wire::Walk;
use crate::scene::GpuQuery;

/// A node as the walk sees it.
///
/// Twin: `NodeTest` (`collide_traverse.wgsl`).
#[derive(Clone, Copy, Debug)]
struct NodeTest {
    /// 1 settled clear (or printed later), −1 wholly inside the head, 0
    /// undecided.
    state: i32,
    /// The head grid's signed distance at its centre less its radius
    /// ([`GridSample::v`](super::common::GridSample::v)): of two undecided children, the one reaching
    /// deeper into the head is walked first.
    depth: f32,
}

/// A node's stamp, its sphere against the grid, then its slab and the
/// hull plane facing it.
///
/// Twin: `test_node` (`collide_traverse.wgsl`).
#[inline(always)]
fn test_node(s: &SceneView, q: &GpuQuery, i: u32) -> NodeTest {
    let node = s.nodes[i as usize];
    if node.min_stamp >= q.cutoff {
        return NodeTest {
            state: 1,
            depth: 0.0,
        };
    }
    let c = to_head(q, node.center);
    let margin = sphere_margin(q, c, node.radius);
    let g = grid_sample(s.head, s.grid, c);
    let cls = classify_sample(s.head, &g, c, node.radius, margin);
    if cls != 0 {
        return NodeTest {
            state: cls,
            depth: 0.0,
        };
    }
    if slab_clear(s.head, s.grid, q, &node, margin)
        || node_hull_clear(s.head, s.grid, q, &node, c, margin)
    {
        return NodeTest {
            state: 1,
            depth: 0.0,
        };
    }
    NodeTest {
        state: 0,
        depth: g.v - node.radius,
    }
}

/// The walk for query `q`: children tested before they are pushed (only
/// undecided ones are, the one reaching deeper into the head on top), a
/// node or a triangle wholly inside the head ends it.
///
/// Twin: `walk_begin`, then `walk_step` while `walk_on`
/// (`collide_traverse.wgsl`), every pair handed over in one pass.
pub fn walk(s: &SceneView, q: &GpuQuery) -> Walk {
    let mut out = Walk::default();
    let mut stack = [0u32; STACK_SIZE];
    let mut sp = 0usize;
    let root = test_node(s, q, 0);
    out.hit = root.state < 0;
    if root.state == 0 {
        sp = 1;
    }
    while sp > 0 && !out.hit {
        sp -= 1;
        let node = s.nodes[stack[sp] as usize];
        match node.leaf_range() {
            Some((first, count)) => {
                for t in first..first + count {
                    let tri = &s.tris[t as usize];
                    if tri.stamp < q.cutoff {
                        let h = head_tri(s, q, tri);
                        if h.cls < 0 {
                            out.hit = true;
                        } else if h.cls == 0 {
                            out.candidates.push(t);
                        }
                    }
                }
            }
            None => {
                let a = node.packed;
                let (ta, tb) = (test_node(s, q, a), test_node(s, q, a + 1));
                if ta.state < 0 || tb.state < 0 {
                    out.hit = true;
                } else if ta.state == 0 && tb.state == 0 {
                    let (first, then) = if ta.depth <= tb.depth {
                        (a, a + 1)
                    } else {
                        (a + 1, a)
                    };
                    stack[sp] = then;
                    stack[sp + 1] = first;
                    sp += 2;
                } else if ta.state == 0 {
                    stack[sp] = a;
                    sp += 1;
                } else if tb.state == 0 {
                    stack[sp] = a + 1;
                    sp += 1;
                }
            }
        }
    }
    out
}

//! CPU mirror of `shaders/collide_traverse.wgsl`: one query's walk of the
//! part BVH as the kernel makes it, settling what the distance grid, the
//! slabs and the hull planes can and listing the undecided (query,
//! triangle) pairs in the order the walk meets them. The kernel appends
//! that list to the batch's shared candidate list (a query whose pairs do
//! not all fit hands over the rest in a resumed pass); here it is returned
//! whole. The cpu backend itself does not use it (its walk,
//! [`super::first_hit`], tests each undecided triangle on the spot and
//! stops at the first hit): it is the twin the kernel is tested against,
//! pair by pair.

use super::{
    classify_sample, grid_sample, hull_clear, node_hull_clear, slab_clear, sphere_margin, to_head,
    triangle_margin, SceneView, STACK_SIZE,
};
use crate::geometry::{length, sub, V3};
use crate::scene::{GpuQuery, GpuTriangle};

/// What the walk of one query found.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Walk {
    /// A node or a triangle lies wholly inside the head: the query
    /// collides (the walk stopped there).
    pub hit: bool,
    /// The undecided triangles (indices into the part triangles) in walk
    /// order, for the exact tests ([`super::exact`]).
    pub candidates: Vec<u32>,
}

/// A triangle moved into the head frame, with its margin and what the
/// grid and the hull plane say of it (the kernels' `HeadTri`).
#[derive(Clone, Copy, Debug)]
pub struct HeadTri {
    /// Vertices, head frame.
    pub a: V3,
    /// See `a`.
    pub b: V3,
    /// See `a`.
    pub c: V3,
    /// The margin it must keep ([`triangle_margin`]).
    pub margin: f32,
    /// 1 clear, −1 colliding (wholly inside, or its centroid inside), 0
    /// undecided (the exact tests decide).
    pub cls: i32,
}

/// The kernels' `head_tri`: the triangle in the head frame, classified by
/// the grid around its centroid (its sphere wholly outside or inside, or
/// the centroid itself inside: a point of the triangle in the head), then
/// by the hull plane facing it.
#[inline(always)]
pub fn head_tri(s: &SceneView, q: &GpuQuery, tri: &GpuTriangle) -> HeadTri {
    let a = to_head(q, tri.v0);
    let b = to_head(q, tri.v1);
    let c = to_head(q, tri.v2);
    // Multiply, not divide: WGSL division is not exactly rounded.
    const THIRD: f32 = 1.0 / 3.0;
    let m = [
        (a[0] + b[0] + c[0]) * THIRD,
        (a[1] + b[1] + c[1]) * THIRD,
        (a[2] + b[2] + c[2]) * THIRD,
    ];
    let r = length(sub(a, m))
        .max(length(sub(b, m)))
        .max(length(sub(c, m)));
    let margin = triangle_margin(q, a, b, c);
    let g = grid_sample(s.head, s.grid, m);
    let mut cls = classify_sample(s.head, &g, m, r, margin);
    // A centroid inside the head is a point of the triangle inside it.
    if cls == 0 && classify_sample(s.head, &g, m, 0.0, 0.0) < 0 {
        cls = -1;
    }
    if cls == 0 && hull_clear(s.head, s.grid, m, [a, b, c], margin) {
        cls = 1;
    }
    HeadTri {
        a,
        b,
        c,
        margin,
        cls,
    }
}

/// A node as the walk sees it (the kernel's `NodeTest`).
#[derive(Clone, Copy, Debug)]
struct NodeTest {
    /// 1 settled clear (or printed later), −1 wholly inside the head, 0
    /// undecided.
    state: i32,
    /// The head grid's signed distance at its centre less its radius
    /// ([`GridSample::v`]): of two undecided children, the one reaching
    /// deeper into the head is walked first.
    depth: f32,
}

/// The kernel's `test_node`: the node's stamp, its sphere against the
/// grid, then its slab and the hull plane facing it.
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

/// The kernel's walk for query `q`: children tested before they are
/// pushed (only undecided ones are, the one reaching deeper into the head
/// on top), a node or a triangle wholly inside the head ends it.
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

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
//!
//! The build is here; `layout` collapses obvhs's tree and lays it out
//! depth first, `bounds` computes what each node bounds (boxes, stamps,
//! spheres) from the triangles below it.

mod bounds;
mod layout;

pub use bounds::{max_stamps, refresh_min_stamps, sphere_nodes};
pub(crate) use bounds::{triangle_spans, vertices_in};

use super::gpu_types::STACK_SIZE;
use super::gpu_types::{GpuNode, GpuTriangle, MAX_LEAF_TRIS, MAX_TRIS};
use super::SceneError;
use bounds::{fit_boxes, min_stamps};
use layout::{lay_out, too_deep, Collapse};
use obvhs::aabb::Aabb;
use obvhs::bvh2::reinsertion::ReinsertionOptimizer;
use obvhs::bvh2::Bvh2;
use obvhs::ploc::PlocBuilder;
use obvhs::triangle::Triangle;
use obvhs::BvhBuildParams;
use rayon::prelude::*;

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
/// walk culls material is the head's. Lifts from a twentieth of the head
/// to the whole head all pay about alike, and layers wholly apart pay
/// nothing; an eighth of the head, the subdivision length, sits inside
/// that range.
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
    // obvhs's fast preset: medium_build's better tree does not repay its
    // longer build, and very_fast_build's tree costs the queries more than
    // its build saves (paired runs, BENCHMARKS.md).
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
    // PLOC reads only the primitives' boxes: boxes, not triangles, are
    // handed over (32 bytes a primitive, not 48; the load's peak on a part
    // of millions of bead triangles).
    let boxes: Vec<Aabb> = tris
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
            .aabb()
        })
        .collect();
    let mut bvh = PlocBuilder::with_capacity(boxes.len()).build(
        params.ploc_search_distance,
        &boxes,
        (0..boxes.len() as u32).collect(),
        params.sort_precision,
        params.search_depth_threshold,
    );
    drop(boxes);
    ReinsertionOptimizer::default().run(&mut bvh, params.reinsertion_batch_ratio, None);
    bvh
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

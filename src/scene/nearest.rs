//! The nearest point of the head's surface to a point, over the head's
//! BVH: what the distance grids ([`super::head`]) and the hull planes
//! ([`super::hull_plane`]) are built from. Building only, in `f64`; the
//! evaluators read the grids.

use super::gpu_types::{GpuNode, GpuTriangle};
use crate::geometry::aabb::point_box_distance;
use crate::geometry::point_triangle_distance::closest_point;
use crate::geometry::V3;
use glam::DVec3;

/// The head BVH's nodes and its triangles in leaf order.
pub(crate) type HeadBvh<'a> = (&'a [GpuNode], &'a [GpuTriangle]);

/// Distance from `p` to the nearest head triangle: the BVH walked nearer
/// child first, subtrees pruned by their box's distance (in f32, so with
/// 1e-4 mm to spare).
pub(crate) fn nearest_distance(bvh: HeadBvh, p: [f64; 3]) -> f64 {
    nearest_on(bvh, p).0
}

/// [`nearest_distance`], the nearest point of the head's surface and the
/// triangle it lies on (index into the BVH's triangles).
pub(crate) fn nearest_on((nodes, tris): HeadBvh, p: [f64; 3]) -> (f64, [f64; 3], usize) {
    let pf = p.map(|x| x as f32);
    let box_distance = |n: u32| {
        let node = &nodes[n as usize];
        point_box_distance(pf, node.min, node.max) as f64 - 1e-4
    };
    let f64v = |v: V3| v.map(|x| x as f64);
    let mut best = (f64::INFINITY, p, 0);
    let mut stack = vec![0u32];
    while let Some(n) = stack.pop() {
        if box_distance(n) >= best.0 {
            continue;
        }
        match nodes[n as usize].leaf_range() {
            Some((first, count)) => {
                let first = first as usize;
                for (i, t) in tris.iter().enumerate().skip(first).take(count as usize) {
                    let q = closest_point(p, f64v(t.v0), f64v(t.v1), f64v(t.v2));
                    let d = DVec3::from(p).distance(DVec3::from(q));
                    if d < best.0 {
                        best = (d, q, i);
                    }
                }
            }
            None => {
                let (l, r) = (nodes[n as usize].packed, nodes[n as usize].packed + 1);
                // Nearer child on top.
                if box_distance(l) <= box_distance(r) {
                    stack.extend([r, l]);
                } else {
                    stack.extend([l, r]);
                }
            }
        }
    }
    best
}

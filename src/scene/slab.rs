//! Slabs: a second bound per part node, for flat material.
//!
//! A node's bounding sphere is a poor fit for a flat patch of layer: a
//! patch 2 mm wide has a sphere of radius 1 mm, which reaches up to the
//! nozzle from the layer 0.4 mm below it, so the walk descends to the
//! leaves there. Each node therefore also keeps a slab — a unit normal
//! `n` (the dominant axis of its triangles' normals, whichever way they
//! are wound) and the interval `[lo, hi]` of `n · (x − centre)` over its
//! vertices — and the head keeps its support function `h(u) = max u · x`
//! (head frame) as a cube map of upper bounds ([`support_map`]), each
//! cell's word holding the bounds of both `h(u)` and `h(−u)`
//! ([`support_pairs`]): the test reads one word for both sides. A node
//! lies wholly on one side of the head, farther than the margin, when its
//! interval along `n` ends `margin` short of the head's `[−h(−n), h(n)]`
//! (`collide::cpu::common::slab_clear`). Only slabs thinner than half the node's
//! radius are tested: thicker ones are rarely decisive and cost their
//! lookups.
//!
//! Packed into the node's spare 8 bytes ([`GpuPartNode::slab_normal`],
//! [`GpuPartNode::slab_range`]): the normal octahedral in two snorm16,
//! the interval as two snorm16 fractions of the radius, rounded outwards
//! by one step more than the encoding needs so a GPU's own rounding of
//! the decode stays inside.

use super::bvh::{triangle_spans, vertices_in, StampedBvh};
use super::gpu_types::GpuPartNode;
use glam::DVec3;
use rayon::prelude::*;

/// A node's slab as its words decode ([`GpuPartNode::slab_normal`],
/// [`GpuPartNode::slab_range`]): the unit normal and the interval
/// `[lo, hi]` in units of the node's radius. The CPU's readers (the cpu
/// backend's walk, the extrusion's distance search) hold every node's
/// decoded ([`super::Scene::part_slabs`]) instead of decoding it at every
/// visit: the decode's square root and division are dearer than the rest
/// of a slab test.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Slab {
    /// The unit normal `n`.
    pub normal: [f32; 3],
    /// `[lo, hi]`: the interval of `n · (x − centre)` over the node's
    /// vertices, as fractions of its radius.
    pub range: [f32; 2],
}

impl Slab {
    /// `node`'s slab, decoded as the kernels decode it.
    pub fn of(node: &GpuPartNode) -> Slab {
        Slab {
            normal: oct_decode(unpack_snorm2x16(node.slab_normal)),
            range: unpack_snorm2x16(node.slab_range),
        }
    }
}

/// Cells per cube-map face side of the head's support function.
pub const SUPPORT_SIDE: u32 = 32;

/// Subtrees of at most this many triangles get the exact interval (over
/// their span of triangles); larger ones one from their children's slabs
/// and their box.
const EXACT_SLAB_TRIS: u32 = 64;

/// Fill every node's slab words (nodes as [`super::bvh::sphere_nodes`]
/// gives them: the same tree as `bvh`). Linear in the tree: a node's
/// normal is its children's area-weighted normals added with their
/// signs aligned (the data set's layers alternate their winding), and
/// its interval is exact over the vertices of subtrees of at most
/// `EXACT_SLAB_TRIS` triangles and, above, the tighter of its box's and
/// its children's slabs' (`child_interval`).
///
/// `walls[s]` marks the soup's triangle `s` (its `source`) as a wall of a
/// solid (a bead's sides and ends) whose normal says nothing of which way
/// the node is thin: it is left out of the normal (an empty slice: none
/// is).
pub fn add_slabs(bvh: &StampedBvh, spheres: &mut [GpuPartNode], walls: &[bool]) {
    let is_wall = |t: &crate::scene::GpuTriangle| walls.get(t.source as usize) == Some(&true);
    let nodes = &bvh.nodes;
    // Normals, children first (the depth-first layout stores every child
    // after its parent).
    let mut sum = vec![DVec3::ZERO; nodes.len()];
    for i in (0..nodes.len()).rev() {
        sum[i] = match nodes[i].leaf_range() {
            Some((first, c)) => bvh.triangles[first as usize..(first + c) as usize]
                .iter()
                .filter(|t| !is_wall(t))
                .fold(DVec3::ZERO, |acc, t| aligned_add(acc, area_normal(t))),
            None => {
                let l = nodes[i].packed as usize;
                aligned_add(sum[l], sum[l + 1])
            }
        };
    }
    // The normal as stored; every reader decodes it (`decoded`).
    let normal: Vec<u32> = sum.par_iter().map(|s| oct_encode(*s)).collect();
    drop(sum);
    let decoded = |i: usize| DVec3::from(oct_decode(unpack_snorm2x16(normal[i])).map(|x| x as f64));
    let centre = |i: usize| DVec3::from(spheres[i].center.map(|x| x as f64));
    let spans = triangle_spans(nodes);
    // Exact intervals of n · (x − centre) for small subtrees; the others
    // (NaN here) children first below.
    let mut range: Vec<[f64; 2]> = (0..nodes.len())
        .into_par_iter()
        .map(|i| {
            let (first, end) = spans[i];
            if end - first > EXACT_SLAB_TRIS {
                return [f64::NAN; 2];
            }
            let (n, c) = (decoded(i), centre(i));
            vertices_in(bvh, spans[i]).fold([f64::INFINITY, f64::NEG_INFINITY], |r, v| {
                let d = n.dot(DVec3::from(v.map(|x| x as f64)) - c);
                [r[0].min(d), r[1].max(d)]
            })
        })
        .collect();
    drop(spans);
    for i in (0..nodes.len()).rev() {
        if !range[i][0].is_nan() {
            continue;
        }
        let (n, c) = (decoded(i), centre(i));
        let b = &nodes[i];
        let box_centre: [f64; 3] =
            std::array::from_fn(|k| 0.5 * (b.min[k] as f64 + b.max[k] as f64));
        let mid = n.dot(DVec3::from(box_centre) - c);
        let half: f64 = (0..3)
            .map(|k| n[k].abs() * 0.5 * (b.max[k] as f64 - b.min[k] as f64))
            .sum();
        let child =
            |j: usize| child_interval(n, c, decoded(j), centre(j), range[j], spheres[j].radius);
        let l = b.packed as usize;
        let ([l0, l1], [r0, r1]) = (child(l), child(l + 1));
        range[i] = [(mid - half).max(l0.min(r0)), (mid + half).min(l1.max(r1))];
    }
    spheres
        .par_iter_mut()
        .zip(range)
        .zip(normal)
        .for_each(|((node, [lo, hi]), normal)| {
            let r = node.radius as f64;
            node.slab_range = if r > 0.0 && lo.is_finite() && hi.is_finite() {
                // Outwards, and one step more for a GPU's decode.
                let q = |x: f64| (x / r * SNORM).clamp(-SNORM, SNORM);
                let lo = (q(lo).floor() - 1.0).max(-SNORM) as i32;
                let hi = (q(hi).ceil() + 1.0).min(SNORM) as i32;
                pack_i16(lo, hi)
            } else {
                pack_i16(-SNORM as i32, SNORM as i32)
            };
            node.slab_normal = normal;
        });
}

/// The interval of `n · (x − c)` over a child's points, from the child's
/// slab (normal `m`, interval `r` about its centre `cc`, radius `rad`):
/// `n = m + (n − m)`, and the second term moves a point of the child's
/// sphere by at most `|n − m| · rad`.
fn child_interval(n: DVec3, c: DVec3, m: DVec3, cc: DVec3, r: [f64; 2], rad: f32) -> [f64; 2] {
    let shift = n.dot(cc - c);
    let tilt = (n - m).length() * rad as f64;
    [shift + r[0] - tilt, shift + r[1] + tilt]
}

/// `a + b` or `a − b`, whichever keeps `b` on `a`'s side.
fn aligned_add(a: DVec3, b: DVec3) -> DVec3 {
    let s = if a.dot(b) < 0.0 { -1.0 } else { 1.0 };
    a + b * s
}

/// The largest snorm16 value.
const SNORM: f64 = 32767.0;

/// Two 16-bit integers in one word, `a` in the low half.
fn pack_i16(a: i32, b: i32) -> u32 {
    (a as u32 & 0xffff) | ((b as u32 & 0xffff) << 16)
}

/// WGSL's `unpack2x16snorm`: the low half first, each `i16 / 32767`
/// clamped to −1.
#[inline(always)]
pub fn unpack_snorm2x16(w: u32) -> [f32; 2] {
    let f = |h: u32| ((h & 0xffff) as u16 as i16 as f32 / 32767.0).max(-1.0);
    [f(w), f(w >> 16)]
}

/// A direction's octahedral code (two snorm16, x low), nearest; `+z`
/// for the zero vector.
fn oct_encode(n: DVec3) -> u32 {
    let l1 = n[0].abs() + n[1].abs() + n[2].abs();
    if l1.is_nan() || l1 <= 0.0 {
        return 0;
    }
    let (mut x, mut y) = (n[0] / l1, n[1] / l1);
    if n[2] < 0.0 {
        let (ax, ay) = (x.abs(), y.abs());
        x = (1.0 - ay) * if x >= 0.0 { 1.0 } else { -1.0 };
        y = (1.0 - ax) * if y >= 0.0 { 1.0 } else { -1.0 };
    }
    let q = |v: f64| (v.clamp(-1.0, 1.0) * SNORM).round() as i32;
    pack_i16(q(x), q(y))
}

/// The unit vector of an octahedral code's two components (the shaders'
/// `oct_decode`, operation for operation).
#[inline(always)]
pub fn oct_decode(p: [f32; 2]) -> [f32; 3] {
    let mut v = [p[0], p[1], 1.0 - p[0].abs() - p[1].abs()];
    let t = (-v[2]).max(0.0);
    v[0] += if v[0] >= 0.0 { -t } else { t };
    v[1] += if v[1] >= 0.0 { -t } else { t };
    let inv = 1.0 / (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    [v[0] * inv, v[1] * inv, v[2] * inv]
}

/// Twice the triangle's area times its unit normal (f64).
fn area_normal(t: &crate::scene::GpuTriangle) -> DVec3 {
    let [a, b, c] = [t.v0, t.v1, t.v2].map(|v| DVec3::from(v.map(|x| x as f64)));
    (b - a).cross(c - a)
}

/// The support map as the grid buffer holds it: per cube-map cell `c`,
/// one word with upper bounds of `h(u)` (low half) and of `h(−u)` (high
/// half) for every `u` whose cell is `c` ([`support_map`] of the vertices
/// and of their mirror image), each an IEEE half rounded up
/// ([`half_at_least`]: at most 1/1024 of the value, 0.06 mm at a head's
/// 100 mm), stored as the bits of an f32. The slab test needs both sides
/// of the head along a direction; as two cells of f32 it would read two
/// words, and on lavapipe each read with a per-query index is a loop over
/// the SIMD lanes.
/// Rounding up only loosens the test; what it culls is still clear.
pub fn support_pairs(vertices: &[[f32; 3]]) -> Vec<f32> {
    let mirrored: Vec<[f32; 3]> = vertices.iter().map(|v| v.map(|x| -x)).collect();
    let (up, down) = rayon::join(|| support_map(vertices), || support_map(&mirrored));
    up.iter()
        .zip(&down)
        .map(|(&u, &d)| f32::from_bits(half_at_least(u) as u32 | (half_at_least(d) as u32) << 16))
        .collect()
}

/// A word of [`support_pairs`] as the kernels read it (WGSL's
/// `unpack2x16float`, exact): the bounds of `h(u)` and `h(−u)`.
///
/// Twin: WGSL's `unpack2x16float` of `grid_word`, in `slab_gap`
/// (`collide_common.wgsl`).
#[inline(always)]
pub fn support_pair(word: f32) -> [f32; 2] {
    let w = word.to_bits();
    [
        half::f16::from_bits(w as u16).to_f32(),
        half::f16::from_bits((w >> 16) as u16).to_f32(),
    ]
}

/// The bits of the least IEEE half at least `x` (not NaN).
pub fn half_at_least(x: f32) -> u16 {
    let h = half::f16::from_f32(x);
    if h.to_f32() >= x {
        return h.to_bits();
    }
    // One step up: a positive half's magnitude grows with its bits, a
    // negative one's shrinks (−0 steps to the least positive).
    match h.to_bits() {
        0x8000 => 1,
        b if b & 0x8000 != 0 => b - 1,
        b => b + 1,
    }
}

/// Upper bounds of the support function `max u · v` over `vertices`, per
/// cube-map cell, for every unit `u` whose cell is that one or a
/// neighbour across a rounding (each cell's cone is widened).
pub fn support_map(vertices: &[[f32; 3]]) -> Vec<f32> {
    let side = SUPPORT_SIDE as usize;
    let cells = 6 * side * side;
    let verts: Vec<(DVec3, f64)> = vertices
        .iter()
        .map(|v| {
            let d = DVec3::from(v.map(|x| x as f64));
            (d, d.length())
        })
        .collect();
    let dir = |face: usize, s: f64, t: f64| {
        let k = face / 2;
        let sign = if face.is_multiple_of(2) { 1.0 } else { -1.0 };
        let (i, j) = ((k + 1) % 3, (k + 2) % 3);
        let mut u = DVec3::ZERO;
        u[k] = sign;
        u[i] = s;
        u[j] = t;
        u / u.length()
    };
    let angle = |a: DVec3, b: DVec3| a.dot(b).clamp(-1.0, 1.0).acos();
    (0..cells)
        .into_par_iter()
        .map(|c| {
            let face = c / (side * side);
            let (t, s) = ((c / side) % side, c % side);
            let coord = |x: usize| 2.0 * x as f64 / side as f64 - 1.0;
            let (s0, s1, t0, t1) = (coord(s), coord(s + 1), coord(t), coord(t + 1));
            let centre = dir(face, 0.5 * (s0 + s1), 0.5 * (t0 + t1));
            // The cell's angular radius: its corners and edge midpoints,
            // widened for directions rounded into it from a neighbour.
            let mut delta: f64 = 0.0;
            for (a, b) in [
                (s0, t0),
                (s1, t0),
                (s0, t1),
                (s1, t1),
                (0.5 * (s0 + s1), t0),
                (0.5 * (s0 + s1), t1),
                (s0, 0.5 * (t0 + t1)),
                (s1, 0.5 * (t0 + t1)),
            ] {
                delta = delta.max(angle(centre, dir(face, a, b)));
            }
            let delta = delta * 1.01 + 1e-4;
            let mut best = f64::NEG_INFINITY;
            for (v, len) in &verts {
                if *len == 0.0 {
                    best = best.max(0.0);
                    continue;
                }
                let unit = *v / *len;
                let a = (angle(centre, unit) - delta).max(0.0);
                best = best.max(len * a.cos());
            }
            (best as f32).next_up()
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::collide::cpu::common::{support_cell, support_pair};
    use crate::geometry::xorshift as rng;
    use crate::scene::bvh;
    use crate::scene::GpuTriangle;

    fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
        DVec3::from(a).dot(DVec3::from(b))
    }

    /// A built scene holds every node's slab decoded, bit for bit as the
    /// kernels decode its words, and frees them with the BVH.
    #[test]
    fn the_scene_holds_each_nodes_slab_decoded_until_its_bvh_goes() {
        let mut scene = crate::default_job::scene();
        assert_eq!(scene.part_slabs.len(), scene.part_nodes.len());
        let bits = |s: &Slab| (s.normal.map(f32::to_bits), s.range.map(f32::to_bits));
        let mut thin = 0;
        for (node, slab) in scene.part_nodes.iter().zip(&scene.part_slabs) {
            let normal = oct_decode(unpack_snorm2x16(node.slab_normal));
            let range = unpack_snorm2x16(node.slab_range);
            assert_eq!(bits(slab), bits(&Slab { normal, range }));
            thin += (range[1] - range[0] < 0.5) as usize;
        }
        // Slabs that the walk tests (thinner than half the radius) are there.
        assert!(thin > scene.part_nodes.len() / 4, "{thin}");
        scene.release_bvh();
        assert!(scene.part_slabs.is_empty());
    }

    fn unit(v: [f64; 3]) -> [f64; 3] {
        (DVec3::from(v) / DVec3::from(v).length()).to_array()
    }

    /// Every direction's bound is at least the true support over the
    /// vertices (a plain loop, f64), and not much more: a cell's cone of
    /// angular radius `δ` costs at most `reach · sin 2δ` (the direction at
    /// one side of it, the maximising one at the other). Directions include ones on the
    /// faces' edges and corners, where the cell is a rounding away.
    #[test]
    fn the_support_map_bounds_every_direction() {
        let mut next = rng(0x9e37_79b9_7f4a_7c15);
        // A lopsided cloud around a point 0.3 above the origin (a lifted
        // tip), reaching 40.
        let verts: Vec<[f32; 3]> = (0..400)
            .map(|_| {
                let d = unit([next() - 0.5, next() - 0.5, next() * 1.2 - 0.2]);
                let r = 40.0 * next() * next();
                [
                    (d[0] * r) as f32,
                    (d[1] * r) as f32,
                    (0.3 + d[2] * r) as f32,
                ]
            })
            .collect();
        let map = support_map(&verts);
        assert_eq!(map.len(), 6 * (SUPPORT_SIDE * SUPPORT_SIDE) as usize);
        let mut dirs: Vec<[f64; 3]> = (0..20_000)
            .map(|_| unit([next() - 0.5, next() - 0.5, next() - 0.5]))
            .collect();
        for a in [-1.0, 0.0, 1.0] {
            for b in [-1.0, -0.5, 0.0, 1.0] {
                dirs.push(unit([1.0, a, b]));
                dirs.push(unit([a, -1.0, b]));
                dirs.push(unit([b, a, -1.0]));
            }
        }
        // The largest cells, at a face's centre: half a diagonal.
        let delta = (2f64.sqrt() / SUPPORT_SIDE as f64).atan() * 1.01 + 1e-4;
        for u in dirs {
            let truth = verts
                .iter()
                .map(|v| dot(u, v.map(|x| x as f64)))
                .fold(f64::NEG_INFINITY, f64::max);
            let got = map[support_cell(u.map(|x| x as f32)) as usize] as f64;
            assert!(got >= truth - 1e-5, "{u:?}: {got} < {truth}");
            assert!(
                got <= truth + 40.0 * (2.0 * delta).sin(),
                "{u:?}: {got} ≫ {truth}"
            );
        }
    }

    /// The grid's words hold, for each direction, bounds of the support
    /// on both sides — `h(u)` and `h(−u)` read from `u`'s cell — at least
    /// the true ones (a plain loop, f64) and at most a half's rounding
    /// above the f32 map's.
    #[test]
    fn support_pairs_bound_both_sides() {
        let mut next = rng(0x51ab_5eed_0bad_cafe);
        let verts: Vec<[f32; 3]> = (0..300)
            .map(|_| {
                let d = unit([next() - 0.5, next() - 0.5, next() - 0.3]);
                let r = 60.0 * next();
                [
                    (d[0] * r) as f32,
                    (d[1] * r) as f32,
                    (d[2] * r) as f32 + 0.2,
                ]
            })
            .collect();
        let pairs = support_pairs(&verts);
        let map = support_map(&verts);
        let support = |u: [f64; 3]| {
            verts
                .iter()
                .map(|v| dot(u, v.map(|x| x as f64)))
                .fold(f64::NEG_INFINITY, f64::max)
        };
        let mut tight = 0;
        for _ in 0..20_000 {
            let u = unit([next() - 0.5, next() - 0.5, next() - 0.5]);
            let cell = support_cell(u.map(|x| x as f32)) as usize;
            let [up, down] = support_pair(pairs[cell]);
            assert!(up as f64 >= support(u) - 1e-5, "{u:?}: h(u) {up}");
            assert!(
                down as f64 >= support(u.map(|x| -x)) - 1e-5,
                "{u:?}: h(-u) {down}"
            );
            assert!(up >= map[cell] && up - map[cell] <= map[cell].abs() / 1024.0 + 1e-6);
            tight += (up == map[cell]) as usize;
        }
        assert!(
            tight < 20_000,
            "every bound exactly a half: the test shows nothing"
        );
    }

    /// `half_at_least` is the least half at least its argument.
    #[test]
    fn halves_round_up() {
        let mut next = rng(0x0123_4567_89ab_cdef);
        for k in 0..100_000 {
            let x = match k % 4 {
                0 => (next() as f32 - 0.5) * 200.0,
                1 => (next() as f32 - 0.5) * 1e-3,
                2 => -(next() as f32) * 5e-8,
                _ => (next() as f32) * 1e4,
            };
            let bits = half_at_least(x);
            let h = half::f16::from_bits(bits).to_f32();
            assert!(h >= x, "{x}: {h}");
            // The half one step below it, towards −∞.
            let down = match bits {
                0 => 0x8001,
                b if b & 0x8000 != 0 => b + 1,
                b => b - 1,
            };
            let prev = half::f16::from_bits(down).to_f32();
            assert!(prev < x, "{x}: {h} is not the least ({prev} is not below)");
        }
        assert_eq!(half_at_least(0.0), 0);
        assert_eq!(half::f16::from_bits(half_at_least(1.0)).to_f32(), 1.0);
        assert!(half::f16::from_bits(half_at_least(1.0001)).to_f32() > 1.0);
    }

    /// Every vertex below a node lies inside its slab as a reader decodes
    /// it, and nodes across layers wound in turn either way get thin
    /// slabs.
    #[test]
    fn slabs_hold_every_vertex_below() {
        let mut next = rng(0x2545_f491_4f6c_dd1d);
        // Wavy layers 0.4 apart, windings alternating per layer, plus a
        // scatter of tilted triangles.
        let mut tris = Vec::new();
        for layer in 0..6 {
            let z = 0.4 * layer as f64;
            for i in 0..40 {
                for j in 0..40 {
                    let (x, y) = (0.5 * i as f64, 0.5 * j as f64);
                    let h = |x: f64, y: f64| (z + 0.05 * (0.3 * x).sin() * (0.2 * y).cos()) as f32;
                    let (a, b, c) = (
                        [x as f32, y as f32, h(x, y)],
                        [(x + 0.5) as f32, y as f32, h(x + 0.5, y)],
                        [x as f32, (y + 0.5) as f32, h(x, y + 0.5)],
                    );
                    let (v1, v2) = if layer % 2 == 0 { (b, c) } else { (c, b) };
                    tris.push(GpuTriangle {
                        v0: a,
                        v1,
                        v2,
                        stamp: tris.len() as u32 + 1,
                        ..Default::default()
                    });
                }
            }
        }
        for _ in 0..500 {
            let c = [next() * 20.0, next() * 20.0, next() * 3.0];
            let mut v = || {
                [
                    (c[0] + next()) as f32,
                    (c[1] + next()) as f32,
                    (c[2] + next()) as f32,
                ]
            };
            tris.push(GpuTriangle {
                v0: v(),
                v1: v(),
                v2: v(),
                stamp: tris.len() as u32 + 1,
                ..Default::default()
            });
        }
        let tree = bvh::build(&tris, 4, 0.0).unwrap();
        let mut nodes = bvh::sphere_nodes(&tree);
        add_slabs(&tree, &mut nodes, &[]);
        let mut thin_layered = 0;
        for (i, node) in nodes.iter().enumerate() {
            let n = oct_decode(unpack_snorm2x16(node.slab_normal)).map(|x| x as f64);
            let [lo, hi] = unpack_snorm2x16(node.slab_range).map(|x| x as f64 * node.radius as f64);
            let c = node.center.map(|x| x as f64);
            let mut stack = vec![i];
            let mut only_layers = true;
            let mut layers = std::collections::BTreeSet::new();
            while let Some(j) = stack.pop() {
                match nodes[j].leaf_range() {
                    Some((first, count)) => {
                        for t in &tree.triangles[first as usize..(first + count) as usize] {
                            only_layers &= t.stamp <= 6 * 1600;
                            layers.insert((t.stamp - 1) / 1600);
                            for v in [t.v0, t.v1, t.v2] {
                                let d = dot(
                                    n,
                                    (DVec3::from(v.map(|x| x as f64)) - DVec3::from(c)).to_array(),
                                );
                                assert!(d >= lo && d <= hi, "node {i}: {d} outside [{lo}, {hi}]");
                            }
                        }
                    }
                    None => {
                        let l = nodes[j].packed as usize;
                        stack.extend([l, l + 1]);
                    }
                }
            }
            // Thin as the walk tests it: layered nodes spanning layers of
            // both windings.
            if only_layers && layers.len() > 1 && hi - lo < 0.5 * node.radius as f64 {
                thin_layered += 1;
            }
        }
        // 630 with the signs aligned, 184 adding normals as wound.
        assert!(
            thin_layered > 400,
            "{thin_layered} thin nodes across layers"
        );
    }

    /// Octahedral codes decode to unit vectors within a snorm step of the
    /// direction encoded, in every octant.
    #[test]
    fn octahedral_codes_round_trip() {
        let mut next = rng(7);
        for _ in 0..10_000 {
            let u = unit([next() - 0.5, next() - 0.5, next() - 0.5]);
            let v = oct_decode(unpack_snorm2x16(oct_encode(DVec3::from(u)))).map(|x| x as f64);
            assert!((dot(v, v) - 1.0).abs() < 1e-6);
            // Within 1e-4 rad of u.
            assert!(dot(u, unit(v)) > 1.0 - 5e-9, "{u:?} → {v:?}");
        }
        assert_eq!(
            oct_decode(unpack_snorm2x16(oct_encode(DVec3::ZERO))),
            [0.0, 0.0, 1.0]
        );
    }
}

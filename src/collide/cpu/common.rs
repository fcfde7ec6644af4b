//! CPU mirror of `shaders/shared/collide_common.wgsl`: the bindings
//! ([`SceneView`]) and the per-query helpers every `collide_*` kernel
//! shares — the head frame, the distance grids, the slabs, the hull
//! planes, the margins, a triangle's classification ([`head_tri`]) and
//! the exact tests ([`tri_hits_exact`]).
//!
//! Each function and struct here has a twin of the same name in the WGSL
//! file (named in its doc), with the same operations in the same order,
//! so the cpu and gpu backends round identically: the arithmetic is
//! spelled out in `f32` through `crate::geometry`'s helpers, never glam
//! (`geometry/mod.rs` says why). The decoders of the packed node words
//! are the scene's own ([`oct_decode`], [`unpack_snorm2x16`]: the slab
//! builder decodes a normal as every reader does) and are re-exported
//! here beside the rest of what the kernels read.

use crate::geometry::aabb::{overlaps, point_box_distance, triangle_box_overlap};
use crate::geometry::point_in_mesh::ray_crosses;
use crate::geometry::tri_tri::TriPlane;
use crate::geometry::tri_tri_distance::{plane_separates, tri_tri_closer_than};
use crate::geometry::{dot, length, sub, vmax, vmin, V3};
use crate::scene::slab::Slab;
use crate::scene::{GpuHeadParams, GpuNode, GpuPartNode, GpuQuery, GpuTriangle, Scene};

/// Twins of `oct_decode` (`collide_common.wgsl`), of WGSL's
/// `unpack2x16snorm` and of its `unpack2x16float` of a support-map word,
/// defined beside the scene's encoders.
pub use crate::scene::slab::{oct_decode, support_pair, unpack_snorm2x16};
/// `SUPPORT_SIDE` and `STACK_SIZE` of `collide_common.wgsl`, defined with
/// the buffers they size.
pub use crate::scene::{gpu_types::STACK_SIZE, slab::SUPPORT_SIDE};

/// Borrowed views of the scene arrays, exactly what the shader binds.
///
/// Twin: the `@group(0)` bindings of `collide_common.wgsl`.
#[derive(Clone, Copy)]
pub struct SceneView<'a> {
    /// Part BVH nodes (spheres).
    pub nodes: &'a [GpuPartNode],
    /// Part triangles.
    pub tris: &'a [GpuTriangle],
    /// Head scalars.
    pub head: &'a GpuHeadParams,
    /// Head BVH nodes.
    pub head_nodes: &'a [GpuNode],
    /// Head triangles, head frame.
    pub head_tris: &'a [GpuTriangle],
    /// Head triangles, ray space.
    pub head_ray_tris: &'a [GpuTriangle],
    /// Head distance grid.
    pub grid: &'a [f32],
    /// Part nodes' slabs, decoded (no twin: the kernels decode the
    /// node's words where they test them; the values are the same).
    pub slabs: &'a [Slab],
    /// The head's support map, its words decoded (no twin: the kernels
    /// unpack the word they read, [`support_pair`];
    /// [`crate::scene::Head::support`]).
    pub support: &'a [[f32; 2]],
}

impl<'a> SceneView<'a> {
    /// View of a built scene.
    pub fn new(scene: &'a Scene) -> Self {
        SceneView {
            nodes: &scene.part_nodes,
            tris: &scene.part_tris,
            head: &scene.head.params,
            head_nodes: &scene.head.nodes,
            head_tris: &scene.head.triangles,
            head_ray_tris: &scene.head.ray_triangles,
            grid: &scene.head.grid,
            slabs: &scene.part_slabs,
            support: &scene.head.support,
        }
    }
}

/// Part frame → head frame: `Rᵀ (p − tip)`.
///
/// Twin: `to_head` (`collide_common.wgsl`).
#[inline(always)]
pub fn to_head(q: &GpuQuery, p: V3) -> V3 {
    let d = [
        p[0] - q.rows[0][3],
        p[1] - q.rows[1][3],
        p[2] - q.rows[2][3],
    ];
    let r = &q.rows;
    [
        dot([r[0][0], r[0][1], r[0][2]], d),
        dot([r[1][0], r[1][1], r[1][2]], d),
        dot([r[2][0], r[2][1], r[2][2]], d),
    ]
}

/// What the head's grids say at a point (the kernels' `GridSample`).
///
/// Twin: `GridSample` (`collide_common.wgsl`).
#[derive(Clone, Copy, Debug)]
pub struct GridSample {
    /// The fine grid's signed distance where it holds the point, else the
    /// far grid's unsigned one (everything there is outside the head),
    /// else the distance to the head's box.
    pub v: f32,
    /// The cell holding the point, its grid's origin and cell size; `None`
    /// beyond both grids.
    pub(crate) cell: Option<([u32; 3], V3, f32)>,
}

/// The head's grids at `c` (head frame), one grid read (the kernels'
/// `grid_sample`: on lavapipe a read with a per-query index is a loop over
/// the SIMD lanes, so they pick the grid first and read once).
///
/// Twin: `grid_sample` (`collide_common.wgsl`).
#[inline(always)]
pub fn grid_sample(h: &GpuHeadParams, grid: &[f32], c: V3) -> GridSample {
    if let Some(ijk @ [ix, iy, iz]) = grid_cell(c, h.grid_origin, h.inv_cell, h.grid_dims) {
        let [nx, ny, _] = h.grid_dims;
        return GridSample {
            v: grid[((iz * ny + iy) * nx + ix) as usize],
            cell: Some((ijk, h.grid_origin, h.cell)),
        };
    }
    if let Some(ijk @ [ix, iy, iz]) = grid_cell(c, h.far_origin, h.far_inv_cell, h.far_dims) {
        let [nx, ny, _] = h.far_dims;
        return GridSample {
            v: grid[(h.far_offset + (iz * ny + iy) * nx + ix) as usize],
            cell: Some((ijk, h.far_origin, h.far_cell)),
        };
    }
    GridSample {
        v: point_box_distance(c, h.aabb_min, h.aabb_max),
        cell: None,
    }
}

/// Classify the sphere `(c, r)` (head frame) against the head:
/// 1 = wholly outside and more than `margin` from the head's surface,
/// -1 = wholly inside, 0 = cannot tell.
///
/// Twin: `classify` (`collide_common.wgsl`).
#[inline(always)]
pub fn classify(h: &GpuHeadParams, grid: &[f32], c: V3, r: f32, margin: f32) -> i32 {
    classify_sample(h, &grid_sample(h, grid, c), c, r, margin)
}

/// [`classify`] from the grid sample `g` at `c`. In the far grid `v >= 0`,
/// so the fine grid's formula serves it too; beyond both grids, the box.
///
/// Twin: `classify_sample` (`collide_common.wgsl`).
#[inline(always)]
pub fn classify_sample(h: &GpuHeadParams, g: &GridSample, c: V3, r: f32, margin: f32) -> i32 {
    let Some((ijk, origin, size)) = g.cell else {
        return if g.v - h.grid_slack - margin > r {
            1
        } else {
            0
        };
    };
    // Decisive when |v| − |c − centre| − grid_slack > r, plus the query's
    // margin on the outside. (x − 0 is exact, so margin 0 rounds as if the
    // term were absent.)
    let m = if g.v < 0.0 { 0.0 } else { margin };
    let slack = g.v.abs() - h.grid_slack - r - m;
    if !clears_centre(c, origin, size, ijk, slack) {
        0
    } else if g.v < 0.0 {
        -1
    } else {
        1
    }
}

/// The cube-map cell of direction `u` (any length > 0): face `0..6`
/// (axis `k`, `+` then `−`) and the cell in it, as one index.
///
/// Twin: `support_cell` (`collide_common.wgsl`).
#[inline(always)]
pub fn support_cell(u: [f32; 3]) -> u32 {
    let (face, s, t) = support_face(u);
    let n = SUPPORT_SIDE as f32;
    // Clamped to [0, n − 1] as `clamp` would, and a NaN (`u` of length 0)
    // to 0 as the saturating cast takes it: `max` and `min` return the
    // operand that is a number.
    let cell = |x: f32| {
        let x = x.max(0.0).min(n - 1.0);
        // SAFETY: x is a number in [0, n − 1], its integer part a `u32`.
        unsafe { x.to_int_unchecked::<u32>() }
    };
    (face * SUPPORT_SIDE + cell(t)) * SUPPORT_SIDE + cell(s)
}

/// The cube-map face of direction `u` and the position in it, in cells,
/// before it is clamped to the face and cut to a cell: [`support_cell`]'s
/// first steps.
#[inline(always)]
fn support_face(u: [f32; 3]) -> (u32, f32, f32) {
    let a = [u[0].abs(), u[1].abs(), u[2].abs()];
    let (k, i, j) = if a[0] >= a[1] && a[0] >= a[2] {
        (0usize, 1usize, 2usize)
    } else if a[1] >= a[2] {
        (1, 2, 0)
    } else {
        (2, 0, 1)
    };
    let face = 2 * k as u32 + if u[k] < 0.0 { 1 } else { 0 };
    let inv = 1.0 / a[k];
    let n = SUPPORT_SIDE as f32;
    (
        face,
        (u[i] * inv + 1.0) * 0.5 * n,
        (u[j] * inv + 1.0) * 0.5 * n,
    )
}

/// Does the node's slab ([`crate::scene::slab`]) lie wholly on one side
/// of the head, farther than `margin` from it?
///
/// Twin: `slab_clear` (`collide_common.wgsl`).
#[inline(always)]
pub fn slab_clear(
    h: &GpuHeadParams,
    grid: &[f32],
    q: &GpuQuery,
    node: &GpuPartNode,
    margin: f32,
) -> bool {
    slab_gap(h, grid, q, node) - h.grid_slack > margin
}

/// How far the node's slab lies from the head along its normal: the gap
/// between the node's interval of `n · (x − tip)` and the head's
/// `[−h(−n), h(n)]` (support map, head frame), on whichever side it is
/// larger; `−1` for slabs thicker than half the node's radius, which are
/// not tested.
///
/// Twin: `slab_gap` (`collide_common.wgsl`).
#[inline(always)]
pub fn slab_gap(h: &GpuHeadParams, grid: &[f32], q: &GpuQuery, node: &GpuPartNode) -> f32 {
    slab_gap_by(q, node, &Slab::of(node), |cell| {
        support_pair(grid[(h.support_offset + cell) as usize])
    })
}

/// [`slab_gap`] with the node's slab and the support map's words decoded
/// beforehand (the cpu backend's walk reads [`SceneView::slabs`] and
/// [`SceneView::support`]).
#[inline(always)]
pub fn slab_gap_of(support: &[[f32; 2]], q: &GpuQuery, node: &GpuPartNode, slab: &Slab) -> f32 {
    slab_gap_by(q, node, slab, |cell| support[cell as usize])
}

/// [`slab_gap`] of `slab`, `pair(cell)` the bounds of `h(u)` and `h(−u)`
/// of the support map's cell `cell` ([`support_cell`]).
#[inline(always)]
fn slab_gap_by(
    q: &GpuQuery,
    node: &GpuPartNode,
    slab: &Slab,
    pair: impl Fn(u32) -> [f32; 2],
) -> f32 {
    let [lo, hi] = slab.range;
    if hi - lo >= 0.5 {
        return -1.0;
    }
    let n = slab.normal;
    // The node's interval along n from the tip (part frame) ...
    let o = n[0] * (node.center[0] - q.rows[0][3])
        + n[1] * (node.center[1] - q.rows[1][3])
        + n[2] * (node.center[2] - q.rows[2][3]);
    let lo = o + lo * node.radius;
    let hi = o + hi * node.radius;
    // ... and the head's along n in its own frame.
    let nh = [
        q.rows[0][0] * n[0] + q.rows[0][1] * n[1] + q.rows[0][2] * n[2],
        q.rows[1][0] * n[0] + q.rows[1][1] * n[1] + q.rows[1][2] * n[2],
        q.rows[2][0] * n[0] + q.rows[2][1] * n[1] + q.rows[2][2] * n[2],
    ];
    let [above, below] = pair(support_cell(nh));
    (-below - hi).max(lo - above)
}

/// Does the node lie farther than `margin` from the head, beyond the hull
/// plane of the cell holding its centre `c` (head frame)? See
/// [`node_hull_gap`].
///
/// Twin: `node_hull_clear` (`collide_common.wgsl`).
#[inline(always)]
pub fn node_hull_clear(
    h: &GpuHeadParams,
    grid: &[f32],
    q: &GpuQuery,
    node: &GpuPartNode,
    c: V3,
    margin: f32,
) -> bool {
    node_hull_gap(h, grid, q, node, c) - h.grid_slack > margin
}

/// How far the node lies beyond the hull plane `n · x = h` of the cell
/// holding its centre `c` (head frame; `scene::hull_plane`): the least
/// `n · x − h` over the points `x` of its sphere that its slab allows
/// (`scene::slab`). With `α = n · m` for the slab's normal `m` (head
/// frame), `β = √(1 − α²)`, a point `c + a m + y` (`y ⊥ m`, `|y| ≤ √(r² −
/// a²)`, `a` in the slab's interval) has `n · x ≥ n · c + α a − β √(r² −
/// a²)`, least at `a = −α r` clamped to the interval. A flat node beside
/// a tilted head's flank, nearly parallel to it, is bounded by about its
/// distance, where its sphere alone reaches into the head. `β` is
/// taken from `1 − α² + 10⁻⁶` (the f32 normals are unit only within
/// rounding, and `√` is steep near 0), and `10⁻⁵ r` more is given up for
/// the rest of the rounding.
///
/// Twin: `node_hull_gap` (`collide_common.wgsl`).
#[inline(always)]
pub fn node_hull_gap(
    h: &GpuHeadParams,
    grid: &[f32],
    q: &GpuQuery,
    node: &GpuPartNode,
    c: V3,
) -> f32 {
    node_hull_gap_of(h, grid, q, node, &Slab::of(node), c)
}

/// [`node_hull_gap`] with the node's slab decoded beforehand (the cpu
/// backend's walk reads [`SceneView::slabs`]).
#[inline(always)]
pub fn node_hull_gap_of(
    h: &GpuHeadParams,
    grid: &[f32],
    q: &GpuQuery,
    node: &GpuPartNode,
    slab: &Slab,
    c: V3,
) -> f32 {
    let Some(k) = hull_plane_at(h, c) else {
        return -1.0;
    };
    let n = [grid[k], grid[k + 1], grid[k + 2]];
    // The slab's normal in the head frame, and its interval in mm.
    let m = slab.normal;
    let mh = [
        q.rows[0][0] * m[0] + q.rows[0][1] * m[1] + q.rows[0][2] * m[2],
        q.rows[1][0] * m[0] + q.rows[1][1] * m[1] + q.rows[1][2] * m[2],
        q.rows[2][0] * m[0] + q.rows[2][1] * m[1] + q.rows[2][2] * m[2],
    ];
    let [lo, hi] = slab.range;
    let r = node.radius;
    let alpha = dot(n, mh).clamp(-1.0, 1.0);
    let beta = (1.0 - alpha * alpha + 1e-6).sqrt();
    let a = (-alpha * r).clamp(lo * r, hi * r);
    let least = alpha * a - beta * (r * r - a * a).max(0.0).sqrt();
    dot(n, c) + least - grid[k + 3] - 1e-5 * r
}

/// Where the hull plane `(n, h)` of the cell holding `p` (head frame)
/// starts in the grid buffer (`scene::hull_plane`); `None` outside the
/// planes' grid.
///
/// Twin: `hull_plane_at` (`collide_common.wgsl`).
#[inline(always)]
pub fn hull_plane_at(h: &GpuHeadParams, p: V3) -> Option<usize> {
    let [ix, iy, iz] = grid_cell(p, h.plane_origin, h.plane_inv_cell, h.plane_dims)?;
    let [nx, ny, _] = h.plane_dims;
    Some((h.plane_offset + 4 * ((iz * ny + iy) * nx + ix)) as usize)
}

/// The cell holding `c` in a grid with corner `origin`, `1 / cell` =
/// `inv_cell` and `dims` cells, or `None` outside it. Any cell gives a
/// valid bound (it is measured from that cell's centre), so the index
/// needs no exact division.
///
/// Twin: `grid_cell` (`collide_common.wgsl`).
#[inline(always)]
pub fn grid_cell(c: V3, origin: V3, inv_cell: f32, dims: [u32; 3]) -> Option<[u32; 3]> {
    let fx = (c[0] - origin[0]) * inv_cell;
    let fy = (c[1] - origin[1]) * inv_cell;
    let fz = (c[2] - origin[2]) * inv_cell;
    let [nx, ny, nz] = dims;
    if !(fx >= 0.0 && fy >= 0.0 && fz >= 0.0 && fx < nx as f32 && fy < ny as f32 && fz < nz as f32)
    {
        return None;
    }
    // SAFETY: each of fx, fy, fz is now a number in [0, n) for its
    // grid's count n of cells, a `u32`: its integer part is a `u32`, at
    // most n − 1, which is what a checked cast and a clamp to n − 1 would
    // give. Unchecked, the cast is one instruction where the saturating
    // one spends five on cases already excluded (the walk looks a grid
    // cell up two or three times a node).
    let cell = |f: f32| unsafe { f.to_int_unchecked::<u32>() };
    Some([cell(fx), cell(fy), cell(fz)])
}

/// Is `slack` positive and larger than the distance from `c` to the centre
/// of cell `ijk` (squared, to skip a sqrt)?
///
/// Twin: `clears_centre` (`collide_common.wgsl`).
#[inline(always)]
pub fn clears_centre(c: V3, origin: V3, cell: f32, [ix, iy, iz]: [u32; 3], slack: f32) -> bool {
    if slack <= 0.0 {
        return false;
    }
    let d = [
        c[0] - (origin[0] + (ix as f32 + 0.5) * cell),
        c[1] - (origin[1] + (iy as f32 + 0.5) * cell),
        c[2] - (origin[2] + (iz as f32 + 0.5) * cell),
    ];
    slack * slack > d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
}

/// Does the triangle `(a, b, c)` (head frame) cross a head triangle
/// (Möller), or, with a positive `margin`, come closer than the margin to
/// one? One walk of the head BVH, the boxes grown by the contact tolerance
/// plus the margin (exactly the tolerance at margin 0); per head
/// triangle, Möller first, then — margin > 0 only — the head triangle
/// against the part triangle's plane (Möller's own plane, so the dot
/// products are shared: farther than the margin on one side settles most
/// pairs), the two triangles' boxes grown by the same
/// amount, and [`tri_tri_closer_than`] (the other plane, the edge axes,
/// then the exact distance). Crossing and nearness share the walk because
/// a second walk per undecided triangle cost more than the distance tests
/// themselves.
///
/// Twin: `tri_crosses_head` (`collide_common.wgsl`).
#[inline(always)]
pub fn tri_crosses_head(s: &SceneView, a: V3, b: V3, c: V3, margin: f32) -> bool {
    let tol = s.head.tol;
    let grow = margin + tol;
    let plane = TriPlane::new(a, b, c, tol);
    let lim = margin * margin * dot(plane.n, plane.n);
    let tmin = vmin(vmin(a, b), c);
    let tmax = vmax(vmax(a, b), c);
    let lo = [tmin[0] - grow, tmin[1] - grow, tmin[2] - grow];
    let hi = [tmax[0] + grow, tmax[1] + grow, tmax[2] + grow];
    let mut stack = [0u32; STACK_SIZE];
    let mut sp = 1usize;
    while sp > 0 {
        sp -= 1;
        let node = s.head_nodes[stack[sp] as usize];
        if !triangle_box_overlap(a, b, c, grow, node.min, node.max) {
            continue;
        }
        match node.leaf_range() {
            Some((first, count)) => {
                for t in first..first + count {
                    let h = &s.head_tris[t as usize];
                    if plane.overlaps(a, b, c, h.v0, h.v1, h.v2, tol) {
                        return true;
                    }
                    if margin > 0.0 && !plane_separates(plane.n, plane.d, lim, h.v0, h.v1, h.v2) {
                        let hmin = vmin(vmin(h.v0, h.v1), h.v2);
                        let hmax = vmax(vmax(h.v0, h.v1), h.v2);
                        if overlaps(lo, hi, hmin, hmax)
                            && tri_tri_closer_than(a, b, c, h.v0, h.v1, h.v2, margin)
                        {
                            return true;
                        }
                    }
                }
            }
            None => {
                stack[sp] = node.packed;
                stack[sp + 1] = node.packed + 1;
                sp += 2;
            }
        }
    }
    false
}

/// Ray parity from `p` (head frame) along the head's ray direction, over
/// the head BVH.
///
/// Twin: `point_in_head` (`collide_common.wgsl`).
#[inline(always)]
pub fn point_in_head(s: &SceneView, p: V3) -> bool {
    let h = s.head;
    let pr = [
        h.ray_a[0] * p[0] + h.ray_a[1] * p[1] + h.ray_a[2] * p[2],
        h.ray_b[0] * p[0] + h.ray_b[1] * p[1] + h.ray_b[2] * p[2],
        h.ray_d[0] * p[0] + h.ray_d[1] * p[1] + h.ray_d[2] * p[2],
    ];
    let inv = h.inv_ray;
    let tol = h.tol;
    let mut inside = false;
    let mut stack = [0u32; STACK_SIZE];
    let mut sp = 1usize;
    while sp > 0 {
        sp -= 1;
        let node = s.head_nodes[stack[sp] as usize];
        // Slab test on the box grown by `tol` (the direction has no zero
        // component), conservative: parity needs every crossed triangle.
        let t0x = (node.min[0] - tol - p[0]) * inv[0];
        let t1x = (node.max[0] + tol - p[0]) * inv[0];
        let t0y = (node.min[1] - tol - p[1]) * inv[1];
        let t1y = (node.max[1] + tol - p[1]) * inv[1];
        let t0z = (node.min[2] - tol - p[2]) * inv[2];
        let t1z = (node.max[2] + tol - p[2]) * inv[2];
        let tmin = t0x.min(t1x).max(t0y.min(t1y)).max(t0z.min(t1z)).max(0.0);
        let tmax = t0x.max(t1x).min(t0y.max(t1y)).min(t0z.max(t1z));
        if tmax < tmin {
            continue;
        }
        match node.leaf_range() {
            Some((first, count)) => {
                for t in first..first + count {
                    let r = &s.head_ray_tris[t as usize];
                    if ray_crosses(r.v0, r.v1, r.v2, pr) {
                        inside = !inside;
                    }
                }
            }
            None => {
                stack[sp] = node.packed;
                stack[sp + 1] = node.packed + 1;
                sp += 2;
            }
        }
    }
    inside
}

/// The margin everything inside the sphere `(c, r)` (head frame) must at
/// least keep: the query's margin grown by its slope at the sphere's
/// farthest point from the tip (no triangle inside needs more).
///
/// Twin: `sphere_margin` (`collide_common.wgsl`).
#[inline(always)]
pub fn sphere_margin(q: &GpuQuery, c: V3, r: f32) -> f32 {
    if q.slope > 0.0 {
        q.margin + q.slope * (length(c) + r)
    } else {
        q.margin
    }
}

/// The margin the triangle `(a, b, c)` (head frame) must keep: the query's
/// margin grown by its slope at the corner farthest from the tip.
///
/// Twin: `triangle_margin` (`collide_common.wgsl`).
#[inline(always)]
pub fn triangle_margin(q: &GpuQuery, a: V3, b: V3, c: V3) -> f32 {
    if q.slope > 0.0 {
        q.margin + q.slope * length(a).max(length(b)).max(length(c))
    } else {
        q.margin
    }
}

/// A triangle moved into the head frame, with its margin and what the
/// grid and the hull plane say of it (the kernels' `HeadTri`).
///
/// Twin: `HeadTri` (`collide_common.wgsl`).
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
///
/// Twin: `head_tri` (`collide_common.wgsl`).
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

/// Does the triangle `abc` (head frame, centroid `m`) lie farther than
/// `margin` from the head, beyond the hull plane of the cell holding `m`
/// (`scene::hull_plane`: every point `x` is at least `n · x − h` from the
/// head's hull, and a triangle is as far as its nearest corner)? Three
/// dot products instead of the exact tests: beside a tilted head's flank
/// the grid's sphere around a triangle reaches into the head, the plane
/// does not.
///
/// Twin: `hull_clear` (`collide_common.wgsl`).
#[inline(always)]
pub fn hull_clear(h: &GpuHeadParams, grid: &[f32], m: V3, [a, b, c]: [V3; 3], margin: f32) -> bool {
    let Some(k) = hull_plane_at(h, m) else {
        return false;
    };
    let n = [grid[k], grid[k + 1], grid[k + 2]];
    let near = dot(n, a).min(dot(n, b)).min(dot(n, c));
    near - grid[k + 3] - h.grid_slack > margin
}

/// The exact tests for a triangle (head frame) the grid could not settle:
/// crossing (or, with a positive margin, coming within it), then
/// containment.
///
/// Twin: `tri_hits_exact` (`collide_common.wgsl`).
#[inline(always)]
pub fn tri_hits_exact(s: &SceneView, a: V3, b: V3, c: V3, margin: f32) -> bool {
    if tri_crosses_head(s, a, b, c, margin) {
        return true;
    }
    // A triangle that crosses nothing is wholly inside or wholly outside.
    let cls = classify(s.head, s.grid, a, 0.0, 0.0);
    if cls != 0 {
        return cls < 0;
    }
    point_in_head(s, a)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::collide::brute::BruteBackend;
    use crate::collide::cpu::query_hits;
    use crate::collide::sample::tilted_queries;
    use crate::collide::Query;
    use crate::geometry::FUSED;

    /// `f` with every multiply-add of the mirror fused, on this thread.
    fn fused<T>(f: impl FnOnce() -> T) -> T {
        FUSED.with(|x| x.set(true));
        let out = f();
        FUSED.with(|x| x.set(false));
        out
    }

    /// The cell lookups' unchecked casts give what checked, clamped casts
    /// give (the kernels' `u32(…)` of a value clamped in range): a grid
    /// cell for points inside, on the faces and corners, just outside,
    /// far off, infinite and NaN; a support cell for directions of every
    /// sign and size, on the cube's edges and corners, and of length 0
    /// or NaN.
    #[test]
    fn cell_lookups_give_the_checked_casts_cells() {
        let checked_grid = |c: V3, origin: V3, inv_cell: f32, dims: [u32; 3]| {
            let f: [f32; 3] = std::array::from_fn(|k| (c[k] - origin[k]) * inv_cell);
            let inside = (0..3).all(|k| f[k] >= 0.0 && f[k] < dims[k] as f32);
            inside.then(|| std::array::from_fn(|k| (f[k] as u32).min(dims[k] - 1)))
        };
        let checked_support = |u: [f32; 3]| {
            let (face, s, t) = support_face(u);
            let n = SUPPORT_SIDE as f32;
            let cell = |x: f32| x.clamp(0.0, n - 1.0) as u32;
            (face * SUPPORT_SIDE + cell(t)) * SUPPORT_SIDE + cell(s)
        };
        let mut uniform = crate::geometry::xorshift(0x5eed_1234_abcd_0004);
        let mut next = || uniform() as f32;
        let (origin, inv_cell, dims) = ([-3.0, -2.0, -5.0], 4.0, [24, 16, 40]);
        let specials = [
            0.0,
            -0.0,
            1e-30,
            -1e-30,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
        ];
        let (mut inside, mut outside) = (0, 0);
        for i in 0..20_000 {
            let mut c: V3 = std::array::from_fn(|k| {
                origin[k] + (1.4 * next() - 0.2) * dims[k] as f32 / inv_cell
            });
            match i % 5 {
                // On a face or corner of the grid, or of a cell.
                0 => c[i % 3] = origin[i % 3],
                1 => c[i % 3] = origin[i % 3] + dims[i % 3] as f32 / inv_cell,
                2 => c[i % 3] = origin[i % 3] + (i % 7) as f32 / inv_cell,
                3 => c[i % 3] = specials[i % specials.len()],
                _ => {}
            }
            let want = checked_grid(c, origin, inv_cell, dims);
            assert_eq!(grid_cell(c, origin, inv_cell, dims), want, "point {c:?}");
            if want.is_some() {
                inside += 1
            } else {
                outside += 1
            }
        }
        assert!(
            inside > 5_000 && outside > 5_000,
            "{inside} inside, {outside} outside"
        );
        for i in 0..20_000usize {
            let scale = 10f32.powi((i % 7) as i32 - 3);
            let mut u: [f32; 3] = std::array::from_fn(|_| (2.0 * next() - 1.0) * scale);
            match i % 4 {
                0 => u[i % 3] = u[(i + 1) % 3],
                1 => u = [u[0], -u[0], u[0]],
                2 => u[i % 3] = specials[i % specials.len()],
                _ => {}
            }
            assert_eq!(support_cell(u), checked_support(u), "direction {u:?}");
        }
        for u in [
            [0.0; 3],
            [f32::NAN; 3],
            [-0.0, 0.0, -0.0],
            [1.0, f32::NAN, 0.0],
        ] {
            assert_eq!(support_cell(u), checked_support(u), "direction {u:?}");
        }
    }

    /// A GPU may fuse multiply-adds (WGSL allows it; Vulkan drivers do),
    /// lavapipe does not. The mirror with the multiply-adds of its dot and
    /// cross products and frame changes fused — the head frame, every
    /// plane, grid cell, slab, hull-plane and Möller value derived from
    /// them — flips verdicts only at near-contacts: wherever it disagrees
    /// with the plain arithmetic, the nearest existing triangle is within
    /// 1e-3 mm of the margin (brute force in f64). Asked on the default
    /// job's tilted poses at plain margins, and at each pose's own
    /// clearance (the margin set to its distance: a contact rounding
    /// decides).
    #[test]
    fn fused_multiply_adds_flip_verdicts_only_at_near_contacts() {
        let scene = crate::default_job::scene();
        let view = SceneView::new(&scene);
        let brute = BruteBackend::new(&scene);
        let poses = tilted_queries(&scene.waypoint_queries, 1_200, 3);
        let mut queries: Vec<Query> = [0.0, 0.05, 0.3]
            .iter()
            .flat_map(|&margin| poses.iter().map(move |q| Query { margin, ..*q }))
            .collect();
        let at_contact: Vec<Query> = poses
            .iter()
            .filter_map(|q| {
                let d = brute.margin_slack(&Query { margin: 0.0, ..*q }, 2.0);
                (d > 0.0 && d < 2.0).then_some(Query {
                    margin: d as f32,
                    ..*q
                })
            })
            .collect();
        assert!(
            at_contact.len() > 100,
            "{} poses near the part",
            at_contact.len()
        );
        queries.extend(&at_contact);
        let gpu: Vec<GpuQuery> = queries.iter().map(|q| q.to_gpu()).collect();
        let plain: Vec<bool> = gpu.iter().map(|q| query_hits(&view, q)).collect();
        let fma: Vec<bool> = fused(|| gpu.iter().map(|q| query_hits(&view, q)).collect());
        // The fused arithmetic is in force: frame changes round otherwise.
        let probe = view.tris[view.tris.len() / 2].v0;
        let framed: Vec<V3> = gpu.iter().map(|q| to_head(q, probe)).collect();
        let framed_fma: Vec<V3> = fused(|| gpu.iter().map(|q| to_head(q, probe)).collect());
        let moved = framed
            .iter()
            .zip(&framed_fma)
            .filter(|(a, b)| a != b)
            .count();
        assert!(
            moved * 4 > gpu.len(),
            "fused frame changes differ in {moved} of {}",
            gpu.len()
        );
        let flips: Vec<(usize, f64)> = (0..queries.len())
            .filter(|&i| plain[i] != fma[i])
            .map(|i| (i, brute.margin_slack(&queries[i], 0.01)))
            .collect();
        let worst = flips.iter().map(|f| f.1.abs()).fold(0.0, f64::max);
        eprintln!(
            "{} queries ({} at their own clearance), {} colliding: {} flip fused, the farthest {worst:.2e} mm from its margin",
            queries.len(),
            at_contact.len(),
            plain.iter().filter(|&&h| h).count(),
            flips.len()
        );
        for &(i, slack) in &flips {
            assert!(
                slack.abs() < 1e-3,
                "query {i} flips {slack} mm from its margin: {:?}",
                queries[i]
            );
        }
    }
}

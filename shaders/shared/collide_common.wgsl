// Bindings and per-query helpers shared by the collide_* kernels (one
// pipeline layout serves them all; src/collide/gpu/resources.rs builds it).
// Mirrored function for function by src/collide/cpu/common.rs.

// The batch's scalars. Keep in sync with src/collide/gpu/wire.rs (GpuParams).
struct Params {
    // Elements per part-node / part-triangle binding (scenes larger than one
    // storage binding are split across several).
    nodes_per_chunk: u32,
    tris_per_chunk: u32,
    query_count: u32,
    // Capacity of the candidate list.
    capacity: u32,
    // 0: the batch's first walk; 1: a resumed walk (collide_traverse).
    resume: u32,
    // The most candidates one query hands over in one pass.
    per_query: u32,
    pad1: u32,
    pad2: u32,
}

// The per-query result word. Keep in sync with src/collide/gpu/wire.rs
// (RESULT_*): bit 0 the query
// collides, bit 1 some of its candidates found the list full, the bits
// above RESULT_STORED_SHIFT how many of its candidates (in walk order)
// have been handed to collide_exact.
const RESULT_HIT: u32 = 1u;
const RESULT_INCOMPLETE: u32 = 2u;
const RESULT_STORED_SHIFT: u32 = 2u;

// Candidate counter, then the indirect dispatch size of collide_exact,
// then the next query a persistent lane takes (traverse_persistent.wgsl).
struct Control {
    count: atomic<u32>,
    args: array<u32, 3>,
    next: atomic<u32>,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<uniform> head: HeadParams;
@group(0) @binding(2) var<storage, read> queries: array<Query>;
@group(0) @binding(3) var<storage, read_write> results: array<atomic<u32>>;
@group(0) @binding(4) var<storage, read> head_nodes: array<Node>;
@group(0) @binding(5) var<storage, read> head_tris: array<Triangle>;
@group(0) @binding(6) var<storage, read> head_ray_tris: array<Triangle>;
// The head's grids, support map and hull planes, one array of 32-bit words
// read four at a time: a plane (n, h) is one read (`grid4`), as is any
// value (`grid_at`) or a support map's pair of halves (`grid_word`).
// Words, not f32: a pair of halves is no f32 a driver must keep bit for
// bit. On lavapipe every read with a per-query index is a loop over the
// SIMD lanes, so reads are few: a plane is one vec4 read, not four
// floats; classify reads one grid, not two; the support map's two sides
// are one word.
@group(0) @binding(7) var<storage, read> grid: array<vec4<u32>>;
@group(0) @binding(8) var<storage, read> part_nodes0: array<PartNode>;
@group(0) @binding(9) var<storage, read> part_nodes1: array<PartNode>;
@group(0) @binding(10) var<storage, read> part_tris0: array<Triangle>;
@group(0) @binding(11) var<storage, read> part_tris1: array<Triangle>;
@group(0) @binding(12) var<storage, read> part_tris2: array<Triangle>;
@group(0) @binding(13) var<storage, read> part_tris3: array<Triangle>;
// (query, triangle) pairs the traversal could not settle.
@group(0) @binding(14) var<storage, read_write> candidates: array<vec2<u32>>;
@group(0) @binding(15) var<storage, read_write> control: Control;

const STACK_SIZE: u32 = 64u;
// Cells per cube-map face side of the head's support map (src/scene/slab.rs
// SUPPORT_SIDE).
const SUPPORT_SIDE: u32 = 32u;
// Whether tri_crosses_head has the margin's distance tests at all. The host
// builds collide_exact twice and runs the variant without them on batches
// whose queries all have margin 0: lavapipe evaluates the body of a branch
// even when no invocation takes it, so margin-0 batches would pay for the
// distance tests they never use. With the tests compiled in, a query with
// margin 0 still skips them, as common.rs does.
override MARGIN_TESTS: bool = true;
const WORKGROUP: u32 = 64u;

// How many of the part node and part triangle bindings the scene fills
// (1..=2 and 1..=4; the host builds the pipelines for its scene). Reads
// past those are compiled out: lavapipe, which runs every branch of a
// SIMD lane group, would otherwise fetch a triangle four times and a node
// twice.
override NODE_BINDINGS: u32 = 2u;
override TRI_BINDINGS: u32 = 4u;

// (Compared, not divided: an integer division per node and triangle read
// is scalar code on a SIMD adapter such as lavapipe.)
fn part_node(i: u32) -> PartNode {
    if NODE_BINDINGS == 1u || i < params.nodes_per_chunk {
        return part_nodes0[i];
    }
    return part_nodes1[i - params.nodes_per_chunk];
}

fn part_tri(i: u32) -> Triangle {
    let n = params.tris_per_chunk;
    if TRI_BINDINGS == 1u || i < n {
        return part_tris0[i];
    }
    if TRI_BINDINGS == 2u || i < 2u * n {
        return part_tris1[i - n];
    }
    if TRI_BINDINGS == 3u || i < 3u * n {
        return part_tris2[i - 2u * n];
    }
    return part_tris3[i - 3u * n];
}

// The head grid's value at i (an index into it as f32s, as in common.rs).
fn grid_at(i: u32) -> f32 {
    return bitcast<f32>(grid[i >> 2u][i & 3u]);
}

// The head grid's word at i, as stored.
fn grid_word(i: u32) -> u32 {
    return grid[i >> 2u][i & 3u];
}

// The four values of the head grid from i, a multiple of 4 (a hull plane).
fn grid4(i: u32) -> vec4<f32> {
    return bitcast<vec4<f32>>(grid[i >> 2u]);
}

fn to_head(q: Query, p: vec3<f32>) -> vec3<f32> {
    let d = vec3<f32>(p.x - q.rows[0].w, p.y - q.rows[1].w, p.z - q.rows[2].w);
    return vec3<f32>(
        q.rows[0].x * d.x + q.rows[0].y * d.y + q.rows[0].z * d.z,
        q.rows[1].x * d.x + q.rows[1].y * d.y + q.rows[1].z * d.z,
        q.rows[2].x * d.x + q.rows[2].y * d.y + q.rows[2].z * d.z,
    );
}

// What the head's grids say at c (common.rs `grid_sample`): the fine grid's
// signed distance where it holds c; beyond it the far grid's unsigned one
// (everything there is outside the head); beyond that the distance to the
// head's box (`cell.w == 0`). The grid is chosen first and read once.
struct GridSample {
    v: f32,
    cell: vec4<u32>,
    origin: vec3<f32>,
    size: f32,
}

fn grid_sample(c: vec3<f32>) -> GridSample {
    let fine = grid_cell(c, head.grid_origin, head.inv_cell, head.grid_dims);
    let far = grid_cell(c, head.far_origin, head.far_inv_cell, head.far_dims);
    let in_fine = fine.w != 0u;
    let cell = select(far, fine, in_fine);
    let dims = select(head.far_dims, head.grid_dims, in_fine);
    let first = select(head.far_offset, 0u, in_fine);
    let v = grid_at(first + (cell.z * dims.y + cell.y) * dims.x + cell.x);
    let d = point_box_distance(c, head.aabb_min, head.aabb_max);
    return GridSample(
        select(d, v, cell.w != 0u),
        cell,
        select(head.far_origin, head.grid_origin, in_fine),
        select(head.far_cell, head.cell, in_fine),
    );
}

// common.rs `classify`: 1 = the sphere (c, r) wholly outside the head and
// more than `margin` from its surface, -1 = wholly inside, 0 = cannot
// tell.
fn classify(c: vec3<f32>, r: f32, margin: f32) -> i32 {
    return classify_sample(grid_sample(c), c, r, margin);
}

// common.rs `classify_sample`: `classify` from the grid sample at c. In the
// far grid v >= 0, so the fine grid's formula serves it too.
fn classify_sample(g: GridSample, c: vec3<f32>, r: f32, margin: f32) -> i32 {
    if g.cell.w == 0u {
        if g.v - head.grid_slack - margin > r {
            return 1;
        }
        return 0;
    }
    let m = select(margin, 0.0, g.v < 0.0);
    let slack = abs(g.v) - head.grid_slack - r - m;
    if !clears_centre(c, g.origin, g.size, g.cell.xyz, slack) {
        return 0;
    }
    if g.v < 0.0 {
        return -1;
    }
    return 1;
}

// src/scene/slab.rs `oct_decode` (re-exported by common.rs): the unit
// vector of an octahedral code.
fn oct_decode(p: vec2<f32>) -> vec3<f32> {
    var v = vec3<f32>(p.x, p.y, 1.0 - abs(p.x) - abs(p.y));
    let t = max(-v.z, 0.0);
    v.x += select(t, -t, v.x >= 0.0);
    v.y += select(t, -t, v.y >= 0.0);
    let inv = 1.0 / sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
    return vec3<f32>(v.x * inv, v.y * inv, v.z * inv);
}

// common.rs `support_cell`: the support map's cell of direction u.
fn support_cell(u: vec3<f32>) -> u32 {
    let a = abs(u);
    var k = 2u;
    var i = 0u;
    var j = 1u;
    if a.x >= a.y && a.x >= a.z {
        k = 0u;
        i = 1u;
        j = 2u;
    } else if a.y >= a.z {
        k = 1u;
        i = 2u;
        j = 0u;
    }
    let face = 2u * k + select(0u, 1u, u[k] < 0.0);
    let inv = 1.0 / a[k];
    let n = f32(SUPPORT_SIDE);
    let s = u32(clamp((u[i] * inv + 1.0) * 0.5 * n, 0.0, n - 1.0));
    let t = u32(clamp((u[j] * inv + 1.0) * 0.5 * n, 0.0, n - 1.0));
    return (face * SUPPORT_SIDE + t) * SUPPORT_SIDE + s;
}

// common.rs `slab_clear`: the node's slab wholly on one side of the head,
// farther than margin.
fn slab_clear(q: Query, node: PartNode, margin: f32) -> bool {
    return slab_gap(q, node) - head.grid_slack > margin;
}

// common.rs `slab_gap`: how far the node's slab lies from the head along its
// normal (-1 for slabs thicker than half the radius).
fn slab_gap(q: Query, node: PartNode) -> f32 {
    let range = unpack2x16snorm(node.slab_range);
    if range.y - range.x >= 0.5 {
        return -1.0;
    }
    let n = oct_decode(unpack2x16snorm(node.slab_normal));
    let o = n.x * (node.center.x - q.rows[0].w)
        + n.y * (node.center.y - q.rows[1].w)
        + n.z * (node.center.z - q.rows[2].w);
    let lo = o + range.x * node.radius;
    let hi = o + range.y * node.radius;
    let nh = vec3<f32>(
        q.rows[0].x * n.x + q.rows[0].y * n.y + q.rows[0].z * n.z,
        q.rows[1].x * n.x + q.rows[1].y * n.y + q.rows[1].z * n.z,
        q.rows[2].x * n.x + q.rows[2].y * n.y + q.rows[2].z * n.z,
    );
    // The bounds of h(nh) and h(-nh) (slab.rs `support_pairs`).
    let support = unpack2x16float(grid_word(head.support_offset + support_cell(nh)));
    return max(-support.y - hi, lo - support.x);
}

// common.rs `node_hull_clear`: the node farther than margin from the head,
// beyond the hull plane of the cell holding its centre c (head frame).
fn node_hull_clear(q: Query, node: PartNode, c: vec3<f32>, margin: f32) -> bool {
    return node_hull_gap(q, node, c) - head.grid_slack > margin;
}

// common.rs `node_hull_gap`: the least n·x − h over the node's sphere within
// its slab, for the hull plane (n, h) of the cell holding c.
fn node_hull_gap(q: Query, node: PartNode, c: vec3<f32>) -> f32 {
    let k = hull_plane_at(c);
    if k == OUTSIDE_PLANES {
        return -1.0;
    }
    let plane = grid4(k);
    let n = plane.xyz;
    let m = oct_decode(unpack2x16snorm(node.slab_normal));
    let mh = vec3<f32>(
        q.rows[0].x * m.x + q.rows[0].y * m.y + q.rows[0].z * m.z,
        q.rows[1].x * m.x + q.rows[1].y * m.y + q.rows[1].z * m.z,
        q.rows[2].x * m.x + q.rows[2].y * m.y + q.rows[2].z * m.z,
    );
    let range = unpack2x16snorm(node.slab_range);
    let r = node.radius;
    let alpha = clamp(dot3(n, mh), -1.0, 1.0);
    let beta = sqrt(1.0 - alpha * alpha + 1e-6);
    let a = clamp(-alpha * r, range.x * r, range.y * r);
    let least = alpha * a - beta * sqrt(max(r * r - a * a, 0.0));
    return dot3(n, c) + least - plane.w - 1e-5 * r;
}

// hull_plane_at's answer outside the planes' grid (not hull_plane.rs
// `NO_PLANE`, a cell's own "no plane").
const OUTSIDE_PLANES: u32 = 0xffffffffu;

// common.rs `hull_plane_at`: where the hull plane (n, h) of the cell holding p
// (head frame) starts in the grid buffer, or OUTSIDE_PLANES outside the planes'
// grid.
fn hull_plane_at(p: vec3<f32>) -> u32 {
    let cell = grid_cell(p, head.plane_origin, head.plane_inv_cell, head.plane_dims);
    if cell.w == 0u {
        return OUTSIDE_PLANES;
    }
    return head.plane_offset + 4u * ((cell.z * head.plane_dims.y + cell.y) * head.plane_dims.x + cell.x);
}

// common.rs `grid_cell`: the cell holding c (xyz) and w = 1, or w = 0 outside
// the grid.
fn grid_cell(c: vec3<f32>, origin: vec3<f32>, inv_cell: f32, dims: vec3<u32>) -> vec4<u32> {
    let fx = (c.x - origin.x) * inv_cell;
    let fy = (c.y - origin.y) * inv_cell;
    let fz = (c.z - origin.z) * inv_cell;
    if !(fx >= 0.0 && fy >= 0.0 && fz >= 0.0 && fx < f32(dims.x) && fy < f32(dims.y) && fz < f32(dims.z)) {
        return vec4<u32>(0u, 0u, 0u, 0u);
    }
    return vec4<u32>(min(u32(fx), dims.x - 1u), min(u32(fy), dims.y - 1u), min(u32(fz), dims.z - 1u), 1u);
}

// common.rs `clears_centre`.
fn clears_centre(c: vec3<f32>, origin: vec3<f32>, cell: f32, ijk: vec3<u32>, slack: f32) -> bool {
    if slack <= 0.0 {
        return false;
    }
    let dx = c.x - (origin.x + (f32(ijk.x) + 0.5) * cell);
    let dy = c.y - (origin.y + (f32(ijk.y) + 0.5) * cell);
    let dz = c.z - (origin.z + (f32(ijk.z) + 0.5) * cell);
    return slack * slack > dx * dx + dy * dy + dz * dz;
}

// Möller against the head, or, with a positive margin, closer than it:
// one walk with boxes grown by tol + margin (common.rs `tri_crosses_head`).
fn tri_crosses_head(a: vec3<f32>, b: vec3<f32>, c: vec3<f32>, margin: f32) -> bool {
    let tol = head.tol;
    let grow = margin + tol;
    let plane = tri_plane(a, b, c, tol);
    let lim = margin * margin * dot3(plane.n, plane.n);
    let tmin = min(min(a, b), c);
    let tmax = max(max(a, b), c);
    let lo = vec3<f32>(tmin.x - grow, tmin.y - grow, tmin.z - grow);
    let hi = vec3<f32>(tmax.x + grow, tmax.y + grow, tmax.z + grow);
    var stack: array<u32, STACK_SIZE>;
    var sp = 1u;
    stack[0] = 0u;
    var hit = false;
    while sp > 0u && !hit {
        sp -= 1u;
        let node = head_nodes[stack[sp]];
        if triangle_box_overlap(a, b, c, grow, node.min, node.max) {
            if is_leaf(node.packed) {
                let first = leaf_first(node.packed);
                let end = first + leaf_count(node.packed);
                for (var t = first; t < end; t++) {
                    let h = head_tris[t];
                    if tri_plane_overlaps(plane, a, b, c, h.v0, h.v1, h.v2, tol) {
                        hit = true;
                    } else if MARGIN_TESTS {
                        if margin > 0.0 && !plane_separates(plane.n, plane.d, lim, h.v0, h.v1, h.v2) {
                            let hmin = min(min(h.v0, h.v1), h.v2);
                            let hmax = max(max(h.v0, h.v1), h.v2);
                            if boxes_overlap(lo, hi, hmin, hmax)
                                && tri_tri_closer_than(a, b, c, h.v0, h.v1, h.v2, margin) {
                                hit = true;
                            }
                        }
                    }
                }
            } else {
                stack[sp] = node.packed;
                stack[sp + 1u] = node.packed + 1u;
                sp += 2u;
            }
        }
    }
    return hit;
}

fn point_in_head(p: vec3<f32>) -> bool {
    let pr = vec3<f32>(
        head.ray_a.x * p.x + head.ray_a.y * p.y + head.ray_a.z * p.z,
        head.ray_b.x * p.x + head.ray_b.y * p.y + head.ray_b.z * p.z,
        head.ray_d.x * p.x + head.ray_d.y * p.y + head.ray_d.z * p.z,
    );
    let inv = head.inv_ray;
    let tol = head.tol;
    var crossings = 0u;
    var stack: array<u32, STACK_SIZE>;
    var sp = 1u;
    stack[0] = 0u;
    while sp > 0u {
        sp -= 1u;
        let node = head_nodes[stack[sp]];
        let t0x = (node.min.x - tol - p.x) * inv.x;
        let t1x = (node.max.x + tol - p.x) * inv.x;
        let t0y = (node.min.y - tol - p.y) * inv.y;
        let t1y = (node.max.y + tol - p.y) * inv.y;
        let t0z = (node.min.z - tol - p.z) * inv.z;
        let t1z = (node.max.z + tol - p.z) * inv.z;
        let tmin = max(max(max(min(t0x, t1x), min(t0y, t1y)), min(t0z, t1z)), 0.0);
        let tmax = min(min(max(t0x, t1x), max(t0y, t1y)), max(t0z, t1z));
        if tmax >= tmin {
            if is_leaf(node.packed) {
                let first = leaf_first(node.packed);
                let end = first + leaf_count(node.packed);
                for (var t = first; t < end; t++) {
                    let r = head_ray_tris[t];
                    crossings += select(0u, 1u, ray_crosses(r.v0, r.v1, r.v2, pr));
                }
            } else {
                stack[sp] = node.packed;
                stack[sp + 1u] = node.packed + 1u;
                sp += 2u;
            }
        }
    }
    return (crossings & 1u) == 1u;
}

// common.rs `sphere_margin`: the margin everything inside the sphere (c, r)
// (head frame) must at least keep.
fn sphere_margin(q: Query, c: vec3<f32>, r: f32) -> f32 {
    if q.slope > 0.0 {
        return q.margin + q.slope * (len3(c) + r);
    }
    return q.margin;
}

// common.rs `triangle_margin`: the margin the triangle (head frame) must keep.
fn triangle_margin(q: Query, a: vec3<f32>, b: vec3<f32>, c: vec3<f32>) -> f32 {
    if q.slope > 0.0 {
        return q.margin + q.slope * max(max(len3(a), len3(b)), len3(c));
    }
    return q.margin;
}

// The triangle in the head frame, the margin it must keep and its
// classification by bounding sphere, then centroid, then hull plane (1
// outside, -1 colliding, 0 undecided): common.rs `head_tri`, the first
// half of frontier.rs `tri_hits`. A centroid the grid shows inside the head is a point of
// the triangle inside it: the triangle collides (it crosses the surface
// or lies inside), and the exact tests would find the same.
struct HeadTri {
    a: vec3<f32>,
    b: vec3<f32>,
    c: vec3<f32>,
    margin: f32,
    cls: i32,
}

fn head_tri(q: Query, tri: Triangle) -> HeadTri {
    let a = to_head(q, tri.v0);
    let b = to_head(q, tri.v1);
    let c = to_head(q, tri.v2);
    let third = 1.0 / 3.0;
    let m = (a + b + c) * third;
    let r = max(max(len3(a - m), len3(b - m)), len3(c - m));
    let margin = triangle_margin(q, a, b, c);
    let g = grid_sample(m);
    var cls = classify_sample(g, m, r, margin);
    if cls == 0 && classify_sample(g, m, 0.0, 0.0) < 0 {
        cls = -1;
    }
    if cls == 0 && hull_clear(m, a, b, c, margin) {
        cls = 1;
    }
    return HeadTri(a, b, c, margin, cls);
}

// common.rs `hull_clear`: the triangle farther than margin from the head,
// beyond the hull plane of the cell holding its centroid m.
fn hull_clear(m: vec3<f32>, a: vec3<f32>, b: vec3<f32>, c: vec3<f32>, margin: f32) -> bool {
    let k = hull_plane_at(m);
    if k == OUTSIDE_PLANES {
        return false;
    }
    let plane = grid4(k);
    let n = plane.xyz;
    let near = min(min(dot3(n, a), dot3(n, b)), dot3(n, c));
    return near - plane.w - head.grid_slack > margin;
}

// common.rs `tri_hits_exact` (the exact half of frontier.rs `tri_hits`), for an undecided
// triangle: crossing or within the margin, then containment. The two walks
// of the head BVH run one after another, never nested.
fn tri_hits_exact(a: vec3<f32>, b: vec3<f32>, c: vec3<f32>, margin: f32) -> bool {
    if tri_crosses_head(a, b, c, margin) {
        return true;
    }
    let cls_a = classify(a, 0.0, 0.0);
    if cls_a != 0 {
        return cls_a < 0;
    }
    return point_in_head(a);
}

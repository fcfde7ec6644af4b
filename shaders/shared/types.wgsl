// GPU structs shared by every kernel. Keep Triangle, Node, PartNode, Query
// and HeadParams in sync with src/scene/gpu_types.rs, Move and Motion with
// src/collide/gpu/wire.rs (tests/shaders.rs checks sizes with naga's
// layouter).

struct Triangle {
    v0: vec3<f32>,
    stamp: u32,
    v1: vec3<f32>,
    layer: u32,
    v2: vec3<f32>,
    source: u32,
}

struct Node {
    min: vec3<f32>,
    packed: u32,
    max: vec3<f32>,
    min_stamp: u32,
}

struct PartNode {
    center: vec3<f32>,
    packed: u32,
    radius: f32,
    min_stamp: u32,
    slab_normal: u32,
    slab_range: u32,
}

struct Query {
    rows: array<vec4<f32>, 3>,
    cutoff: u32,
    margin: f32,
    slope: f32,
    pad: u32,
}

struct HeadParams {
    aabb_min: vec3<f32>,
    tol: f32,
    aabb_max: vec3<f32>,
    grid_slack: f32,
    grid_origin: vec3<f32>,
    cell: f32,
    grid_dims: vec3<u32>,
    tri_count: u32,
    ray_a: vec4<f32>,
    ray_b: vec4<f32>,
    ray_d: vec4<f32>,
    inv_ray: vec3<f32>,
    inv_cell: f32,
    far_origin: vec3<f32>,
    far_cell: f32,
    far_dims: vec3<u32>,
    far_offset: u32,
    far_inv_cell: f32,
    support_offset: u32,
    plane_offset: u32,
    plane_inv_cell: f32,
    plane_origin: vec3<f32>,
    plane_cell: f32,
    plane_dims: vec3<u32>,
    _pad: u32,
}

// A machine move the motion kernels sample (src/collide/gpu/wire.rs GpuMove).
struct Move {
    start: vec4<f32>,
    end: vec4<f32>,
    c_from: f32,
    c_delta: f32,
    inv_n: f32,
    cutoff: u32,
    margin: f32,
    first: u32,
    count: u32,
    pad: u32,
}

// The machine and the batch's move count (src/collide/gpu/wire.rs GpuMotion).
struct Motion {
    configuration: u32,
    rotary: u32,
    interpolation: u32,
    move_count: u32,
    d: f32,
    h: f32,
    r: f32,
    pad: u32,
}

// Leaf encoding of Node.packed / PartNode.packed (src/scene/gpu_types.rs).
const LEAF_BIT: u32 = 0x80000000u;
const FIRST_MASK: u32 = 0x07ffffffu;

fn is_leaf(packed: u32) -> bool {
    return (packed & LEAF_BIT) != 0u;
}

fn leaf_first(packed: u32) -> u32 {
    return packed & FIRST_MASK;
}

fn leaf_count(packed: u32) -> u32 {
    return ((packed >> 27u) & 0xfu) + 1u;
}

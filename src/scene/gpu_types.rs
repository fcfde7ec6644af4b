//! The scene's buffers as the kernels and their CPU mirrors read them:
//! `#[repr(C)]` Pod structs that go to the GPU as they are (triangles,
//! BVH nodes, the head's scalars) and the query that poses the head among
//! them. Each has a WGSL twin in `shaders/shared/types.wgsl`; keep the two
//! in sync (the size assertions below and the naga layout test,
//! `tests/shaders.rs`, catch drift). The kernels' own per-batch records
//! (parameters, moves, result words) are `collide::gpu::wire`'s.

use bytemuck::{Pod, Zeroable};

/// One triangle of the stamped part (or of the head), 48 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuTriangle {
    /// First vertex.
    pub v0: [f32; 3],
    /// Print stamp: present for queries whose cutoff is greater (0 = platform).
    pub stamp: u32,
    /// Second vertex.
    pub v1: [f32; 3],
    /// Layer index (`u32::MAX` for the platform and the head).
    pub layer: u32,
    /// Third vertex.
    pub v2: [f32; 3],
    /// Index of the triangle before BVH reordering (for diagnostics).
    pub source: u32,
}

/// One BVH node, 32 bytes. Inner nodes store the left child index (the
/// right child is the next node); leaves set the top bit and pack
/// `count - 1` (4 bits) and the first triangle (27 bits).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuNode {
    /// Box lower corner.
    pub min: [f32; 3],
    /// Child index, or the packed leaf range.
    pub packed: u32,
    /// Box upper corner.
    pub max: [f32; 3],
    /// Smallest stamp below this node: skip it when `min_stamp >= cutoff`.
    pub min_stamp: u32,
}

/// One node of the part BVH as a bounding sphere, 32 bytes: the sphere's
/// centre is the node box's centre, its radius the farthest vertex below
/// (tighter than the half-diagonal). Children and leaves are packed as in
/// [`GpuNode`].
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuPartNode {
    /// Sphere centre.
    pub center: [f32; 3],
    /// Child index, or the packed leaf range.
    pub packed: u32,
    /// Sphere radius (rounded up).
    pub radius: f32,
    /// Smallest stamp below this node.
    pub min_stamp: u32,
    /// The slab's unit normal, octahedral, two snorm16 (`pack2x16snorm`
    /// order: x in the low half) — see `scene::slab`.
    pub slab_normal: u32,
    /// The slab's interval `[lo, hi]` of `n · (x − center)` as fractions
    /// of `radius`, two snorm16 (lo low), rounded outwards.
    pub slab_range: u32,
}

impl GpuPartNode {
    /// `Some((first, count))` for a leaf.
    #[inline(always)]
    pub fn leaf_range(&self) -> Option<(u32, u32)> {
        GpuNode {
            packed: self.packed,
            ..GpuNode::default()
        }
        .leaf_range()
    }
}

/// Depth of the fixed traversal stacks of the evaluators (cpu and WGSL,
/// `STACK_SIZE` in `shaders/shared/collide_common.wgsl`); scene building
/// rejects deeper BVHs.
pub const STACK_SIZE: usize = 64;

/// Leaf flag in [`GpuNode::packed`].
pub const LEAF_BIT: u32 = 0x8000_0000;
/// Largest triangle count one leaf can hold.
pub const MAX_LEAF_TRIS: u32 = 16;
/// Largest number of triangles one BVH can index (27 bits).
pub const MAX_TRIS: u32 = 1 << 27;

impl GpuNode {
    /// `Some((first, count))` for a leaf.
    #[inline(always)]
    pub fn leaf_range(&self) -> Option<(u32, u32)> {
        if self.packed & LEAF_BIT != 0 {
            Some((
                self.packed & (MAX_TRIS - 1),
                ((self.packed >> 27) & 0xF) + 1,
            ))
        } else {
            None
        }
    }

    /// Pack a leaf range.
    pub fn pack_leaf(first: u32, count: u32) -> u32 {
        debug_assert!((1..=MAX_LEAF_TRIS).contains(&count) && first < MAX_TRIS);
        LEAF_BIT | ((count - 1) << 27) | first
    }
}

/// One collision query, 64 bytes: the head pose and the cutoff stamp.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuQuery {
    /// Rows of Rᵀ (the columns of the head→part rotation); `.w` holds the
    /// tip coordinate of that axis.
    pub rows: [[f32; 4]; 3],
    /// Part triangles with `stamp < cutoff` exist for this query.
    pub cutoff: u32,
    /// Safety margin (mm): closer than this counts as a collision.
    pub margin: f32,
    /// Growth of the margin with distance from the tip (mm per mm):
    /// [`crate::scene::Query::slope`].
    pub slope: f32,
    /// Padding to 16-byte multiples.
    pub _pad: u32,
}

/// The head's scalar parameters, 208 bytes.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuHeadParams {
    /// Head bounding box lower corner (head frame).
    pub aabb_min: [f32; 3],
    /// Contact tolerance (mm).
    pub tol: f32,
    /// Head bounding box upper corner.
    pub aabb_max: [f32; 3],
    /// Conservative slack on the grid's distance bounds (mm), covering
    /// rounding; not the query's safety margin ([`GpuQuery::margin`]).
    pub grid_slack: f32,
    /// Distance grid origin (corner of cell 0).
    pub grid_origin: [f32; 3],
    /// Grid cell size (mm).
    pub cell: f32,
    /// Grid cell counts along x, y, z.
    pub grid_dims: [u32; 3],
    /// Number of head triangles.
    pub tri_count: u32,
    /// Ray-space frame for containment: first two rows; the third is in
    /// `ray_d`.
    pub ray_a: [f32; 4],
    /// Second ray-frame row.
    pub ray_b: [f32; 4],
    /// Ray direction.
    pub ray_d: [f32; 4],
    /// `1 / ray_d`, component-wise (the ray direction has no zero component).
    pub inv_ray: [f32; 3],
    /// `1 / cell`.
    pub inv_cell: f32,
    /// Far grid origin (corner of its cell 0): a coarse grid around the
    /// fine one, read only where the fine grid does not reach.
    pub far_origin: [f32; 3],
    /// Far grid cell size (mm).
    pub far_cell: f32,
    /// Far grid cell counts along x, y, z.
    pub far_dims: [u32; 3],
    /// Index of the far grid's first cell in the grid buffer (after the
    /// fine grid's cells).
    pub far_offset: u32,
    /// `1 / far_cell`.
    pub far_inv_cell: f32,
    /// Index of the support map's first cell in the grid buffer (after
    /// the far grid): upper bounds of the head's support function per
    /// cube-map cell, `scene::slab::SUPPORT_SIDE`² cells a face, one word
    /// a cell for both `h(u)` and `h(−u)` (`scene::slab::support_pairs`).
    pub support_offset: u32,
    /// Index of the hull planes' first cell in the grid buffer (after the
    /// support map): four floats a cell, `n` and `h` (`scene::hull_plane`).
    pub plane_offset: u32,
    /// `1 / plane_cell`.
    pub plane_inv_cell: f32,
    /// Hull-plane grid origin (corner of its cell 0).
    pub plane_origin: [f32; 3],
    /// Hull-plane grid cell size (mm).
    pub plane_cell: f32,
    /// Hull-plane grid cell counts along x, y, z.
    pub plane_dims: [u32; 3],
    /// Padding to 16-byte multiples.
    pub _pad: u32,
}

const _: () = assert!(std::mem::size_of::<GpuTriangle>() == 48);
const _: () = assert!(std::mem::size_of::<GpuNode>() == 32);
const _: () = assert!(std::mem::size_of::<GpuPartNode>() == 32);
const _: () = assert!(std::mem::size_of::<GpuQuery>() == 64);
const _: () = assert!(std::mem::size_of::<GpuHeadParams>() == 208);

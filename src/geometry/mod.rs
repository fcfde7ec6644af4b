//! Geometric predicates on triangles, written as plain `f32` loops that the
//! WGSL shaders mirror operation for operation (see DESIGN.md, "Pair each
//! shader with its host and a CPU mirror").
//!
//! Every arithmetic helper here spells out its evaluation order (no `glam`
//! SIMD dot products) so that the CPU and GPU backends round identically.

pub mod aabb;
pub mod mesh;
pub mod point_in_mesh;
pub mod point_triangle_distance;
pub mod pose;
pub mod tri_tri;
pub mod tri_tri_distance;

pub use aabb::Aabb;
pub use mesh::Mesh;
pub use pose::Pose;

/// A 3-vector of `f32`, plain and `Pod`, used at every GPU-facing interface.
pub type V3 = [f32; 3];

/// `a - b`, component-wise.
#[inline(always)]
pub fn sub(a: V3, b: V3) -> V3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// `a + b`, component-wise.
#[inline(always)]
pub fn add(a: V3, b: V3) -> V3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// `a * s`.
#[inline(always)]
pub fn scale(a: V3, s: f32) -> V3 {
    [a[0] * s, a[1] * s, a[2] * s]
}

/// Dot product, summed left to right: `(x + y) + z`.
#[inline(always)]
pub fn dot(a: V3, b: V3) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Cross product.
#[inline(always)]
pub fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Euclidean length.
#[inline(always)]
pub fn length(a: V3) -> f32 {
    dot(a, a).sqrt()
}

/// Component-wise minimum.
#[inline(always)]
pub fn vmin(a: V3, b: V3) -> V3 {
    [a[0].min(b[0]), a[1].min(b[1]), a[2].min(b[2])]
}

/// Component-wise maximum.
#[inline(always)]
pub fn vmax(a: V3, b: V3) -> V3 {
    [a[0].max(b[0]), a[1].max(b[1]), a[2].max(b[2])]
}

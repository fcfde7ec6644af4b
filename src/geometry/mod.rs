//! Geometric predicates on triangles, written as plain `f32` loops that the
//! WGSL shaders mirror operation for operation (see DESIGN.md, "Pair each
//! shader with its host and a CPU mirror").
//!
//! Every arithmetic helper here spells out its evaluation order (no `glam`
//! SIMD dot products) so that the CPU and GPU backends round identically.
//! The exact distances in `f64` (`point_triangle_distance`,
//! `point_segment_distance`) have no shader twin: they build the head's
//! grids and serve the ground truth and the generators, so they use glam.

pub mod aabb;
pub mod mesh;
pub mod point_in_mesh;
pub mod point_segment_distance;
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

#[cfg(test)]
thread_local! {
    /// Whether [`madd`] fuses on this thread, as a GPU that contracts
    /// multiply-adds would (WGSL lets it; Vulkan drivers do): only the
    /// robustness test of the mirror's verdicts turns it on
    /// (`collide::cpu`'s tests). Not compiled outside the crate's unit
    /// tests, so the shipped arithmetic is plain.
    pub static FUSED: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// A xorshift generator of uniform numbers in `[0, 1)` from `seed`, for
/// the crate's unit tests (reproducible, no dependency).
#[cfg(test)]
pub(crate) fn xorshift(mut seed: u64) -> impl FnMut() -> f64 {
    move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// `a · b + c`: two roundings, as the WGSL mirrors spell it (one under
/// `FUSED` in the crate's unit tests). The multiply-adds of the
/// collision mirror go through here, so that a test can fuse them all.
#[inline(always)]
pub fn madd(a: f32, b: f32, c: f32) -> f32 {
    #[cfg(test)]
    if FUSED.with(|f| f.get()) {
        return a.mul_add(b, c);
    }
    a * b + c
}

/// Dot product, summed left to right: `(x + y) + z` (each addition as
/// [`madd`]: the same rounding, addition being commutative).
#[inline(always)]
pub fn dot(a: V3, b: V3) -> f32 {
    madd(a[2], b[2], madd(a[1], b[1], a[0] * b[0]))
}

/// Cross product (each component `x − y` as [`madd`]`(…, −y)`).
#[inline(always)]
pub fn cross(a: V3, b: V3) -> V3 {
    [
        madd(a[1], b[2], -(a[2] * b[1])),
        madd(a[2], b[0], -(a[0] * b[2])),
        madd(a[0], b[1], -(a[1] * b[0])),
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

//! WGSL sources, compiled into the binary (never read at run time). WGSL
//! has no `#include`, so each kernel is the shared files plus its own file.

macro_rules! kernel {
    ($file:literal) => {
        concat!(
            include_str!("../../../shaders/shared/types.wgsl"),
            "\n",
            include_str!("../../../shaders/shared/geometry.wgsl"),
            "\n",
            include_str!("../../../shaders/shared/tri_tri.wgsl"),
            "\n",
            include_str!("../../../shaders/shared/tri_tri_distance.wgsl"),
            "\n",
            include_str!("../../../shaders/shared/point_in_mesh.wgsl"),
            "\n",
            include_str!("../../../shaders/shared/collide_common.wgsl"),
            "\n",
            include_str!(concat!("../../../shaders/", $file)),
        )
    };
}

/// Pass 1: BVH traversal per query (`shaders/collide_traverse.wgsl`).
pub const COLLIDE_TRAVERSE: &str = kernel!("collide_traverse.wgsl");
/// Between the passes: indirect dispatch size (`shaders/collide_prepare.wgsl`).
pub const COLLIDE_PREPARE: &str = kernel!("collide_prepare.wgsl");
/// Pass 2: exact tests per candidate (`shaders/collide_exact.wgsl`).
pub const COLLIDE_EXACT: &str = kernel!("collide_exact.wgsl");

/// Every kernel by name, for validation.
pub const ALL: &[(&str, &str)] = &[
    ("collide_traverse", COLLIDE_TRAVERSE),
    ("collide_prepare", COLLIDE_PREPARE),
    ("collide_exact", COLLIDE_EXACT),
];

//! WGSL sources, compiled into the binary (never read at run time). WGSL
//! has no `#include`, so each kernel is the shared files plus its own file
//! (and how the walk appends a candidate: `shared/append_atomic.wgsl`, or
//! `shared/append_subgroup.wgsl` where the adapter has subgroups).

macro_rules! kernel {
    ($file:literal) => {
        kernel!("shared/append_atomic.wgsl", $file)
    };
    ($append:literal, $file:literal) => {
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
            include_str!(concat!("../../../shaders/", $append)),
            "\n",
            include_str!(concat!("../../../shaders/", $file)),
        )
    };
}

macro_rules! motion_kernel {
    ($file:literal) => {
        concat!(
            include_str!("../../../shaders/shared/types.wgsl"),
            "\n",
            include_str!("../../../shaders/shared/motion.wgsl"),
            "\n",
            include_str!(concat!("../../../shaders/", $file)),
        )
    };
}

/// Before a batch of moves: their samples posed per move
/// (`shaders/collide_expand.wgsl`).
pub const COLLIDE_EXPAND: &str = motion_kernel!("collide_expand.wgsl");
/// After a batch of moves: one verdict per move from its samples'
/// (`shaders/collide_reduce.wgsl`).
pub const COLLIDE_REDUCE: &str = motion_kernel!("collide_reduce.wgsl");

/// `collide_traverse.wgsl` (one query's walk) with an entry point
/// handing queries to invocations and a way of appending candidates.
macro_rules! traverse_kernel {
    ($append:literal, $entry:literal) => {
        concat!(
            kernel!($append, "collide_traverse.wgsl"),
            "\n",
            include_str!(concat!("../../../shaders/", $entry)),
        )
    };
}

/// Pass 1: BVH traversal per query, one query an invocation
/// (`shaders/traverse_lane.wgsl`), one atomic per candidate appended
/// (`shaders/shared/append_atomic.wgsl`): adapters without subgroups.
pub const COLLIDE_TRAVERSE: &str =
    traverse_kernel!("shared/append_atomic.wgsl", "traverse_lane.wgsl");
/// Pass 1 with persistent lanes (`shaders/traverse_persistent.wgsl`),
/// one atomic per candidate: software adapters with subgroups (lavapipe).
pub const COLLIDE_TRAVERSE_PERSISTENT: &str =
    traverse_kernel!("shared/append_atomic.wgsl", "traverse_persistent.wgsl");
/// Pass 1 with persistent lanes and one atomic per subgroup and append
/// (`shaders/shared/append_subgroup.wgsl`): hardware with subgroups.
pub const COLLIDE_TRAVERSE_SUBGROUP: &str =
    traverse_kernel!("shared/append_subgroup.wgsl", "traverse_persistent.wgsl");
/// Between the passes: indirect dispatch size (`shaders/collide_prepare.wgsl`).
pub const COLLIDE_PREPARE: &str = kernel!("collide_prepare.wgsl");
/// Pass 2: exact tests per candidate (`shaders/collide_exact.wgsl`).
pub const COLLIDE_EXACT: &str = kernel!("collide_exact.wgsl");

/// Every kernel by name, for validation.
pub const ALL: &[(&str, &str)] = &[
    ("collide_traverse", COLLIDE_TRAVERSE),
    (
        "collide_traverse persistent (subgroups)",
        COLLIDE_TRAVERSE_PERSISTENT,
    ),
    (
        "collide_traverse persistent, subgroup appends (subgroups)",
        COLLIDE_TRAVERSE_SUBGROUP,
    ),
    ("collide_prepare", COLLIDE_PREPARE),
    ("collide_exact", COLLIDE_EXACT),
    ("collide_expand", COLLIDE_EXPAND),
    ("collide_reduce", COLLIDE_REDUCE),
];

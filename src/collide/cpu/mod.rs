//! The `cpu` backend and the CPU mirrors of the `collide_*` kernels, kept
//! as linebender/vello keeps its CPU shaders: one file per kernel, named
//! for it, reading like it, with the same operations in the same order so
//! the two backends round identically.
//!
//! | file | mirrors |
//! | --- | --- |
//! | [`common`] | `shaders/shared/collide_common.wgsl`: the bindings and the helpers every kernel shares |
//! | [`traverse`] | `shaders/collide_traverse.wgsl` (entered by `traverse_lane.wgsl` or `traverse_persistent.wgsl`): one query's walk, the undecided pairs in walk order |
//! | [`exact`] | `shaders/collide_exact.wgsl`: one pair's exact tests |
//! | [`expand`] | `shaders/collide_expand.wgsl` with `shaders/shared/motion.wgsl`: a move's samples posed in `f32` |
//! | [`reduce`] | `shaders/collide_reduce.wgsl`: a move's verdict from its samples' |
//!
//! `collide_prepare.wgsl` (the exact pass's dispatch size) has no mirror:
//! the CPU needs no dispatch. The mirrors are tested against the kernels
//! pair by pair (`tests/gpu.rs`).
//!
//! The backend itself is the CPU's own and has no twin: [`backend`] (a
//! worker per thread, trying the triangles of its recent hits first) and
//! [`frontier`] (its tree walk, from the root or from the cut the last
//! query stopped at, testing each undecided triangle on the spot where the
//! kernels hand it to a second pass). None of that changes a verdict.
//!
//! Per query: walk the part BVH, skipping nodes with `min_stamp >= cutoff`.
//! Each node's bounding sphere is moved into the head frame and classified
//! with the head's distance grid: wholly outside and farther than the
//! query's safety margin (skip), wholly inside (a collision: the node holds
//! a triangle that exists), or unknown; an unknown node whose slab lies
//! wholly on one side of the head, farther than the margin, is skipped too
//! ([`slab_clear`], `scene::slab`: flat layers under the nozzle, which
//! spheres fit badly), and so is one whose sphere and slab together lie
//! beyond the head hull's plane facing it ([`node_hull_clear`]: flat
//! layers beside a tilted head's flank), else the walk descends. With a
//! slope the margin grows with distance from the tip: a node is measured
//! at its farthest point from the tip ([`sphere_margin`]), a triangle at
//! its farthest corner ([`triangle_margin`]). Leaf triangles get the same
//! classification and, if it cannot tell, the head hull's plane facing
//! them ([`hull_clear`]), then the exact tests: Möller against the head
//! triangles its box touches and, with a positive margin, the distance to
//! the head triangles whose boxes lie within the margin (one walk); when
//! nothing crosses or comes near, containment of one vertex (grid first,
//! ray parity if the grid cannot say).

pub mod backend;
pub mod common;
pub mod exact;
pub mod expand;
pub mod frontier;
pub mod reduce;
pub mod traverse;

pub use backend::{witness_hits, CpuBackend};
pub use common::*;
pub use frontier::{first_hit, leaf_hit, query_hits, tri_hits, NO_TRIANGLE};

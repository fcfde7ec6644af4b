//! The records the GPU host and the `collide_*` kernels exchange besides
//! the scene's buffers (`scene::gpu_types`): a batch's parameters, its
//! per-query result words, the moves the motion kernels pose, and what a
//! walk reports. Each struct is `#[repr(C)]` Pod with a size assertion and
//! has a WGSL twin that says to keep it in sync with this file
//! (`shaders/shared/collide_common.wgsl`: `Params` and the `RESULT_*`
//! constants; `shaders/shared/types.wgsl`: `Move`, `Motion`);
//! `tests/shaders.rs` checks both sides with naga.

use bytemuck::{Pod, Zeroable};

/// Per-batch scalars of the `collide_*` kernels, 32 bytes.
///
/// Twin: `Params` (`shaders/shared/collide_common.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuParams {
    /// Elements per part-node binding (a scene larger than one storage
    /// binding is split across several).
    pub nodes_per_chunk: u32,
    /// Elements per part-triangle binding.
    pub tris_per_chunk: u32,
    /// Queries in the batch.
    pub query_count: u32,
    /// Slots of the candidate list.
    pub capacity: u32,
    /// 0: the batch's first walk; 1: a resumed walk, only for the queries
    /// whose candidates did not all fit ([`RESULT_INCOMPLETE`]), handing
    /// over the candidates after the ones already tested.
    pub resume: u32,
    /// The most candidates one query hands over in one pass; the rest
    /// wait for a resumed pass ([`RESULT_INCOMPLETE`]), by when the first
    /// ones may have settled the query.
    pub per_query: u32,
    /// Padding to 16-byte multiples (uniform layout).
    pub _pad: [u32; 2],
}

/// The batch's per-query result word: the query collides.
pub const RESULT_HIT: u32 = 1;
/// The result word: some of the query's candidates were not handed over
/// (the list was full, or the query had handed over its share for the
/// pass): its walk is resumed in the next pass of the batch.
pub const RESULT_INCOMPLETE: u32 = 2;
/// The result word above these bits: how many of the query's candidates,
/// in walk order, have been handed to the exact pass.
pub const RESULT_STORED_SHIFT: u32 = 2;

/// A machine move whose samples the device poses (`collide_expand`) and
/// whose verdict it reduces from theirs (`collide_reduce`), 64 bytes
/// (`Move` in `shaders/shared/types.wgsl`). Sample `k` (1 ≤ k ≤ `count`)
/// is the machine's pose at fraction `k · inv_n` of the move.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuMove {
    /// Machine X, Y, Z and tilt (radians) at the start.
    pub from: [f32; 4],
    /// Machine X, Y, Z and tilt at the end.
    pub to: [f32; 4],
    /// C at the start (radians, reduced to one turn).
    pub c_from: f32,
    /// C's travel over the move (radians, as the machine turns).
    pub c_delta: f32,
    /// `1 / n`, the fraction of the move between samples.
    pub inv_n: f32,
    /// Material with `stamp < cutoff` exists during the move.
    pub cutoff: u32,
    /// Safety margin of every sample (mm).
    pub margin: f32,
    /// The query slot of its first sample in the batch.
    pub first: u32,
    /// Its samples (`n − 1`: the ends are not sampled).
    pub count: u32,
    /// Padding to 16-byte multiples.
    pub _pad: u32,
}

/// The machine the motion kernels pose samples for, and the batch's move
/// count, 32 bytes (`Motion` in `shaders/shared/types.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct GpuMotion {
    /// Table I configuration: 1, 2 or 3 (I, II, III).
    pub configuration: u32,
    /// 0 B/C, 1 A/C.
    pub rotary: u32,
    /// 0 joint-linear, 1 the tip straight in the part frame.
    pub interpolation: u32,
    /// Moves in the batch.
    pub move_count: u32,
    /// Offsets `d`, `h`, `r` (mm).
    pub offsets: [f32; 3],
    /// Padding to 16-byte multiples.
    pub _pad: u32,
}

/// What the walk of one query found: as `collide_traverse` reports it
/// (its result word's hit bit, and the pairs it appended, in walk order)
/// and as its mirror `collide::cpu::traverse::walk` lists it.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Walk {
    /// A node or a triangle lies wholly inside the head: the query
    /// collides (the walk stopped there).
    pub hit: bool,
    /// The undecided triangles (indices into the part triangles) in walk
    /// order, for the exact tests (`collide::cpu::exact`).
    pub candidates: Vec<u32>,
}

const _: () = assert!(std::mem::size_of::<GpuParams>() == 32);
const _: () = assert!(std::mem::size_of::<GpuMove>() == 64);
const _: () = assert!(std::mem::size_of::<GpuMotion>() == 32);

//! CPU mirror of `shaders/collide_reduce.wgsl`: after a batch of moves,
//! one move's verdict from its samples' result words (the move collides
//! when any of its samples does). The host's own moves
//! (`collide::moves::host_sampled_moves`) reduce the same way.

use crate::collide::gpu::wire::{GpuMove, RESULT_HIT};

/// The result word of move `mv`: [`RESULT_HIT`] when any of its samples'
/// words (its slots `first..first + count` of `sample_results`) has it.
///
/// Twin: `main` (`collide_reduce.wgsl`) for one move.
pub fn move_result(mv: &GpuMove, sample_results: &[u32]) -> u32 {
    let mut hit = 0;
    for k in 0..mv.count {
        hit |= sample_results[(mv.first + k) as usize] & RESULT_HIT;
    }
    hit
}

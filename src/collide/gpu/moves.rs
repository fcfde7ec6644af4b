//! The move path of the gpu backend: each move goes up once
//! ([`GpuMove`]), `collide_expand` poses its samples into a batch's query
//! slots, the query path's passes decide them, and `collide_reduce` leaves
//! one word per move to read back.

use super::super::moves::SampledMove;
use super::super::CollideError;
use super::resources::{BatchSet, WORKGROUP};
use super::wire::{GpuMotion, GpuMove, RESULT_HIT};
use super::GpuBackend;
use crate::kinematics::{Axes, Configuration, Interpolation, Machine, Rotary};

/// The machine as the motion kernels read it.
pub fn gpu_motion(m: &Machine, move_count: usize) -> GpuMotion {
    let [d, h, r] = m.offsets();
    GpuMotion {
        configuration: match m.configuration {
            Configuration::I => 1,
            Configuration::II => 2,
            Configuration::III => 3,
        },
        rotary: match m.rotary {
            Rotary::BC => 0,
            Rotary::AC => 1,
        },
        interpolation: match m.post.interpolation() {
            Interpolation::Joint => 0,
            Interpolation::TipLinear => 1,
        },
        move_count: move_count as u32,
        offsets: [d as f32, h as f32, r as f32],
        _pad: 0,
    }
}

/// `mv` as the motion kernels read it, its samples in the query slots
/// from `first` on. C starts reduced to one turn (the same pose, and `f32`
/// keeps its digits for the angle, not for whole turns).
pub fn gpu_move(mv: &SampledMove, first: u32) -> GpuMove {
    let at = |a: &Axes| {
        [
            a.xyz[0] as f32,
            a.xyz[1] as f32,
            a.xyz[2] as f32,
            a.tilt as f32,
        ]
    };
    GpuMove {
        from: at(&mv.from),
        to: at(&mv.to),
        c_from: mv.from.c.rem_euclid(std::f64::consts::TAU) as f32,
        c_delta: (mv.to.c - mv.from.c) as f32,
        inv_n: (1.0 / mv.intervals.max(1) as f64) as f32,
        cutoff: mv.cutoff,
        margin: mv.margin,
        first,
        count: mv.intervals.saturating_sub(1),
        _pad: 0,
    }
}

/// A batch of consecutive moves as the device gets them.
#[derive(Default)]
struct MoveBatch {
    /// Each move's index in the caller's list.
    owners: Vec<usize>,
    /// The moves, each with its samples' first query slot.
    moves: Vec<GpuMove>,
    /// Their samples in all (query slots used).
    samples: usize,
}

/// Moves: their samples posed (`collide_expand`) and their verdicts
/// reduced (`collide_reduce`) on the device; one move record goes up and
/// one word per move comes back.
impl GpuBackend {
    /// [`Backend::sampled_moves`](crate::collide::Backend::sampled_moves) on the device, batches of at most
    /// `batch` samples, two in flight.
    pub(super) fn moves_on_device(
        &self,
        machine: &Machine,
        moves: &[SampledMove],
    ) -> Result<Vec<bool>, CollideError> {
        if let Some(i) = moves
            .iter()
            .position(|m| !(m.margin.is_finite() && m.margin >= 0.0))
        {
            return Err(CollideError::BadMargin(i));
        }
        let _one_caller = self.busy.lock().unwrap_or_else(|e| e.into_inner());
        self.timed(|| self.moves_in_batches(machine, moves))
    }

    /// [`Self::moves_on_device`] once its arguments are checked and the
    /// buffers are this caller's.
    fn moves_in_batches(
        &self,
        machine: &Machine,
        moves: &[SampledMove],
    ) -> Result<Vec<bool>, CollideError> {
        let batches = self.move_batches(moves)?;
        let mut out = vec![false; moves.len()];
        self.two_in_flight(
            &batches,
            |s, batch| self.submit_moves(s, machine, batch),
            |s, batch, index| self.finish_moves(s, batch, index, &mut out),
        )?;
        Ok(out)
    }

    /// `moves` cut into batches of consecutive moves of at most `batch`
    /// samples (moves without samples left out); an error for a move with
    /// more samples than a batch holds.
    fn move_batches(&self, moves: &[SampledMove]) -> Result<Vec<MoveBatch>, CollideError> {
        let mut batches = Vec::new();
        let mut current = MoveBatch::default();
        for (i, mv) in moves.iter().enumerate() {
            let count = mv.intervals.saturating_sub(1) as usize;
            if count == 0 {
                continue;
            }
            if count > self.tuning.batch {
                return Err(CollideError::Unavailable(format!(
                    "a move of {count} samples exceeds one batch of {}",
                    self.tuning.batch
                )));
            }
            if current.samples + count > self.tuning.batch {
                batches.push(std::mem::take(&mut current));
            }
            current.moves.push(gpu_move(mv, current.samples as u32));
            current.owners.push(i);
            current.samples += count;
        }
        if current.samples > 0 {
            batches.push(current);
        }
        Ok(batches)
    }

    /// Encode and submit a batch of moves on set `s`: their samples posed
    /// into the query slots, the usual passes over them, the reduction.
    fn submit_moves(
        &self,
        s: usize,
        machine: &Machine,
        batch: &MoveBatch,
    ) -> wgpu::SubmissionIndex {
        let (moves, total) = (&batch.moves, batch.samples);
        let set = &self.sets[s];
        let q = &self.ctx.queue;
        q.write_buffer(
            &set.params,
            0,
            bytemuck::bytes_of(&self.params(total, false)),
        );
        q.write_buffer(
            &set.motion,
            0,
            bytemuck::bytes_of(&gpu_motion(machine, moves.len())),
        );
        q.write_buffer(&set.moves, 0, bytemuck::cast_slice(moves));
        let mut enc = self.ctx.device.create_command_encoder(&Default::default());
        enc.clear_buffer(&set.results, 0, Some(total as u64 * 4));
        self.encode_motion(&mut enc, set, &self.pipelines.expand, moves.len());
        let margins = moves.iter().any(|m| m.margin > 0.0);
        self.encode_passes(&mut enc, set, total, margins);
        self.encode_reduce(&mut enc, set, moves.len());
        self.send(enc)
    }

    /// One motion kernel over `moves` moves.
    pub(super) fn encode_motion(
        &self,
        enc: &mut wgpu::CommandEncoder,
        set: &BatchSet,
        kernel: &wgpu::ComputePipeline,
        moves: usize,
    ) {
        let mut pass = enc.begin_compute_pass(&Default::default());
        pass.set_bind_group(0, &set.motion_group, &[]);
        pass.set_pipeline(kernel);
        pass.dispatch_workgroups((moves as u32).div_ceil(WORKGROUP), 1, 1);
    }

    /// The reduction and the copy of its verdicts for reading.
    fn encode_reduce(&self, enc: &mut wgpu::CommandEncoder, set: &BatchSet, moves: usize) {
        self.encode_motion(enc, set, &self.pipelines.reduce, moves);
        enc.copy_buffer_to_buffer(
            &set.move_results,
            0,
            &set.move_readback,
            0,
            moves as u64 * 4,
        );
    }

    /// Settle set `s`'s batch of moves (its walks resumed if its list
    /// filled, then reduced again) and scatter its verdicts into `out`.
    fn finish_moves(
        &self,
        s: usize,
        batch: &MoveBatch,
        index: wgpu::SubmissionIndex,
        out: &mut [bool],
    ) -> Result<(), CollideError> {
        let set = &self.sets[s];
        let margins = batch.moves.iter().any(|m| m.margin > 0.0);
        let (_, resumed) = self.settle(s, batch.samples, margins, index.clone())?;
        let index = if resumed {
            // The reduction in the first submission saw the first pass's
            // verdicts only.
            let mut enc = self.ctx.device.create_command_encoder(&Default::default());
            self.encode_reduce(&mut enc, set, batch.moves.len());
            self.send(enc)
        } else {
            index
        };
        let words = self.map_words(&set.move_readback, batch.moves.len(), Some(index))?;
        for (&i, w) in batch.owners.iter().zip(words) {
            out[i] = w & RESULT_HIT != 0;
        }
        Ok(())
    }
}

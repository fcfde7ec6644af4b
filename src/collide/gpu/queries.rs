//! The query path of the gpu backend: a batch runs three dispatches in
//! one submission — `collide_traverse` (per query: BVH walk, grid
//! culling, undecided pairs appended to a candidate list),
//! `collide_prepare` (indirect dispatch size) and `collide_exact` (per
//! candidate: Möller, the safety margin's distance tests, containment).
//! Two sets of per-batch buffers alternate, so the next batch computes
//! while the previous one is read back. When a batch's candidates do not
//! all fit the list, the queries that lost some are walked again
//! (`resume`): each hands over the pairs after the ones it had stored, so
//! no pair is tested twice and no batch is redone ([`GpuStats`] counts
//! it).

use super::super::order::coherent_order;
use super::super::{CollideError, Query};
use super::resources::{BatchSet, WORKGROUP};
use super::wire::{GpuParams, RESULT_HIT, RESULT_INCOMPLETE};
use super::{GpuBackend, GpuStats};
use crate::scene::GpuQuery;
use rayon::prelude::*;

/// Whether a pass over `queries` needs `collide_exact` with the margin's
/// distance tests (a query with a margin or a slope).
pub(super) fn margin_tests(queries: &[Query]) -> bool {
    queries.iter().any(|q| q.margin > 0.0 || q.slope > 0.0)
}

/// Queries: batches walked, their pairs tested, their verdicts read.
impl GpuBackend {
    pub(super) fn params(&self, n: usize, resume: bool) -> GpuParams {
        GpuParams {
            nodes_per_chunk: self.nodes_per_chunk,
            tris_per_chunk: self.tris_per_chunk,
            query_count: n as u32,
            capacity: self.capacity,
            resume: resume as u32,
            per_query: self.tuning.per_query,
            _pad: [0; 2],
        }
    }

    /// Encode and submit one batch on buffer set `s`.
    fn submit(&self, s: usize, batch: &[Query]) -> wgpu::SubmissionIndex {
        let set = &self.sets[s];
        self.upload(set, batch, self.params(batch.len(), false));
        let mut enc = self.ctx.device.create_command_encoder(&Default::default());
        enc.clear_buffer(&set.results, 0, Some(batch.len() as u64 * 4));
        self.encode_passes(&mut enc, set, batch.len(), margin_tests(batch));
        self.send(enc)
    }

    /// Write a pass's scalars and its queries into `set`.
    pub(super) fn upload(&self, set: &BatchSet, queries: &[Query], params: GpuParams) {
        let gpu: Vec<GpuQuery> = queries.par_iter().map(|q| q.to_gpu()).collect();
        let q = &self.ctx.queue;
        q.write_buffer(&set.params, 0, bytemuck::bytes_of(&params));
        q.write_buffer(&set.queries, 0, bytemuck::cast_slice(&gpu));
    }

    /// Resume the walks of set `s`'s batch of `n` queries whose candidates
    /// did not all fit (its queries and result words are still in place).
    fn submit_resume(&self, s: usize, n: usize, margins: bool) -> wgpu::SubmissionIndex {
        let set = &self.sets[s];
        let q = &self.ctx.queue;
        q.write_buffer(&set.params, 0, bytemuck::bytes_of(&self.params(n, true)));
        let mut enc = self.ctx.device.create_command_encoder(&Default::default());
        self.encode_passes(&mut enc, set, n, margins);
        self.send(enc)
    }

    /// The three dispatches of a pass over `n` queries, then the copies of
    /// their result words and the candidate counter to the readback buffer.
    pub(super) fn encode_passes(
        &self,
        enc: &mut wgpu::CommandEncoder,
        set: &BatchSet,
        n: usize,
        margins: bool,
    ) {
        enc.clear_buffer(&set.control, 0, None);
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("collide traverse"),
                timestamp_writes: None,
            });
            pass.set_bind_group(0, &set.bind_group, &[]);
            pass.set_pipeline(&self.pipelines.traverse);
            pass.dispatch_workgroups((n as u32).div_ceil(WORKGROUP), 1, 1);
            pass.set_pipeline(&self.pipelines.prepare);
            pass.dispatch_workgroups(1, 1, 1);
        }
        self.encode_exact(enc, set, margins);
        self.encode_readback(enc, set, n);
    }

    /// `collide_exact` over the candidates `collide_prepare` counted, with
    /// the margin's tests when `margins`.
    pub(super) fn encode_exact(
        &self,
        enc: &mut wgpu::CommandEncoder,
        set: &BatchSet,
        margins: bool,
    ) {
        enc.copy_buffer_to_buffer(&set.control, 4, &set.indirect, 0, 12);
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("collide exact"),
            timestamp_writes: None,
        });
        pass.set_bind_group(0, &set.bind_group, &[]);
        pass.set_pipeline(self.pipelines.exact_for(&self.ctx.device, margins));
        pass.dispatch_workgroups_indirect(&set.indirect, 0);
    }

    /// The copies of `n` result words and the candidate counter to the
    /// readback buffer ([`Self::read`]).
    pub(super) fn encode_readback(&self, enc: &mut wgpu::CommandEncoder, set: &BatchSet, n: usize) {
        enc.copy_buffer_to_buffer(&set.results, 0, &set.readback, 0, n as u64 * 4);
        enc.copy_buffer_to_buffer(
            &set.control,
            0,
            &set.readback,
            self.tuning.batch as u64 * 4,
            4,
        );
    }

    /// Wait for set `s`'s pass over `n` queries; its result words and the
    /// number of appends the candidate list was asked for.
    pub(super) fn read(
        &self,
        s: usize,
        n: usize,
        index: wgpu::SubmissionIndex,
    ) -> Result<(Vec<u32>, u32), CollideError> {
        self.map_read(&self.sets[s].readback, Some(index), |words| {
            (words[..n].to_vec(), words[self.tuning.batch])
        })
    }

    /// Finish set `s`'s batch of `batch` queries (submitted as `index`):
    /// settle it and append the verdicts to `out`.
    fn finish(
        &self,
        s: usize,
        batch: &[Query],
        index: wgpu::SubmissionIndex,
        out: &mut Vec<bool>,
    ) -> Result<(), CollideError> {
        let (words, _) = self.settle(s, batch.len(), margin_tests(batch), index)?;
        out.extend(words.iter().map(|&w| w & RESULT_HIT != 0));
        Ok(())
    }

    /// Read set `s`'s batch of `n` queries (submitted as `index`) and
    /// resume the walks its full candidate list cut short until every
    /// query is decided: the final result words, and whether any pass was
    /// resumed.
    pub(super) fn settle(
        &self,
        s: usize,
        n: usize,
        margins: bool,
        index: wgpu::SubmissionIndex,
    ) -> Result<(Vec<u32>, bool), CollideError> {
        let waiting = |words: &[u32]| {
            words
                .iter()
                .filter(|&&w| w & RESULT_INCOMPLETE != 0 && w & RESULT_HIT == 0)
                .count()
        };
        let (mut words, mut asked) = self.read(s, n, index)?;
        let mut counted = GpuStats {
            batches: 1,
            queries: n as u64,
            ..GpuStats::default()
        };
        let mut left = waiting(&words);
        let resumed = left > 0;
        loop {
            counted.candidates += asked.min(self.capacity) as u64;
            counted.full_lists += (asked > self.capacity) as u64;
            if left == 0 {
                break;
            }
            // Every waiting query has a pair left to hand over and the list
            // takes at least one, so this ends.
            counted.resumed_passes += 1;
            counted.resumed_queries += left as u64;
            let index = self.submit_resume(s, n, margins);
            (words, asked) = self.read(s, n, index)?;
            left = waiting(&words);
        }
        self.stats
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .add(&counted);
        Ok((words, resumed))
    }

    /// Evaluate `queries`: walked in coherent order
    /// ([`crate::collide::order`]), answered in theirs.
    pub(super) fn run(&self, queries: &[Query]) -> Result<Vec<bool>, CollideError> {
        if !self.tuning.coherent {
            return self.run_in_order(queries);
        }
        let order = coherent_order(queries);
        let sorted: Vec<Query> = order.par_iter().map(|&i| queries[i as usize]).collect();
        let mut out = vec![false; queries.len()];
        for (verdict, &i) in self.run_in_order(&sorted)?.into_iter().zip(&order) {
            out[i as usize] = verdict;
        }
        Ok(out)
    }

    /// Evaluate `queries` as given, in batches of at most `batch`, two in
    /// flight.
    fn run_in_order(&self, queries: &[Query]) -> Result<Vec<bool>, CollideError> {
        let mut out = Vec::with_capacity(queries.len());
        self.two_in_flight(
            queries.chunks(self.tuning.batch),
            |s, chunk| self.submit(s, chunk),
            |s, chunk, index| self.finish(s, chunk, index, &mut out),
        )?;
        Ok(out)
    }
}

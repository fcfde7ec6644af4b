//! Each kernel alone, for the differential tests against its CPU mirror
//! (`collide::cpu::traverse`, `collide::cpu::exact`,
//! `collide::cpu::expand`), pair by pair: not used by the backend's own
//! paths.

use super::super::moves::SampledMove;
use super::super::{check_finite, CollideError, Query};
use super::moves::{gpu_motion, gpu_move};
use super::queries::margin_tests;
use super::resources::WORKGROUP;
use super::wire::{GpuParams, Walk, RESULT_HIT};
use super::GpuBackend;
use crate::kinematics::Machine;
use crate::scene::GpuQuery;

/// Each kernel alone.
impl GpuBackend {
    /// `collide_traverse` alone over at most one batch of `queries` (every
    /// pair of a walk handed over at once): per query, whether the walk
    /// found it colliding and its undecided triangles in walk order (one invocation appends its pairs in order,
    /// so the shared list keeps each query's order). Fails when the pairs
    /// do not fit the candidate list: build the backend with a larger
    /// [`GpuOptions::capacity`](crate::collide::gpu::tuning::GpuOptions::capacity).
    pub fn walks(&self, queries: &[Query]) -> Result<Vec<Walk>, CollideError> {
        check_finite(queries)?;
        self.fits(queries.len())?;
        let _one_caller = self.busy.lock().unwrap_or_else(|e| e.into_inner());
        let set = &self.sets[0];
        let n = queries.len();
        let params = GpuParams {
            per_query: u32::MAX,
            ..self.params(n, false)
        };
        self.upload(set, queries, params);
        let pairs = self.scratch("walks: pairs", self.capacity as u64 * 8);
        let mut enc = self.ctx.device.create_command_encoder(&Default::default());
        enc.clear_buffer(&set.results, 0, Some(n as u64 * 4));
        enc.clear_buffer(&set.control, 0, None);
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            pass.set_bind_group(0, &set.bind_group, &[]);
            pass.set_pipeline(&self.pipelines.traverse);
            pass.dispatch_workgroups((n as u32).div_ceil(WORKGROUP), 1, 1);
        }
        self.encode_readback(&mut enc, set, n);
        enc.copy_buffer_to_buffer(&set.candidates, 0, &pairs, 0, self.capacity as u64 * 8);
        let index = self.send(enc);
        let (words, asked) = self.read(0, n, index)?;
        if asked > self.capacity {
            return Err(CollideError::Unavailable(format!(
                "walks: {asked} pairs do not fit the candidate list of {}",
                self.capacity
            )));
        }
        let list: Vec<[u32; 2]> = self
            .map_words(&pairs, asked as usize * 2, None)?
            .chunks(2)
            .map(|p| [p[0], p[1]])
            .collect();
        let mut out: Vec<Walk> = words
            .iter()
            .map(|&w| Walk {
                hit: w & RESULT_HIT != 0,
                candidates: Vec::new(),
            })
            .collect();
        for [qi, t] in list {
            out[qi as usize].candidates.push(t);
        }
        Ok(out)
    }

    /// `collide_exact` alone over the given pairs (query, part triangle),
    /// each as if the walk had handed it over: one verdict per pair.
    pub fn exact_pairs(&self, pairs: &[(Query, u32)]) -> Result<Vec<bool>, CollideError> {
        let queries: Vec<Query> = pairs.iter().map(|p| p.0).collect();
        check_finite(&queries)?;
        self.fits(pairs.len())?;
        if pairs.len() > self.capacity as usize {
            return Err(CollideError::Unavailable(format!(
                "exact_pairs: {} pairs exceed the candidate list of {}",
                pairs.len(),
                self.capacity
            )));
        }
        let _one_caller = self.busy.lock().unwrap_or_else(|e| e.into_inner());
        let set = &self.sets[0];
        let n = pairs.len();
        let list: Vec<[u32; 2]> = pairs
            .iter()
            .enumerate()
            .map(|(k, p)| [k as u32, p.1])
            .collect();
        self.upload(set, &queries, self.params(n, false));
        let q = &self.ctx.queue;
        if n > 0 {
            q.write_buffer(&set.candidates, 0, bytemuck::cast_slice(&list));
        }
        q.write_buffer(&set.control, 0, bytemuck::cast_slice(&[n as u32, 0, 0, 0]));
        let mut enc = self.ctx.device.create_command_encoder(&Default::default());
        enc.clear_buffer(&set.results, 0, Some(n as u64 * 4));
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            pass.set_bind_group(0, &set.bind_group, &[]);
            pass.set_pipeline(&self.pipelines.prepare);
            pass.dispatch_workgroups(1, 1, 1);
        }
        self.encode_exact(&mut enc, set, margin_tests(&queries));
        self.encode_readback(&mut enc, set, n);
        let index = self.send(enc);
        let (words, _) = self.read(0, n, index)?;
        Ok(words.iter().map(|&w| w & RESULT_HIT != 0).collect())
    }

    /// `collide_expand` alone: the queries it poses for `moves` (at most
    /// one batch of samples), in order, as the traverse kernel would read
    /// them.
    pub fn expanded(
        &self,
        machine: &Machine,
        moves: &[SampledMove],
    ) -> Result<Vec<GpuQuery>, CollideError> {
        let mut gpu_moves = Vec::new();
        let mut total = 0usize;
        for mv in moves {
            gpu_moves.push(gpu_move(mv, total as u32));
            total += mv.intervals.saturating_sub(1) as usize;
        }
        self.fits(total)?;
        let _one_caller = self.busy.lock().unwrap_or_else(|e| e.into_inner());
        let set = &self.sets[0];
        let q = &self.ctx.queue;
        q.write_buffer(
            &set.motion,
            0,
            bytemuck::bytes_of(&gpu_motion(machine, gpu_moves.len())),
        );
        if !gpu_moves.is_empty() {
            q.write_buffer(&set.moves, 0, bytemuck::cast_slice(&gpu_moves));
        }
        let size = std::mem::size_of::<GpuQuery>() as u64;
        let copy = self.scratch("expanded queries", total as u64 * size);
        let mut enc = self.ctx.device.create_command_encoder(&Default::default());
        self.encode_motion(&mut enc, set, &self.pipelines.expand, gpu_moves.len());
        enc.copy_buffer_to_buffer(&set.queries, 0, &copy, 0, total as u64 * size);
        let index = self.send(enc);
        let words = self.map_words(&copy, total * size as usize / 4, Some(index))?;
        Ok(bytemuck::cast_slice::<u32, GpuQuery>(&words).to_vec())
    }

    /// At most one batch.
    fn fits(&self, n: usize) -> Result<(), CollideError> {
        if n > self.tuning.batch {
            return Err(CollideError::Unavailable(format!(
                "{n} queries exceed one batch of {}",
                self.tuning.batch
            )));
        }
        Ok(())
    }
}

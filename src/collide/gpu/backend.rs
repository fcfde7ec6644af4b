//! The gpu backend ([`GpuBackend`]): the host side of the `collide_*`
//! kernels (`shaders/`). The scene is uploaded once
//! ([`super::resources`]); queries stream in batches sized to the device
//! ([`super::queries`]), moves are posed and reduced on the device
//! ([`super::moves`]). This file builds it and holds what every path
//! shares: one caller at a time, the time it spends waiting on the device,
//! and reading buffers back.

use super::super::moves::SampledMove;
use super::super::{check_finite, Backend, CollideError, Query};
use super::context::{AdapterSummary, GpuContext};
use super::pipelines::Pipelines;
use super::resources::{binding_bytes, BatchSet, BatchSizes, Layouts, SceneBuffers, SceneSplit};
use super::{GpuOptions, GpuStats, GpuTuning};
use crate::kinematics::Machine;
use crate::scene::Scene;

/// Queries whose margin at the head's farthest point exceeds this (mm)
/// are answered on the CPU beside the device ([`Backend::wide_above`]):
/// the kernels gather every pair of head and part volumes within the
/// margin before testing one, so a query of tens of millimetres (a
/// travel's first, coarse samples) costs the device passes that the cpu
/// backend's walk, stopping at the first triangle within the margin,
/// does not.
pub const WIDE_ABOVE: f32 = 8.0;

/// The `gpu` backend.
pub struct GpuBackend {
    pub(super) ctx: GpuContext,
    pub(super) pipelines: Pipelines,
    /// The two sets of per-batch buffers, used in turn.
    pub(super) sets: [BatchSet; 2],
    /// Held for the whole of an `evaluate`: the two buffer sets serve one
    /// caller at a time (the planner measures the input on another thread
    /// while it plans, and both share this backend).
    pub(super) busy: std::sync::Mutex<()>,
    /// What it runs with, the batch within the device's limits.
    pub(super) tuning: GpuTuning,
    /// Slots of each set's candidate list.
    pub(super) capacity: u32,
    /// Counted by [`Self::settle`] and [`Self::timed`], under `busy`.
    pub(super) stats: std::sync::Mutex<GpuStats>,
    /// Nanoseconds [`Self::map_read`] has spent blocked on the device.
    waited_ns: std::sync::atomic::AtomicU64,
    /// Part nodes per binding.
    pub(super) nodes_per_chunk: u32,
    /// Part triangles per binding.
    pub(super) tris_per_chunk: u32,
    /// Scene bytes resident on the device.
    pub scene_bytes: u64,
    /// Storage bindings in use for part nodes and part triangles.
    pub bindings_used: (usize, usize),
}

impl GpuBackend {
    /// Upload `scene` to the context's device and build the pipelines.
    pub fn new(ctx: GpuContext, scene: &Scene, opts: GpuOptions) -> Result<Self, CollideError> {
        assert!(
            !scene.bvh_released(),
            "a backend on a scene whose BVH was released"
        );
        let device = &ctx.device;
        let binding = binding_bytes(device, opts.max_binding_bytes);
        let split = SceneSplit::new(scene, binding, &ctx.summary.name)?;
        let uploaded = SceneBuffers::upload(device, scene, &split);
        let layouts = Layouts::new(device);
        let tuning = opts.tuned(&ctx.summary);
        let pipelines = Pipelines::build(device, &layouts, split.binding_overrides(), &tuning);
        let sizes = BatchSizes::new(&device.limits(), binding, &tuning, opts.capacity);
        let set = |label| BatchSet::new(device, &layouts, &uploaded, sizes, label);
        let sets = [set("batch set 0"), set("batch set 1")];
        Ok(GpuBackend {
            pipelines,
            sets,
            busy: std::sync::Mutex::new(()),
            tuning: GpuTuning {
                batch: sizes.batch,
                ..tuning
            },
            capacity: sizes.capacity as u32,
            stats: Default::default(),
            waited_ns: Default::default(),
            nodes_per_chunk: split.nodes_per_chunk.min(u32::MAX as usize) as u32,
            tris_per_chunk: split.tris_per_chunk.min(u32::MAX as usize) as u32,
            scene_bytes: uploaded.bytes(),
            bindings_used: split.bindings_used,
            ctx,
        })
    }

    /// The adapter in use.
    pub fn adapter(&self) -> &AdapterSummary {
        &self.ctx.summary
    }

    /// The settings this backend runs with (its batch within the device's
    /// limits).
    pub fn tuning(&self) -> GpuTuning {
        self.tuning
    }

    /// Queries per dispatch.
    pub fn batch_size(&self) -> usize {
        self.tuning.batch
    }

    /// What the backend has done so far.
    pub fn stats(&self) -> GpuStats {
        *self.stats.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Run `batches` through the two buffer sets in turn, two in flight:
    /// `submit(set, batch)` encodes and submits one, and
    /// `finish(set, batch, index)` settles the one before it once the next
    /// is on its way (so the device computes one while the host reads the
    /// other back), each batch finished in order.
    pub(super) fn two_in_flight<T: Copy>(
        &self,
        batches: impl IntoIterator<Item = T>,
        submit: impl Fn(usize, T) -> wgpu::SubmissionIndex,
        mut finish: impl FnMut(usize, T, wgpu::SubmissionIndex) -> Result<(), CollideError>,
    ) -> Result<(), CollideError> {
        let mut pending: Option<(usize, T, wgpu::SubmissionIndex)> = None;
        for (k, batch) in batches.into_iter().enumerate() {
            let s = k % 2;
            let index = submit(s, batch);
            if let Some((ps, pb, pi)) = pending.take() {
                finish(ps, pb, pi)?;
            }
            pending = Some((s, batch, index));
        }
        if let Some((ps, pb, pi)) = pending {
            finish(ps, pb, pi)?;
        }
        Ok(())
    }

    /// Run `work` (one caller's call) and count its wall time in
    /// [`GpuStats::host`] and [`GpuStats::waiting`].
    pub(super) fn timed<T>(&self, work: impl FnOnce() -> T) -> T {
        use std::sync::atomic::Ordering::Relaxed;
        let t0 = std::time::Instant::now();
        let waited0 = self.waited_ns.load(Relaxed);
        let out = work();
        let total = t0.elapsed();
        let waiting = std::time::Duration::from_nanos(self.waited_ns.load(Relaxed) - waited0);
        let mut stats = self.stats.lock().unwrap_or_else(|e| e.into_inner());
        stats.host += total.saturating_sub(waiting);
        stats.waiting += waiting;
        out
    }

    /// Submit `enc`, the time it takes counted as waiting on the device
    /// (a driver may block here until earlier work is done: lavapipe runs
    /// a submission's passes before it returns).
    pub(super) fn send(&self, enc: wgpu::CommandEncoder) -> wgpu::SubmissionIndex {
        let t0 = std::time::Instant::now();
        let index = self.ctx.queue.submit([enc.finish()]);
        self.waited_since(t0);
        index
    }

    /// Count the time since `t0` as spent blocked on the device.
    pub(super) fn waited_since(&self, t0: std::time::Instant) {
        self.waited_ns.fetch_add(
            t0.elapsed().as_nanos() as u64,
            std::sync::atomic::Ordering::Relaxed,
        );
    }

    /// A buffer to copy device data into and map.
    pub(super) fn scratch(&self, label: &str, size: u64) -> wgpu::Buffer {
        self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: size.max(4),
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    /// The first `n` words of a mappable buffer whose copy was submitted
    /// (as `index`, or with everything submitted so far).
    pub(super) fn map_words(
        &self,
        buf: &wgpu::Buffer,
        n: usize,
        index: Option<wgpu::SubmissionIndex>,
    ) -> Result<Vec<u32>, CollideError> {
        self.map_read(buf, index, |words| words[..n].to_vec())
    }

    /// Wait for submission `index` (or everything submitted so far), map
    /// `buf` and let `f` read its words.
    pub(super) fn map_read<T>(
        &self,
        buf: &wgpu::Buffer,
        index: Option<wgpu::SubmissionIndex>,
        f: impl FnOnce(&[u32]) -> T,
    ) -> Result<T, CollideError> {
        let slice = buf.slice(..);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        let t0 = std::time::Instant::now();
        let polled = self.ctx.device.poll(wgpu::PollType::Wait {
            submission_index: index,
            timeout: None,
        });
        self.waited_since(t0);
        polled.map_err(|e| CollideError::Unavailable(format!("GPU stopped responding: {e}")))?;
        let failed = |e: String| CollideError::Unavailable(format!("GPU readback failed: {e}"));
        rx.recv()
            .map_err(|e| failed(e.to_string()))?
            .map_err(|e| failed(e.to_string()))?;
        let out = {
            let data = slice
                .get_mapped_range()
                .map_err(|e| failed(e.to_string()))?;
            f(bytemuck::cast_slice(&data))
        };
        buf.unmap();
        Ok(out)
    }
}

impl Backend for GpuBackend {
    fn name(&self) -> &'static str {
        "gpu"
    }

    fn evaluate(&self, queries: &[Query]) -> Result<Vec<bool>, CollideError> {
        check_finite(queries)?;
        // A panic elsewhere while holding it leaves the buffers as
        // consistent as any other finished call: the poison is ignored.
        let _one_caller = self.busy.lock().unwrap_or_else(|e| e.into_inner());
        self.timed(|| self.run(queries))
    }

    /// Four batches a call: the two buffer sets overlap compute and
    /// readback within one call, not across calls.
    fn batch_hint(&self) -> usize {
        4 * self.tuning.batch
    }

    fn summary(&self) -> Option<String> {
        Some(format!("{} [{}]", self.stats(), self.tuning()))
    }

    /// [`WIDE_ABOVE`].
    fn wide_above(&self) -> Option<f32> {
        Some(WIDE_ABOVE)
    }

    /// Posed and reduced on the device ([`super::moves`]).
    fn sampled_moves(
        &self,
        machine: &Machine,
        moves: &[SampledMove],
    ) -> Result<Vec<bool>, CollideError> {
        self.moves_on_device(machine, moves)
    }
}

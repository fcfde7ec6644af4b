//! Host side of the `collide_*` kernels. The scene is uploaded once into
//! persistent buffers (split across bindings where one binding is too
//! small); queries stream in batches sized to the device. Each batch runs
//! three dispatches in one submission — `collide_traverse` (per query: BVH
//! walk, grid culling, undecided pairs appended to a candidate list),
//! `collide_prepare` (indirect dispatch size) and `collide_exact` (per
//! candidate: Möller, the safety margin's distance tests, containment).
//! `collide_exact` is built twice: with the margin's tests and without them
//! (the `MARGIN_TESTS` override), the latter for batches whose queries all
//! have margin 0, so those cost what they did before margins existed on
//! lavapipe too (it runs a branch's body even when no invocation takes
//! it). Two sets of per-batch buffers alternate, so the next batch
//! computes while the previous one is read back. A batch whose candidates
//! overflow the list is redone in halves.

use super::super::{check_finite, Backend, CollideError, Query};
use super::context::GpuContext;
use super::shaders::{COLLIDE_EXACT, COLLIDE_PREPARE, COLLIDE_TRAVERSE};
use crate::scene::{GpuPartNode, GpuQuery, GpuTriangle, Scene};
use bytemuck::{Pod, Zeroable};
use wgpu::util::DeviceExt;

/// Bindings the part nodes and triangles may be split across (keep in sync
/// with `shaders/shared/collide_common.wgsl`).
pub const NODE_CHUNKS: usize = 2;
/// See [`NODE_CHUNKS`].
pub const TRI_CHUNKS: usize = 4;
const WORKGROUP: u32 = 64;
/// Candidate slots per query in a batch (the average on simple_curve's
/// tilted poses is about 40).
const CANDIDATES_PER_QUERY: u64 = 64;

/// Tuning of the GPU backend.
#[derive(Clone, Copy, Debug, Default)]
pub struct GpuOptions {
    /// Cap on one storage binding's size in bytes (default: the device's
    /// limit). Tests lower it to exercise split bindings on small scenes.
    pub max_binding_bytes: Option<u64>,
    /// Queries per dispatch (default: 65,536, within the device's limits).
    pub batch: Option<usize>,
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Params {
    nodes_per_chunk: u32,
    tris_per_chunk: u32,
    query_count: u32,
    capacity: u32,
}

/// One set of per-batch buffers.
struct BatchSet {
    params: wgpu::Buffer,
    queries: wgpu::Buffer,
    results: wgpu::Buffer,
    control: wgpu::Buffer,
    indirect: wgpu::Buffer,
    readback: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
}

/// The `gpu` backend.
pub struct GpuBackend {
    ctx: GpuContext,
    traverse: wgpu::ComputePipeline,
    prepare: wgpu::ComputePipeline,
    /// `collide_exact` with the margin's distance tests.
    exact: wgpu::ComputePipeline,
    /// `collide_exact` without them, for batches at margin 0.
    exact_touch: wgpu::ComputePipeline,
    sets: [BatchSet; 2],
    /// Held for the whole of an `evaluate`: the two buffer sets serve one
    /// caller at a time (the planner measures the input on another thread
    /// while it plans, and both share this backend).
    busy: std::sync::Mutex<()>,
    batch: usize,
    capacity: u32,
    nodes_per_chunk: u32,
    tris_per_chunk: u32,
    /// Scene bytes resident on the device.
    pub scene_bytes: u64,
    /// Storage bindings in use for part nodes and part triangles.
    pub bindings_used: (usize, usize),
}

/// Split `data` into `chunks` pieces of `per` elements (empty pieces get one
/// default element so every binding is valid).
fn chunked<T: Pod + Default>(data: &[T], per: usize, chunks: usize) -> Vec<Vec<T>> {
    (0..chunks)
        .map(|c| {
            let lo = (c * per).min(data.len());
            let hi = ((c + 1) * per).min(data.len());
            if lo < hi {
                data[lo..hi].to_vec()
            } else {
                vec![T::default()]
            }
        })
        .collect()
}

fn layout_entries() -> Vec<wgpu::BindGroupLayoutEntry> {
    let entry = |binding: u32, ty: wgpu::BufferBindingType| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    };
    let read = wgpu::BufferBindingType::Storage { read_only: true };
    let write = wgpu::BufferBindingType::Storage { read_only: false };
    let mut v = vec![
        entry(0, wgpu::BufferBindingType::Uniform),
        entry(1, wgpu::BufferBindingType::Uniform),
        entry(2, read),
        entry(3, write),
    ];
    v.extend((4..14).map(|b| entry(b, read)));
    v.push(entry(14, write));
    v.push(entry(15, write));
    v
}

impl GpuBackend {
    /// Upload `scene` to the context's device and build the pipelines.
    pub fn new(ctx: GpuContext, scene: &Scene, opts: GpuOptions) -> Result<Self, CollideError> {
        let device = &ctx.device;
        let limits = device.limits();
        let binding = limits
            .max_storage_buffer_binding_size
            .min(limits.max_buffer_size)
            .min(opts.max_binding_bytes.unwrap_or(u64::MAX));
        let node_size = std::mem::size_of::<GpuPartNode>() as u64;
        let tri_size = std::mem::size_of::<GpuTriangle>() as u64;
        let nodes_per_chunk = (binding / node_size).min(u32::MAX as u64) as usize;
        let tris_per_chunk = (binding / tri_size).min(u32::MAX as u64) as usize;
        let nodes = &scene.part_nodes;
        let tris = &scene.part_tris;
        if nodes.len() > nodes_per_chunk * NODE_CHUNKS || tris.len() > tris_per_chunk * TRI_CHUNKS {
            return Err(CollideError::Unavailable(format!(
                "the scene ({} triangles) exceeds what {} can bind ({TRI_CHUNKS} × {binding} bytes): split the part into layer ranges or use --backend cpu",
                tris.len(),
                ctx.summary.name
            )));
        }

        let storage = |label: &str, bytes: &[u8]| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: bytes,
                usage: wgpu::BufferUsages::STORAGE,
            })
        };
        let head = &scene.head;
        let head_params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("head params"),
            contents: bytemuck::bytes_of(&head.params),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let mut scene_bufs = vec![
            storage("head nodes", bytemuck::cast_slice(&head.nodes)),
            storage("head tris", bytemuck::cast_slice(&head.triangles)),
            storage("head ray tris", bytemuck::cast_slice(&head.ray_triangles)),
            storage("head grid", bytemuck::cast_slice(&head.grid)),
        ];
        for c in chunked(nodes, nodes_per_chunk, NODE_CHUNKS) {
            scene_bufs.push(storage("part nodes", bytemuck::cast_slice(&c)));
        }
        for c in chunked(tris, tris_per_chunk, TRI_CHUNKS) {
            scene_bufs.push(storage("part tris", bytemuck::cast_slice(&c)));
        }
        let scene_bytes = scene_bufs.iter().map(|b| b.size()).sum();

        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("collide"),
            entries: &layout_entries(),
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("collide"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = |label: &str, src: &str, constants: &[(&str, f64)]| {
            let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(label),
                source: wgpu::ShaderSource::Wgsl(src.into()),
            });
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(label),
                layout: Some(&pipeline_layout),
                module: &module,
                entry_point: Some("main"),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants,
                    ..Default::default()
                },
                cache: None,
            })
        };
        let traverse = pipeline("collide_traverse.wgsl", COLLIDE_TRAVERSE, &[]);
        let prepare = pipeline("collide_prepare.wgsl", COLLIDE_PREPARE, &[]);
        let exact = pipeline(
            "collide_exact.wgsl",
            COLLIDE_EXACT,
            &[("MARGIN_TESTS", 1.0)],
        );
        let exact_touch = pipeline(
            "collide_exact.wgsl (margin 0)",
            COLLIDE_EXACT,
            &[("MARGIN_TESTS", 0.0)],
        );

        let query_size = std::mem::size_of::<GpuQuery>() as u64;
        let max_groups = limits.max_compute_workgroups_per_dimension as u64;
        let batch = (opts.batch.unwrap_or(65_536) as u64)
            .min(max_groups * WORKGROUP as u64)
            .min(binding / query_size)
            .min(max_groups * WORKGROUP as u64 / CANDIDATES_PER_QUERY)
            .max(1);
        let capacity = (batch * CANDIDATES_PER_QUERY)
            .min(binding / 8)
            .min(max_groups * WORKGROUP as u64);
        let batch = batch as usize;
        let make_set = |label: &str| {
            let buf = |what: &str, size: u64, usage: wgpu::BufferUsages| {
                device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some(&format!("{label} {what}")),
                    size,
                    usage,
                    mapped_at_creation: false,
                })
            };
            use wgpu::BufferUsages as U;
            let params = buf(
                "params",
                std::mem::size_of::<Params>() as u64,
                U::UNIFORM | U::COPY_DST,
            );
            let queries = buf(
                "queries",
                batch as u64 * query_size,
                U::STORAGE | U::COPY_DST,
            );
            let results = buf(
                "results",
                batch as u64 * 4,
                U::STORAGE | U::COPY_SRC | U::COPY_DST,
            );
            let candidates = buf("candidates", capacity * 8, U::STORAGE);
            let control = buf("control", 16, U::STORAGE | U::COPY_SRC | U::COPY_DST);
            // Not in the bind group: a buffer bound as storage cannot also
            // drive an indirect dispatch in the same pass.
            let indirect = buf("indirect", 12, U::INDIRECT | U::COPY_DST);
            let readback = buf("readback", batch as u64 * 4 + 4, U::MAP_READ | U::COPY_DST);
            let mut resources = vec![
                params.as_entire_binding(),
                head_params.as_entire_binding(),
                queries.as_entire_binding(),
                results.as_entire_binding(),
            ];
            resources.extend(scene_bufs.iter().map(|b| b.as_entire_binding()));
            resources.push(candidates.as_entire_binding());
            resources.push(control.as_entire_binding());
            let entries: Vec<wgpu::BindGroupEntry> = resources
                .into_iter()
                .enumerate()
                .map(|(i, resource)| wgpu::BindGroupEntry {
                    binding: i as u32,
                    resource,
                })
                .collect();
            let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(label),
                layout: &layout,
                entries: &entries,
            });
            BatchSet {
                params,
                queries,
                results,
                control,
                indirect,
                readback,
                bind_group,
            }
        };
        let sets = [make_set("batch set 0"), make_set("batch set 1")];
        Ok(GpuBackend {
            traverse,
            prepare,
            exact,
            exact_touch,
            sets,
            busy: std::sync::Mutex::new(()),
            batch,
            capacity: capacity as u32,
            nodes_per_chunk: nodes_per_chunk.min(u32::MAX as usize) as u32,
            tris_per_chunk: tris_per_chunk.min(u32::MAX as usize) as u32,
            scene_bytes,
            bindings_used: (
                nodes.len().div_ceil(nodes_per_chunk),
                tris.len().div_ceil(tris_per_chunk),
            ),
            ctx,
        })
    }

    /// The adapter in use.
    pub fn adapter(&self) -> &super::AdapterSummary {
        &self.ctx.summary
    }

    /// Queries per dispatch.
    pub fn batch_size(&self) -> usize {
        self.batch
    }

    /// Encode and submit one batch on buffer set `s`.
    fn submit(&self, s: usize, batch: &[Query]) -> wgpu::SubmissionIndex {
        let set = &self.sets[s];
        let gpu: Vec<GpuQuery> = batch.iter().map(|q| q.to_gpu()).collect();
        let n = batch.len() as u64;
        let params = Params {
            nodes_per_chunk: self.nodes_per_chunk,
            tris_per_chunk: self.tris_per_chunk,
            query_count: batch.len() as u32,
            capacity: self.capacity,
        };
        let q = &self.ctx.queue;
        q.write_buffer(&set.params, 0, bytemuck::bytes_of(&params));
        q.write_buffer(&set.queries, 0, bytemuck::cast_slice(&gpu));
        let mut enc = self.ctx.device.create_command_encoder(&Default::default());
        enc.clear_buffer(&set.results, 0, Some(n * 4));
        enc.clear_buffer(&set.control, 0, None);
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("collide traverse"),
                timestamp_writes: None,
            });
            pass.set_bind_group(0, &set.bind_group, &[]);
            pass.set_pipeline(&self.traverse);
            pass.dispatch_workgroups((batch.len() as u32).div_ceil(WORKGROUP), 1, 1);
            pass.set_pipeline(&self.prepare);
            pass.dispatch_workgroups(1, 1, 1);
        }
        enc.copy_buffer_to_buffer(&set.control, 4, &set.indirect, 0, 12);
        {
            let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("collide exact"),
                timestamp_writes: None,
            });
            pass.set_bind_group(0, &set.bind_group, &[]);
            if batch.iter().any(|q| q.margin > 0.0 || q.slope > 0.0) {
                pass.set_pipeline(&self.exact);
            } else {
                pass.set_pipeline(&self.exact_touch);
            }
            pass.dispatch_workgroups_indirect(&set.indirect, 0);
        }
        enc.copy_buffer_to_buffer(&set.results, 0, &set.readback, 0, n * 4);
        enc.copy_buffer_to_buffer(&set.control, 0, &set.readback, self.batch as u64 * 4, 4);
        q.submit([enc.finish()])
    }

    /// Wait for set `s`'s batch of `n` queries; append its verdicts and say
    /// whether its candidate list overflowed (then they are incomplete).
    fn read(
        &self,
        s: usize,
        n: usize,
        index: wgpu::SubmissionIndex,
        out: &mut Vec<bool>,
    ) -> Result<bool, CollideError> {
        let set = &self.sets[s];
        let slice = set.readback.slice(..);
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.ctx
            .device
            .poll(wgpu::PollType::Wait {
                submission_index: Some(index),
                timeout: None,
            })
            .map_err(|e| CollideError::Unavailable(format!("GPU stopped responding: {e}")))?;
        let failed = |e: String| CollideError::Unavailable(format!("GPU readback failed: {e}"));
        rx.recv()
            .map_err(|e| failed(e.to_string()))?
            .map_err(|e| failed(e.to_string()))?;
        let overflow = {
            let data = slice
                .get_mapped_range()
                .map_err(|e| failed(e.to_string()))?;
            let words: &[u32] = bytemuck::cast_slice(&data);
            out.extend(words[..n].iter().map(|&w| w != 0));
            words[self.batch] > self.capacity
        };
        set.readback.unmap();
        Ok(overflow)
    }

    /// Evaluate `queries` in batches of at most `batch`, two in flight.
    fn run(&self, queries: &[Query], batch: usize) -> Result<Vec<bool>, CollideError> {
        let mut out = Vec::with_capacity(queries.len());
        let mut redo = Vec::new();
        let mut pending: Option<(usize, usize, usize, wgpu::SubmissionIndex)> = None;
        let mut finish = |p: (usize, usize, usize, wgpu::SubmissionIndex), out: &mut Vec<bool>| {
            let (s, start, n, index) = p;
            if self.read(s, n, index, out)? {
                redo.push(start..start + n);
            }
            Ok::<(), CollideError>(())
        };
        for (k, chunk) in queries.chunks(batch).enumerate() {
            let s = k % 2;
            let index = self.submit(s, chunk);
            if let Some(p) = pending.take() {
                finish(p, &mut out)?;
            }
            pending = Some((s, k * batch, chunk.len(), index));
        }
        if let Some(p) = pending {
            finish(p, &mut out)?;
        }
        // Batches whose candidates overflowed: again, in halves.
        for range in redo {
            let half = (range.len() / 2).max(1);
            if half == range.len() {
                return Err(CollideError::Unavailable(format!(
                    "one query needs more than {} exact tests: the GPU candidate list is too small",
                    self.capacity
                )));
            }
            let again = self.run(&queries[range.clone()], half)?;
            out[range].copy_from_slice(&again);
        }
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
        self.run(queries, self.batch)
    }
}

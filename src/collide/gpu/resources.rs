//! The gpu backend's device memory: the scene uploaded once into
//! persistent buffers (the part split across several bindings where one
//! binding is too small), the two bind group layouts (the `collide_*`
//! kernels', the motion kernels'), and the two sets of per-batch buffers
//! that alternate, so the next batch computes while the previous one is
//! read back.

use super::super::CollideError;
use super::wire::{GpuMotion, GpuMove, GpuParams};
use super::GpuTuning;
use crate::scene::{GpuPartNode, GpuQuery, GpuTriangle, Scene};
use bytemuck::Pod;
use wgpu::util::DeviceExt;

/// Bindings the part nodes and triangles may be split across (keep in sync
/// with `shaders/shared/collide_common.wgsl`).
pub const NODE_CHUNKS: usize = 2;
/// See [`NODE_CHUNKS`].
pub const TRI_CHUNKS: usize = 4;
/// Invocations per workgroup of every `collide_*` kernel (`WORKGROUP` in
/// `collide_common.wgsl`, `@workgroup_size` of the entry points).
pub(super) const WORKGROUP: u32 = 64;
/// Candidate slots per query in a batch (more than a tilted pose over a
/// printed part hands over on average).
const CANDIDATES_PER_QUERY: u64 = 64;

/// The largest storage binding the device (and the caller's cap) allows,
/// in bytes.
pub(super) fn binding_bytes(device: &wgpu::Device, cap: Option<u64>) -> u64 {
    let limits = device.limits();
    limits
        .max_storage_buffer_binding_size
        .min(limits.max_buffer_size)
        .min(cap.unwrap_or(u64::MAX))
}

/// How the part's nodes and triangles are split across their bindings.
#[derive(Clone, Copy, Debug)]
pub(super) struct SceneSplit {
    /// Part nodes per binding.
    pub nodes_per_chunk: usize,
    /// Part triangles per binding.
    pub tris_per_chunk: usize,
    /// Bindings the scene fills: (part nodes, part triangles).
    pub bindings_used: (usize, usize),
}

impl SceneSplit {
    /// The split of `scene` into bindings of `binding` bytes; an error
    /// naming `adapter` when even all the bindings cannot hold it.
    pub fn new(scene: &Scene, binding: u64, adapter: &str) -> Result<Self, CollideError> {
        let node_size = std::mem::size_of::<GpuPartNode>() as u64;
        let tri_size = std::mem::size_of::<GpuTriangle>() as u64;
        let nodes_per_chunk = (binding / node_size).min(u32::MAX as u64) as usize;
        let tris_per_chunk = (binding / tri_size).min(u32::MAX as u64) as usize;
        let (nodes, tris) = (scene.part_nodes.len(), scene.part_tris.len());
        if nodes > nodes_per_chunk * NODE_CHUNKS || tris > tris_per_chunk * TRI_CHUNKS {
            return Err(CollideError::Unavailable(format!(
                "the scene ({tris} triangles) exceeds what {adapter} can bind ({TRI_CHUNKS} × {binding} bytes): split the part into layer ranges or use --backend cpu"
            )));
        }
        Ok(SceneSplit {
            nodes_per_chunk,
            tris_per_chunk,
            bindings_used: (
                nodes.div_ceil(nodes_per_chunk).max(1),
                tris.div_ceil(tris_per_chunk).max(1),
            ),
        })
    }

    /// The pipeline overrides naming the bindings this scene fills: reads
    /// past them are compiled out (`NODE_BINDINGS`, `TRI_BINDINGS` in
    /// `collide_common.wgsl`).
    pub fn binding_overrides(&self) -> [(&'static str, f64); 2] {
        [
            ("NODE_BINDINGS", self.bindings_used.0 as f64),
            ("TRI_BINDINGS", self.bindings_used.1 as f64),
        ]
    }
}

/// The scene on the device, in binding order from binding 1: the head's
/// scalars, then its nodes, triangles, ray-space triangles and grid, then
/// the part's node and triangle chunks (bindings 4 to 13).
pub(super) struct SceneBuffers {
    head_params: wgpu::Buffer,
    storage: Vec<wgpu::Buffer>,
}

impl SceneBuffers {
    /// Upload `scene`, split as `split` says.
    pub fn upload(device: &wgpu::Device, scene: &Scene, split: &SceneSplit) -> Self {
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
        let mut buffers = vec![
            storage("head nodes", bytemuck::cast_slice(&head.nodes)),
            storage("head tris", bytemuck::cast_slice(&head.triangles)),
            storage("head ray tris", bytemuck::cast_slice(&head.ray_triangles)),
            storage("head grid", bytemuck::cast_slice(&head.grid)),
        ];
        for c in chunked(&scene.part_nodes, split.nodes_per_chunk, NODE_CHUNKS) {
            buffers.push(storage("part nodes", bytemuck::cast_slice(&c)));
        }
        for c in chunked(&scene.part_tris, split.tris_per_chunk, TRI_CHUNKS) {
            buffers.push(storage("part tris", bytemuck::cast_slice(&c)));
        }
        SceneBuffers {
            head_params,
            storage: buffers,
        }
    }

    /// Bytes resident on the device in its storage buffers.
    pub fn bytes(&self) -> u64 {
        self.storage.iter().map(|b| b.size()).sum()
    }
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

/// The two bind group layouts and their pipeline layouts.
pub(super) struct Layouts {
    /// The `collide_*` kernels' bindings (`collide_common.wgsl`).
    pub collide: wgpu::BindGroupLayout,
    /// Their pipeline layout.
    pub collide_pipeline: wgpu::PipelineLayout,
    /// The motion kernels' bindings (`motion.wgsl`).
    pub motion: wgpu::BindGroupLayout,
    /// Their pipeline layout.
    pub motion_pipeline: wgpu::PipelineLayout,
}

impl Layouts {
    /// Both layouts on `device`.
    pub fn new(device: &wgpu::Device) -> Self {
        let layout = |label: &str, entries: &[wgpu::BindGroupLayoutEntry]| {
            let bind = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
                label: Some(label),
                entries,
            });
            let pipeline = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(label),
                bind_group_layouts: &[Some(&bind)],
                immediate_size: 0,
            });
            (bind, pipeline)
        };
        let (collide, collide_pipeline) = layout("collide", &layout_entries());
        let (motion, motion_pipeline) = layout("collide motion", &motion_layout_entries());
        Layouts {
            collide,
            collide_pipeline,
            motion,
            motion_pipeline,
        }
    }
}

/// A compute kernel's buffer binding.
fn entry(binding: u32, ty: wgpu::BufferBindingType) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// Read-only and read-write storage.
const READ: wgpu::BufferBindingType = wgpu::BufferBindingType::Storage { read_only: true };
const WRITE: wgpu::BufferBindingType = wgpu::BufferBindingType::Storage { read_only: false };

/// The `collide_*` kernels' bindings: the batch's parameters and the
/// head's scalars (uniform), the queries, their result words, the scene
/// (bindings 4 to 13), the candidate list and its counter.
fn layout_entries() -> Vec<wgpu::BindGroupLayoutEntry> {
    let (read, write) = (READ, WRITE);
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

/// The motion kernels' bindings: the machine (uniform), the moves, the
/// batch's queries (written), its result words (read), the move verdicts.
fn motion_layout_entries() -> Vec<wgpu::BindGroupLayoutEntry> {
    let (read, write) = (READ, WRITE);
    vec![
        entry(0, wgpu::BufferBindingType::Uniform),
        entry(1, read),
        entry(2, write),
        entry(3, read),
        entry(4, write),
    ]
}

/// A batch's size within the device's limits, and its candidate list's.
#[derive(Clone, Copy, Debug)]
pub(super) struct BatchSizes {
    /// Queries per batch.
    pub batch: usize,
    /// Slots of the candidate list.
    pub capacity: u64,
}

impl BatchSizes {
    /// The tuning's batch and the given (or default) capacity, within the
    /// dispatch limit and the largest binding (`binding` bytes). A walk
    /// hands over at most `per_query` pairs a pass and a full list only
    /// resumes walks, so the list need not hold 64 a query for every
    /// batch size: past the exact dispatch's limit it holds fewer.
    pub fn new(
        limits: &wgpu::Limits,
        binding: u64,
        tuning: &GpuTuning,
        capacity: Option<u32>,
    ) -> Self {
        let query_size = std::mem::size_of::<GpuQuery>() as u64;
        let max_groups = limits.max_compute_workgroups_per_dimension as u64;
        let batch = (tuning.batch as u64)
            .min(max_groups * WORKGROUP as u64)
            .min(binding / query_size)
            .max(1);
        let capacity = capacity
            .map_or(batch * CANDIDATES_PER_QUERY, |c| c.max(1) as u64)
            .min(binding / 8)
            .min(max_groups * WORKGROUP as u64);
        BatchSizes {
            batch: batch as usize,
            capacity,
        }
    }
}

/// One set of per-batch buffers and their bind groups.
pub(super) struct BatchSet {
    pub params: wgpu::Buffer,
    pub queries: wgpu::Buffer,
    pub results: wgpu::Buffer,
    /// The (query, triangle) pairs the walk hands to the exact tests.
    pub candidates: wgpu::Buffer,
    pub control: wgpu::Buffer,
    pub indirect: wgpu::Buffer,
    pub readback: wgpu::Buffer,
    pub bind_group: wgpu::BindGroup,
    /// The machine and move count of a batch of moves.
    pub motion: wgpu::Buffer,
    /// The batch's moves.
    pub moves: wgpu::Buffer,
    /// One verdict per move (`collide_reduce`).
    pub move_results: wgpu::Buffer,
    pub move_readback: wgpu::Buffer,
    /// The motion kernels' bindings (their own layout).
    pub motion_group: wgpu::BindGroup,
}

impl BatchSet {
    /// A set named `label` for batches of `sizes`, bound to `scene`.
    pub fn new(
        device: &wgpu::Device,
        layouts: &Layouts,
        scene: &SceneBuffers,
        sizes: BatchSizes,
        label: &str,
    ) -> Self {
        let buf = |what: &str, size: u64, usage: wgpu::BufferUsages| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(&format!("{label} {what}")),
                size,
                usage,
                mapped_at_creation: false,
            })
        };
        use std::mem::size_of;
        use wgpu::BufferUsages as U;
        // A uniform holding one value of `size` bytes; a buffer with one
        // entry of `each` bytes per query or move of a batch.
        let uniform = |what: &str, size: usize| buf(what, size as u64, U::UNIFORM | U::COPY_DST);
        let batch = sizes.batch as u64;
        let per_batch = |what: &str, each: usize, usage| buf(what, batch * each as u64, usage);
        let params = uniform("params", size_of::<GpuParams>());
        // (Copied only by `expanded`, for its test.)
        let queries = per_batch(
            "queries",
            size_of::<GpuQuery>(),
            U::STORAGE | U::COPY_DST | U::COPY_SRC,
        );
        let results = per_batch("results", 4, U::STORAGE | U::COPY_SRC | U::COPY_DST);
        // (Copied only by the kernel-by-kernel tests, `walks` and
        // `exact_pairs`.)
        let candidates = buf(
            "candidates",
            sizes.capacity * 8,
            U::STORAGE | U::COPY_SRC | U::COPY_DST,
        );
        let control = buf("control", 32, U::STORAGE | U::COPY_SRC | U::COPY_DST);
        // Not in the bind group: a buffer bound as storage cannot also
        // drive an indirect dispatch in the same pass.
        let indirect = buf("indirect", 12, U::INDIRECT | U::COPY_DST);
        let readback = buf("readback", batch * 4 + 4, U::MAP_READ | U::COPY_DST);
        let mut resources = vec![
            params.as_entire_binding(),
            scene.head_params.as_entire_binding(),
            queries.as_entire_binding(),
            results.as_entire_binding(),
        ];
        resources.extend(scene.storage.iter().map(|b| b.as_entire_binding()));
        resources.push(candidates.as_entire_binding());
        resources.push(control.as_entire_binding());
        let bind_group = bind_group_of(device, &layouts.collide, label, resources);
        let motion = uniform("motion", size_of::<GpuMotion>());
        let moves = per_batch("moves", size_of::<GpuMove>(), U::STORAGE | U::COPY_DST);
        let move_results = per_batch("move results", 4, U::STORAGE | U::COPY_SRC);
        let move_readback = per_batch("move readback", 4, U::MAP_READ | U::COPY_DST);
        let motion_group = bind_group_of(
            device,
            &layouts.motion,
            label,
            vec![
                motion.as_entire_binding(),
                moves.as_entire_binding(),
                queries.as_entire_binding(),
                results.as_entire_binding(),
                move_results.as_entire_binding(),
            ],
        );
        BatchSet {
            params,
            queries,
            results,
            candidates,
            control,
            indirect,
            readback,
            bind_group,
            motion,
            moves,
            move_results,
            move_readback,
            motion_group,
        }
    }
}

/// A bind group on `layout` binding `resources` in order from 0.
fn bind_group_of(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    label: &str,
    resources: Vec<wgpu::BindingResource>,
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry> = resources
        .into_iter()
        .enumerate()
        .map(|(i, resource)| wgpu::BindGroupEntry {
            binding: i as u32,
            resource,
        })
        .collect();
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout,
        entries: &entries,
    })
}

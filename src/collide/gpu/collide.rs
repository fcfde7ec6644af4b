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
//! it). That variant is compiled when a batch first needs it: the planner
//! keeps a margin in every question, so its plans never do (lavapipe
//! spent 0.15–0.19 s of a core compiling it while simple_curve's scene
//! loaded). Two sets of per-batch buffers alternate, so the next batch
//! computes while the previous one is read back. When a batch's
//! candidates do not all fit the list, the queries that lost some are
//! walked again (`resume`): each hands over the pairs after the ones it
//! had stored, so no pair is tested twice and no batch is redone
//! ([`GpuStats`] counts it).

use super::super::cpu::traverse::Walk;
use super::super::moves::{gpu_motion, gpu_move, SampledMove};
use super::super::order::coherent_order;
use super::super::{check_finite, Backend, CollideError, Query};
use super::context::GpuContext;
use super::shaders::{
    COLLIDE_EXACT, COLLIDE_EXPAND, COLLIDE_PREPARE, COLLIDE_REDUCE, COLLIDE_TRAVERSE,
    COLLIDE_TRAVERSE_PERSISTENT, COLLIDE_TRAVERSE_SUBGROUP,
};
use crate::kinematics::Machine;
use crate::scene::gpu_types::{RESULT_HIT, RESULT_INCOMPLETE};
use crate::scene::{GpuMotion, GpuMove, GpuParams, GpuPartNode, GpuQuery, GpuTriangle, Scene};
use bytemuck::Pod;
use rayon::prelude::*;
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
    /// Queries per dispatch (default: [`HARDWARE_BATCH`] on a hardware
    /// adapter, [`SOFTWARE_BATCH`] on a software one, within the device's
    /// limits).
    pub batch: Option<usize>,
    /// Slots of the candidate list per batch (default: 64 per query, within
    /// the device's limits). Tests lower it to make lists fill.
    pub capacity: Option<u32>,
    /// The most candidates one query hands over in one pass (default
    /// [`HARDWARE_PER_QUERY`] on a hardware adapter, [`PER_QUERY`] on a
    /// software one; `u32::MAX`: all of them at once).
    pub per_query: Option<u32>,
    /// Whether the walk uses subgroup operations, where the adapter has
    /// them (default: yes): persistent lanes that take the next query when
    /// their walk ends (`shaders/traverse_persistent.wgsl`). Tests turn it
    /// off to run the one-query-an-invocation kernel.
    pub subgroups: Option<bool>,
    /// With subgroups, whether the walk also reserves candidate slots one
    /// atomic per subgroup (default: on hardware adapters; lavapipe's
    /// atomics are a loop over the SIMD lanes either way, and there that
    /// kernel ran 2.7 % more instructions on simple_curve's bench mix).
    pub subgroup_appends: Option<bool>,
    /// Whether each call's queries are walked in coherent order
    /// ([`crate::collide::order`]; default: on software adapters only).
    /// On lavapipe a group of 8 lanes walks as long as its longest lane,
    /// and the order shortened the bench mix's walks by a sixth; on an
    /// H100 ordering cost the host more than it saved the device (20,000
    /// poses: 5.0–5.5 M poses/s ordered, 8.0–9.0 M as given).
    pub coherent: Option<bool>,
}

/// What [`GpuOptions`] come to on one adapter: each setting given, or the
/// adapter's default (before the device's limits bound the batch).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GpuTuning {
    /// Queries per batch.
    pub batch: usize,
    /// The most candidates a query hands over a pass.
    pub per_query: u32,
    /// Persistent lanes (`shaders/traverse_persistent.wgsl`).
    pub subgroups: bool,
    /// Candidate slots reserved one atomic per subgroup.
    pub subgroup_appends: bool,
    /// Each call's queries walked in coherent order.
    pub coherent: bool,
}

impl GpuOptions {
    /// These options on `adapter`: where one is not given, the default
    /// for a hardware or a software adapter (measured on an H100 and on
    /// lavapipe; BENCHMARKS.md).
    pub fn tuned(&self, adapter: &super::AdapterSummary) -> GpuTuning {
        let hardware = adapter.hardware;
        let subgroups = self.subgroups.unwrap_or(true) && adapter.subgroups;
        GpuTuning {
            batch: self.batch.unwrap_or(if hardware {
                HARDWARE_BATCH
            } else {
                SOFTWARE_BATCH
            }),
            per_query: self
                .per_query
                .unwrap_or(if hardware {
                    HARDWARE_PER_QUERY
                } else {
                    PER_QUERY
                })
                .max(1),
            subgroups,
            subgroup_appends: subgroups && self.subgroup_appends.unwrap_or(hardware),
            coherent: self.coherent.unwrap_or(!hardware),
        }
    }
}

impl std::fmt::Display for GpuTuning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let walk = match (self.subgroups, self.subgroup_appends) {
            (false, _) => "one query an invocation",
            (true, false) => "persistent lanes",
            (true, true) => "persistent lanes, subgroup appends",
        };
        let order = if self.coherent {
            "coherent order"
        } else {
            "queries as given"
        };
        write!(
            f,
            "batches of {}, {} pairs a query a pass, {walk}, {order}",
            self.batch, self.per_query
        )
    }
}

/// Queries per batch on a hardware adapter: an H100 walks 160,000 of
/// simple_curve's bench mix 1.3× as fast in batches of 262,144 as of
/// 65,536 (one batch fills more of its 270,000 resident invocations;
/// BENCHMARKS.md, "On a real GPU").
pub const HARDWARE_BATCH: usize = 262_144;

/// Queries per batch on a software adapter (lavapipe): its invocations run
/// a few at a time on the CPU's cores, so a larger batch only delays the
/// first readback.
pub const SOFTWARE_BATCH: usize = 65_536;

/// Candidates a query hands over per pass on a hardware adapter. There a
/// resumed pass costs a round trip more than the walk it saves, and the
/// extra exact tests run in parallel: on an H100, 160,000 of simple_curve's
/// bench mix waited 11 ms on the device (5 runs) with 64 against 25 ms
/// with 16 (4: 69 ms).
pub const HARDWARE_PER_QUERY: u32 = 64;

/// Candidates a query hands over per pass by default on a software
/// adapter: a colliding query's first few pairs (nearer nodes walked
/// first) mostly settle it, so the rest are never tested; a query they do
/// not settle walks again for the next few.
pub const PER_QUERY: u32 = 16;

/// What the backend has done since it was built: how often a batch's
/// candidate list filled and what that cost, and where the wall time of
/// its calls went (the host's own work, or waiting for the device).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct GpuStats {
    /// Batches submitted (each: one walk per query, one exact test per
    /// candidate).
    pub batches: u64,
    /// Queries evaluated.
    pub queries: u64,
    /// (query, triangle) pairs handed to the exact tests.
    pub candidates: u64,
    /// Passes whose candidate list filled.
    pub full_lists: u64,
    /// Resumed passes (walks of the incomplete, undecided queries only:
    /// their share of pairs handed over, or the list full).
    pub resumed_passes: u64,
    /// Query walks those passes made.
    pub resumed_queries: u64,
    /// Host time spent preparing work: ordering queries, packing and
    /// uploading them, encoding and submitting passes, scattering verdicts.
    pub host: std::time::Duration,
    /// Host time spent blocked on the device (its results not yet there):
    /// the device's work that the host's did not hide.
    pub waiting: std::time::Duration,
}

impl GpuStats {
    /// Count `more` in.
    fn add(&mut self, more: &GpuStats) {
        self.batches += more.batches;
        self.queries += more.queries;
        self.candidates += more.candidates;
        self.full_lists += more.full_lists;
        self.resumed_passes += more.resumed_passes;
        self.resumed_queries += more.resumed_queries;
        self.host += more.host;
        self.waiting += more.waiting;
    }
}

impl std::fmt::Display for GpuStats {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "gpu: {} queries in {} batches, {} exact tests; {} query walk(s) resumed in {} pass(es) (the candidate list full in {}), no batch redone; host {:.1} ms preparing, {:.1} ms waiting on the device",
            self.queries,
            self.batches,
            self.candidates,
            self.resumed_queries,
            self.resumed_passes,
            self.full_lists,
            self.host.as_secs_f64() * 1e3,
            self.waiting.as_secs_f64() * 1e3,
        )
    }
}

/// One set of per-batch buffers.
struct BatchSet {
    params: wgpu::Buffer,
    queries: wgpu::Buffer,
    results: wgpu::Buffer,
    /// The (query, triangle) pairs the walk hands to the exact tests.
    candidates: wgpu::Buffer,
    control: wgpu::Buffer,
    indirect: wgpu::Buffer,
    readback: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    /// The machine and move count of a batch of moves.
    motion: wgpu::Buffer,
    /// The batch's moves.
    moves: wgpu::Buffer,
    /// One verdict per move (`collide_reduce`).
    move_results: wgpu::Buffer,
    move_readback: wgpu::Buffer,
    /// The motion kernels' bindings (their own layout).
    motion_group: wgpu::BindGroup,
}

/// The `gpu` backend.
pub struct GpuBackend {
    ctx: GpuContext,
    traverse: wgpu::ComputePipeline,
    prepare: wgpu::ComputePipeline,
    /// `collide_exact` with the margin's distance tests.
    exact: wgpu::ComputePipeline,
    /// `collide_exact` without them, for batches at margin 0: compiled
    /// when the first such batch comes ([`Self::exact_touch`]).
    exact_touch: std::sync::OnceLock<wgpu::ComputePipeline>,
    /// What compiling `exact_touch` needs: the kernels' layout and the
    /// scene's binding counts.
    layout: wgpu::PipelineLayout,
    filled: [(&'static str, f64); 2],
    /// `collide_expand`: a batch of moves' samples posed on the device.
    expand: wgpu::ComputePipeline,
    /// `collide_reduce`: one verdict per move from its samples'.
    reduce: wgpu::ComputePipeline,
    sets: [BatchSet; 2],
    /// Held for the whole of an `evaluate`: the two buffer sets serve one
    /// caller at a time (the planner measures the input on another thread
    /// while it plans, and both share this backend).
    busy: std::sync::Mutex<()>,
    /// What it runs with, the batch within the device's limits.
    tuning: GpuTuning,
    capacity: u32,
    /// Counted by [`Self::settle`] and [`Self::timed`], under `busy`.
    stats: std::sync::Mutex<GpuStats>,
    /// Nanoseconds [`Self::map_read`] has spent blocked on the device.
    waited_ns: std::sync::atomic::AtomicU64,
    nodes_per_chunk: u32,
    tris_per_chunk: u32,
    /// Scene bytes resident on the device.
    pub scene_bytes: u64,
    /// Storage bindings in use for part nodes and part triangles.
    pub bindings_used: (usize, usize),
}

/// Whether a pass over `queries` needs `collide_exact` with the margin's
/// distance tests (a query with a margin or a slope).
fn margin_tests(queries: &[Query]) -> bool {
    queries.iter().any(|q| q.margin > 0.0 || q.slope > 0.0)
}

/// The compute pipeline of `src`'s `main` on `layout`, its overrides set
/// to `constants`.
fn compute_pipeline(
    device: &wgpu::Device,
    layout: &wgpu::PipelineLayout,
    label: &str,
    src: &str,
    constants: &[(&str, f64)],
) -> wgpu::ComputePipeline {
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(src.into()),
    });
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(label),
        layout: Some(layout),
        module: &module,
        entry_point: Some("main"),
        compilation_options: wgpu::PipelineCompilationOptions {
            constants,
            ..Default::default()
        },
        cache: None,
    })
}

/// A `collide_*` kernel's pipeline for a scene filling the bindings
/// `filled` says (`NODE_BINDINGS`, `TRI_BINDINGS`), with the exact tests'
/// `MARGIN_TESTS` override set where `margin_tests` gives it.
fn scene_pipeline(
    device: &wgpu::Device,
    layout: &wgpu::PipelineLayout,
    filled: [(&str, f64); 2],
    label: &str,
    src: &str,
    margin_tests: Option<bool>,
) -> wgpu::ComputePipeline {
    let mut constants = filled.to_vec();
    if let Some(on) = margin_tests {
        constants.push(("MARGIN_TESTS", on as u8 as f64));
    }
    compute_pipeline(device, layout, label, src, &constants)
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
        let motion_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("collide motion"),
            entries: &motion_layout_entries(),
        });
        let motion_pipeline_layout =
            device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("collide motion"),
                bind_group_layouts: &[Some(&motion_layout)],
                immediate_size: 0,
            });
        let motion_pipeline = |label: &str, src: &str| {
            compute_pipeline(device, &motion_pipeline_layout, label, src, &[])
        };
        // The bindings this scene fills: reads past them are compiled out
        // (`NODE_BINDINGS`, `TRI_BINDINGS` in collide_common.wgsl).
        let bindings_used = (
            nodes.len().div_ceil(nodes_per_chunk).max(1),
            tris.len().div_ceil(tris_per_chunk).max(1),
        );
        let filled = [
            ("NODE_BINDINGS", bindings_used.0 as f64),
            ("TRI_BINDINGS", bindings_used.1 as f64),
        ];
        let tuning = opts.tuned(&ctx.summary);
        let traverse_src = match (tuning.subgroups, tuning.subgroup_appends) {
            (false, _) => COLLIDE_TRAVERSE,
            (true, false) => COLLIDE_TRAVERSE_PERSISTENT,
            (true, true) => COLLIDE_TRAVERSE_SUBGROUP,
        };
        let pipeline = |label: &str, src: &str, margin_tests: Option<bool>| {
            scene_pipeline(device, &pipeline_layout, filled, label, src, margin_tests)
        };
        // Each pipeline compiles its shader (on lavapipe, LLVM: 0.53 s for
        // the six in a row on simple_curve's load); they are independent,
        // so they compile side by side. (`exact_touch`: at its first use.)
        let ((traverse, prepare), (exact, (expand, reduce))) = std::thread::scope(|t| {
            let traverse = t.spawn(|| pipeline("collide_traverse.wgsl", traverse_src, None));
            let exact = t.spawn(|| pipeline("collide_exact.wgsl", COLLIDE_EXACT, Some(true)));
            let prepare = pipeline("collide_prepare.wgsl", COLLIDE_PREPARE, None);
            let expand = motion_pipeline("collide_expand.wgsl", COLLIDE_EXPAND);
            let reduce = motion_pipeline("collide_reduce.wgsl", COLLIDE_REDUCE);
            let join = |h: std::thread::ScopedJoinHandle<'_, wgpu::ComputePipeline>| {
                h.join().expect("a pipeline's compilation panicked")
            };
            ((join(traverse), prepare), (join(exact), (expand, reduce)))
        });

        let query_size = std::mem::size_of::<GpuQuery>() as u64;
        let max_groups = limits.max_compute_workgroups_per_dimension as u64;
        // A walk hands over at most `per_query` pairs a pass and a full
        // list only resumes walks, so the list need not hold 64 a query
        // for every batch size: past the exact dispatch's limit it holds
        // fewer.
        let batch = (tuning.batch as u64)
            .min(max_groups * WORKGROUP as u64)
            .min(binding / query_size)
            .max(1);
        let capacity = opts
            .capacity
            .map_or(batch * CANDIDATES_PER_QUERY, |c| c.max(1) as u64)
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
                std::mem::size_of::<GpuParams>() as u64,
                U::UNIFORM | U::COPY_DST,
            );
            // (Copied only by `expanded`, for its test.)
            let queries = buf(
                "queries",
                batch as u64 * query_size,
                U::STORAGE | U::COPY_DST | U::COPY_SRC,
            );
            let results = buf(
                "results",
                batch as u64 * 4,
                U::STORAGE | U::COPY_SRC | U::COPY_DST,
            );
            // (Copied only by the kernel-by-kernel tests, `walks` and
            // `exact_pairs`.)
            let candidates = buf(
                "candidates",
                capacity * 8,
                U::STORAGE | U::COPY_SRC | U::COPY_DST,
            );
            let control = buf("control", 32, U::STORAGE | U::COPY_SRC | U::COPY_DST);
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
            let motion = buf(
                "motion",
                std::mem::size_of::<GpuMotion>() as u64,
                U::UNIFORM | U::COPY_DST,
            );
            let moves = buf(
                "moves",
                batch as u64 * std::mem::size_of::<GpuMove>() as u64,
                U::STORAGE | U::COPY_DST,
            );
            let move_results = buf("move results", batch as u64 * 4, U::STORAGE | U::COPY_SRC);
            let move_readback = buf("move readback", batch as u64 * 4, U::MAP_READ | U::COPY_DST);
            let motion_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(label),
                layout: &motion_layout,
                entries: &[
                    motion.as_entire_binding(),
                    moves.as_entire_binding(),
                    queries.as_entire_binding(),
                    results.as_entire_binding(),
                    move_results.as_entire_binding(),
                ]
                .into_iter()
                .enumerate()
                .map(|(i, resource)| wgpu::BindGroupEntry {
                    binding: i as u32,
                    resource,
                })
                .collect::<Vec<_>>(),
            });
            BatchSet {
                motion,
                moves,
                move_results,
                move_readback,
                motion_group,
                params,
                queries,
                results,
                candidates,
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
            exact_touch: std::sync::OnceLock::new(),
            layout: pipeline_layout,
            filled,
            expand,
            reduce,
            sets,
            busy: std::sync::Mutex::new(()),
            tuning: GpuTuning { batch, ..tuning },
            capacity: capacity as u32,
            stats: Default::default(),
            waited_ns: Default::default(),
            nodes_per_chunk: nodes_per_chunk.min(u32::MAX as usize) as u32,
            tris_per_chunk: tris_per_chunk.min(u32::MAX as usize) as u32,
            scene_bytes,
            bindings_used,
            ctx,
        })
    }

    /// `collide_exact` without the margin's tests, compiled on first use.
    fn exact_touch(&self) -> &wgpu::ComputePipeline {
        self.exact_touch.get_or_init(|| {
            scene_pipeline(
                &self.ctx.device,
                &self.layout,
                self.filled,
                "collide_exact.wgsl (margin 0)",
                COLLIDE_EXACT,
                Some(false),
            )
        })
    }

    /// The adapter in use.
    pub fn adapter(&self) -> &super::AdapterSummary {
        &self.ctx.summary
    }

    /// Run `work` (one caller's call) and count its wall time in
    /// [`GpuStats::host`] and [`GpuStats::waiting`].
    fn timed<T>(&self, work: impl FnOnce() -> T) -> T {
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
    fn send(&self, enc: wgpu::CommandEncoder) -> wgpu::SubmissionIndex {
        let t0 = std::time::Instant::now();
        let index = self.ctx.queue.submit([enc.finish()]);
        self.waited_since(t0);
        index
    }

    /// Count the time since `t0` as spent blocked on the device.
    fn waited_since(&self, t0: std::time::Instant) {
        self.waited_ns.fetch_add(
            t0.elapsed().as_nanos() as u64,
            std::sync::atomic::Ordering::Relaxed,
        );
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

    fn params(&self, n: usize, resume: bool) -> GpuParams {
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
    fn upload(&self, set: &BatchSet, queries: &[Query], params: GpuParams) {
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
    fn encode_passes(
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
            pass.set_pipeline(&self.traverse);
            pass.dispatch_workgroups((n as u32).div_ceil(WORKGROUP), 1, 1);
            pass.set_pipeline(&self.prepare);
            pass.dispatch_workgroups(1, 1, 1);
        }
        self.encode_exact(enc, set, margins);
        self.encode_readback(enc, set, n);
    }

    /// `collide_exact` over the candidates `collide_prepare` counted, with
    /// the margin's tests when `margins`.
    fn encode_exact(&self, enc: &mut wgpu::CommandEncoder, set: &BatchSet, margins: bool) {
        enc.copy_buffer_to_buffer(&set.control, 4, &set.indirect, 0, 12);
        let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("collide exact"),
            timestamp_writes: None,
        });
        pass.set_bind_group(0, &set.bind_group, &[]);
        pass.set_pipeline(if margins {
            &self.exact
        } else {
            self.exact_touch()
        });
        pass.dispatch_workgroups_indirect(&set.indirect, 0);
    }

    /// The copies of `n` result words and the candidate counter to the
    /// readback buffer ([`Self::read`]).
    fn encode_readback(&self, enc: &mut wgpu::CommandEncoder, set: &BatchSet, n: usize) {
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
    fn read(
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
    fn settle(
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
    fn run(&self, queries: &[Query]) -> Result<Vec<bool>, CollideError> {
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
        let mut pending: Option<(usize, &[Query], wgpu::SubmissionIndex)> = None;
        for (k, chunk) in queries.chunks(self.tuning.batch).enumerate() {
            let s = k % 2;
            let index = self.submit(s, chunk);
            if let Some((ps, pb, pi)) = pending.take() {
                self.finish(ps, pb, pi, &mut out)?;
            }
            pending = Some((s, chunk, index));
        }
        if let Some((ps, pb, pi)) = pending {
            self.finish(ps, pb, pi, &mut out)?;
        }
        Ok(out)
    }
}

/// Moves: their samples posed (`collide_expand`) and their verdicts
/// reduced (`collide_reduce`) on the device; one move record goes up and
/// one word per move comes back.
impl GpuBackend {
    /// [`Backend::sampled_moves`] on the device, batches of at most
    /// `batch` samples, two in flight.
    fn moves_on_device(
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
        // Batches of consecutive moves, each with its samples' first slot.
        let mut batches: Vec<(Vec<usize>, Vec<GpuMove>, usize)> = Vec::new();
        let mut current: (Vec<usize>, Vec<GpuMove>, usize) = Default::default();
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
            if current.2 + count > self.tuning.batch {
                batches.push(std::mem::take(&mut current));
            }
            current.1.push(gpu_move(mv, current.2 as u32));
            current.0.push(i);
            current.2 += count;
        }
        if current.2 > 0 {
            batches.push(current);
        }
        let mut out = vec![false; moves.len()];
        let mut pending: Option<(usize, usize, wgpu::SubmissionIndex)> = None;
        for (k, (_, gm, total)) in batches.iter().enumerate() {
            let s = k % 2;
            let index = self.submit_moves(s, machine, gm, *total);
            if let Some((ps, pk, pi)) = pending.take() {
                self.finish_moves(ps, &batches[pk], pi, &mut out)?;
            }
            pending = Some((s, k, index));
        }
        if let Some((ps, pk, pi)) = pending {
            self.finish_moves(ps, &batches[pk], pi, &mut out)?;
        }
        Ok(out)
    }

    /// Encode and submit a batch of moves on set `s`: their samples posed
    /// into the query slots, the usual passes over them, the reduction.
    fn submit_moves(
        &self,
        s: usize,
        machine: &Machine,
        gm: &[GpuMove],
        total: usize,
    ) -> wgpu::SubmissionIndex {
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
            bytemuck::bytes_of(&gpu_motion(machine, gm.len())),
        );
        q.write_buffer(&set.moves, 0, bytemuck::cast_slice(gm));
        let mut enc = self.ctx.device.create_command_encoder(&Default::default());
        enc.clear_buffer(&set.results, 0, Some(total as u64 * 4));
        self.encode_motion(&mut enc, set, &self.expand, gm.len());
        let margins = gm.iter().any(|m| m.margin > 0.0);
        self.encode_passes(&mut enc, set, total, margins);
        self.encode_reduce(&mut enc, set, gm.len());
        self.send(enc)
    }

    /// One motion kernel over `moves` moves.
    fn encode_motion(
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
        self.encode_motion(enc, set, &self.reduce, moves);
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
        (owners, gm, total): &(Vec<usize>, Vec<GpuMove>, usize),
        index: wgpu::SubmissionIndex,
        out: &mut [bool],
    ) -> Result<(), CollideError> {
        let set = &self.sets[s];
        let margins = gm.iter().any(|m| m.margin > 0.0);
        let (_, resumed) = self.settle(s, *total, margins, index.clone())?;
        let index = if resumed {
            // The reduction in the first submission saw the first pass's
            // verdicts only.
            let mut enc = self.ctx.device.create_command_encoder(&Default::default());
            self.encode_reduce(&mut enc, set, gm.len());
            self.send(enc)
        } else {
            index
        };
        let words = self.map_words(&set.move_readback, gm.len(), Some(index))?;
        for (&i, w) in owners.iter().zip(words) {
            out[i] = w & RESULT_HIT != 0;
        }
        Ok(())
    }
}

/// Each kernel alone, for the differential tests against its CPU mirror
/// (`collide::cpu::traverse`, `collide::cpu::exact`), pair by pair.
impl GpuBackend {
    /// `collide_traverse` alone over at most one batch of `queries` (every
    /// pair of a walk handed over at once): per query, whether the walk
    /// found it colliding and its undecided triangles in walk order (one invocation appends its pairs in order,
    /// so the shared list keeps each query's order). Fails when the pairs
    /// do not fit the candidate list: build the backend with a larger
    /// [`GpuOptions::capacity`].
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
            pass.set_pipeline(&self.traverse);
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
            pass.set_pipeline(&self.prepare);
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
        let mut gm = Vec::new();
        let mut total = 0usize;
        for mv in moves {
            gm.push(gpu_move(mv, total as u32));
            total += mv.intervals.saturating_sub(1) as usize;
        }
        self.fits(total)?;
        let _one_caller = self.busy.lock().unwrap_or_else(|e| e.into_inner());
        let set = &self.sets[0];
        let q = &self.ctx.queue;
        q.write_buffer(
            &set.motion,
            0,
            bytemuck::bytes_of(&gpu_motion(machine, gm.len())),
        );
        if !gm.is_empty() {
            q.write_buffer(&set.moves, 0, bytemuck::cast_slice(&gm));
        }
        let size = std::mem::size_of::<GpuQuery>() as u64;
        let copy = self.scratch("expanded queries", total as u64 * size);
        let mut enc = self.ctx.device.create_command_encoder(&Default::default());
        self.encode_motion(&mut enc, set, &self.expand, gm.len());
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

    /// A buffer to copy device data into and map.
    fn scratch(&self, label: &str, size: u64) -> wgpu::Buffer {
        self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: size.max(4),
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        })
    }

    /// The first `n` words of a mappable buffer whose copy was submitted
    /// (as `index`, or with everything submitted so far).
    fn map_words(
        &self,
        buf: &wgpu::Buffer,
        n: usize,
        index: Option<wgpu::SubmissionIndex>,
    ) -> Result<Vec<u32>, CollideError> {
        self.map_read(buf, index, |words| words[..n].to_vec())
    }

    /// Wait for submission `index` (or everything submitted so far), map
    /// `buf` and let `f` read its words.
    fn map_read<T>(
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

    /// Posed and reduced on the device ([`GpuBackend`]'s motion kernels).
    fn sampled_moves(
        &self,
        machine: &Machine,
        moves: &[SampledMove],
    ) -> Result<Vec<bool>, CollideError> {
        self.moves_on_device(machine, moves)
    }
}

#[cfg(test)]
mod tests {
    use super::super::AdapterSummary;
    use super::*;

    fn adapter(hardware: bool, subgroups: bool) -> AdapterSummary {
        AdapterSummary {
            name: "test adapter".into(),
            backend: "Vulkan".into(),
            device_type: "test".into(),
            hardware,
            driver: "test".into(),
            limits: wgpu::Limits::default(),
            subgroups,
        }
    }

    #[test]
    fn defaults_follow_the_adapter_and_given_options_win() {
        let defaults = GpuOptions::default();
        assert_eq!(
            defaults.tuned(&adapter(true, true)),
            GpuTuning {
                batch: HARDWARE_BATCH,
                per_query: HARDWARE_PER_QUERY,
                subgroups: true,
                subgroup_appends: true,
                coherent: false,
            }
        );
        assert_eq!(
            defaults.tuned(&adapter(false, true)),
            GpuTuning {
                batch: SOFTWARE_BATCH,
                per_query: PER_QUERY,
                subgroups: true,
                subgroup_appends: false,
                coherent: true,
            }
        );
        // Without subgroups neither persistent lanes nor subgroup appends,
        // even when asked for.
        let asked = GpuOptions {
            subgroups: Some(true),
            subgroup_appends: Some(true),
            ..GpuOptions::default()
        };
        let t = asked.tuned(&adapter(true, false));
        assert!(!t.subgroups && !t.subgroup_appends);
        // Given settings win over the adapter's; a share of 0 is 1.
        let given = GpuOptions {
            batch: Some(7),
            per_query: Some(0),
            subgroups: Some(false),
            subgroup_appends: Some(true),
            coherent: Some(true),
            ..GpuOptions::default()
        };
        assert_eq!(
            given.tuned(&adapter(true, true)),
            GpuTuning {
                batch: 7,
                per_query: 1,
                subgroups: false,
                subgroup_appends: false,
                coherent: true,
            }
        );
        assert_eq!(
            defaults.tuned(&adapter(true, true)).to_string(),
            "batches of 262144, 64 pairs a query a pass, persistent lanes, subgroup appends, queries as given"
        );
    }
}

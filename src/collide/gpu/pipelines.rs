//! The gpu backend's compute pipelines, one per kernel, compiled for the
//! scene's bindings and the adapter's walk. `collide_exact` is built
//! twice: with the margin's tests and without them (the `MARGIN_TESTS`
//! override), the latter for batches whose queries all have margin 0, so
//! those cost no more than the plain touch test on lavapipe too (it runs a
//! branch's body even when no invocation takes it). That variant is
//! compiled when a batch first needs it: the planner keeps a margin in
//! every question, so its plans never do.

use super::resources::Layouts;
use super::shaders::{
    COLLIDE_EXACT, COLLIDE_EXPAND, COLLIDE_PREPARE, COLLIDE_REDUCE, COLLIDE_TRAVERSE,
    COLLIDE_TRAVERSE_PERSISTENT, COLLIDE_TRAVERSE_SUBGROUP,
};
use super::GpuTuning;
use std::sync::OnceLock;

/// Every kernel's pipeline.
pub(super) struct Pipelines {
    /// `collide_traverse` with the tuning's entry point and appends.
    pub traverse: wgpu::ComputePipeline,
    /// `collide_prepare`: the exact pass's dispatch size.
    pub prepare: wgpu::ComputePipeline,
    /// `collide_exact` with the margin's distance tests.
    exact: wgpu::ComputePipeline,
    /// `collide_exact` without them, for batches at margin 0: compiled
    /// when the first such batch comes ([`Self::exact_for`]).
    exact_touch: OnceLock<wgpu::ComputePipeline>,
    /// `collide_expand`: a batch of moves' samples posed on the device.
    pub expand: wgpu::ComputePipeline,
    /// `collide_reduce`: one verdict per move from its samples'.
    pub reduce: wgpu::ComputePipeline,
    /// What compiling `exact_touch` needs: the kernels' layout and the
    /// scene's binding counts.
    layout: wgpu::PipelineLayout,
    binding_overrides: [(&'static str, f64); 2],
}

impl Pipelines {
    /// Compile the pipelines for a scene filling the bindings
    /// `binding_overrides` names, walking as `tuning` says. Each compiles
    /// its shader (on lavapipe, with LLVM: a noticeable part of a small
    /// plan's load); they are independent, so they compile side by side.
    pub fn build(
        device: &wgpu::Device,
        layouts: &Layouts,
        binding_overrides: [(&'static str, f64); 2],
        tuning: &GpuTuning,
    ) -> Self {
        let traverse_src = match (tuning.subgroups, tuning.subgroup_appends) {
            (false, _) => COLLIDE_TRAVERSE,
            (true, false) => COLLIDE_TRAVERSE_PERSISTENT,
            (true, true) => COLLIDE_TRAVERSE_SUBGROUP,
        };
        let layout = &layouts.collide_pipeline;
        let pipeline = |label: &str, src: &str, margin_tests: Option<bool>| {
            scene_pipeline(device, layout, binding_overrides, label, src, margin_tests)
        };
        let motion_pipeline = |label: &str, src: &str| {
            compute_pipeline(device, &layouts.motion_pipeline, label, src, &[])
        };
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
        Pipelines {
            traverse,
            prepare,
            exact,
            exact_touch: OnceLock::new(),
            expand,
            reduce,
            layout: layout.clone(),
            binding_overrides,
        }
    }

    /// `collide_exact` with the margin's tests when `margins`, else the
    /// variant without them, compiled on first use.
    pub fn exact_for(&self, device: &wgpu::Device, margins: bool) -> &wgpu::ComputePipeline {
        if margins {
            return &self.exact;
        }
        self.exact_touch.get_or_init(|| {
            scene_pipeline(
                device,
                &self.layout,
                self.binding_overrides,
                "collide_exact.wgsl (margin 0)",
                COLLIDE_EXACT,
                Some(false),
            )
        })
    }
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
/// `binding_overrides` names (`NODE_BINDINGS`, `TRI_BINDINGS`), with the
/// exact tests' `MARGIN_TESTS` override set where `margin_tests` gives it.
fn scene_pipeline(
    device: &wgpu::Device,
    layout: &wgpu::PipelineLayout,
    binding_overrides: [(&str, f64); 2],
    label: &str,
    src: &str,
    margin_tests: Option<bool>,
) -> wgpu::ComputePipeline {
    let mut constants = binding_overrides.to_vec();
    if let Some(on) = margin_tests {
        constants.push(("MARGIN_TESTS", on as u8 as f64));
    }
    compute_pipeline(device, layout, label, src, &constants)
}

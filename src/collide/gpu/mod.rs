//! The `gpu` backend: wgpu compute shaders over the stamped BVH, thousands of
//! poses per dispatch. `context.rs` picks the adapter and opens the device,
//! `collide.rs` is the host side of the `collide_*` kernels
//! (`shaders/`), `shaders.rs` holds their WGSL sources.

pub mod collide;
pub mod context;
pub mod shaders;

pub use collide::{
    GpuBackend, GpuOptions, GpuStats, GpuTuning, HARDWARE_BATCH, HARDWARE_PER_QUERY, PER_QUERY,
    SOFTWARE_BATCH,
};
pub use context::{list_adapters, AdapterSummary, GpuContext};

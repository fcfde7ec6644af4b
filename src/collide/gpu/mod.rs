//! The `gpu` backend: wgpu compute shaders over the stamped BVH, thousands
//! of poses per dispatch. One file per concern:
//!
//! | file | holds |
//! | --- | --- |
//! | [`context`] | the adapter's choice and the device |
//! | [`tuning`] | the options and what they come to on an adapter |
//! | [`wire`] | the records the host and the kernels exchange (`#[repr(C)]`, twins in `shaders/`) |
//! | [`shaders`] | the kernels' WGSL sources |
//! | `resources` | the scene on the device and the per-batch buffers |
//! | `pipelines` | one compute pipeline per kernel |
//! | `backend` | [`GpuBackend`]: built from those, one caller at a time, readback |
//! | `queries` | the query path: batches walked, pairs tested, walks resumed |
//! | [`moves`] | the move path: samples posed and verdicts reduced on the device |
//! | `kernels` | each kernel alone, for the tests against its CPU mirror |
//! | `stats` | [`GpuStats`]: what the backend has done |

mod backend;
pub mod context;
mod kernels;
pub mod moves;
mod pipelines;
mod queries;
mod resources;
pub mod shaders;
mod stats;
pub mod tuning;
pub mod wire;

pub use backend::{GpuBackend, WIDE_ABOVE};
pub use context::{list_adapters, AdapterSummary, GpuContext};
pub use resources::{NODE_CHUNKS, TRI_CHUNKS};
pub use stats::GpuStats;
pub use tuning::{
    GpuOptions, GpuTuning, HARDWARE_BATCH, HARDWARE_PER_QUERY, PER_QUERY, SOFTWARE_BATCH,
};

//! `maamplan info`: the GPU adapters wgpu can see, their kind, the limits
//! that bound batch and scene sizes, and the gpu backend's settings on each.

use anyhow::Result;
use maamplan::collide::gpu::{list_adapters, GpuOptions};

/// Run `info`.
pub fn run() -> Result<()> {
    println!(
        "maamplan {} — {} CPU threads",
        env!("CARGO_PKG_VERSION"),
        rayon::current_num_threads()
    );
    let adapters = list_adapters();
    if adapters.is_empty() {
        println!("no GPU adapter found (WGPU_BACKEND / WGPU_ADAPTER_NAME filter what is listed); install a Vulkan driver, e.g. mesa-vulkan-drivers for lavapipe");
        return Ok(());
    }
    for (i, a) in adapters.iter().enumerate() {
        let l = &a.limits;
        println!(
            "[{i}] {} — {} {} ({}), driver {}",
            a.name,
            a.backend,
            a.device_type,
            if a.hardware { "hardware" } else { "software" },
            a.driver
        );
        println!(
            "    max storage binding {} MiB, max buffer {} MiB, {} storage buffers per stage, {} workgroups per dimension, {} invocations per workgroup, subgroups {}",
            l.max_storage_buffer_binding_size >> 20,
            l.max_buffer_size >> 20,
            l.max_storage_buffers_per_shader_stage,
            l.max_compute_workgroups_per_dimension,
            l.max_compute_invocations_per_workgroup,
            if a.subgroups { "yes" } else { "no" }
        );
        println!("    gpu backend here: {}", GpuOptions::default().tuned(a));
    }
    println!("--backend auto uses the first hardware adapter above, else the cpu backend");
    Ok(())
}

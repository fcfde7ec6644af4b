//! Adapter choice and device creation. `WGPU_BACKEND` (e.g. `vulkan`) and
//! `WGPU_ADAPTER_NAME` (a case-insensitive substring of the adapter's name)
//! are honoured; otherwise the most capable adapter wins (discrete, then
//! integrated, virtual, other, and software last).

use super::super::CollideError;

/// What `maamplan info` shows about an adapter.
#[derive(Clone, Debug)]
pub struct AdapterSummary {
    /// Adapter name, e.g. "NVIDIA H200" or "llvmpipe (LLVM 15.0.6, 256 bits)".
    pub name: String,
    /// Graphics API backend, e.g. "Vulkan".
    pub backend: String,
    /// Device type as wgpu reports it.
    pub device_type: String,
    /// True for a real GPU, false for a software rasteriser such as lavapipe.
    pub hardware: bool,
    /// Driver name and version.
    pub driver: String,
    /// The limits that bound our batches and scene size.
    pub limits: wgpu::Limits,
    /// Whether it has subgroup operations (the walk then reserves its
    /// candidates' slots one atomic per subgroup).
    pub subgroups: bool,
}

/// An opened device.
pub struct GpuContext {
    /// The device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
    /// The adapter's description.
    pub summary: AdapterSummary,
}

fn instance() -> wgpu::Instance {
    wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env())
}

fn is_hardware(t: wgpu::DeviceType) -> bool {
    matches!(
        t,
        wgpu::DeviceType::DiscreteGpu
            | wgpu::DeviceType::IntegratedGpu
            | wgpu::DeviceType::VirtualGpu
    )
}

fn rank(t: wgpu::DeviceType) -> u8 {
    match t {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Other => 3,
        wgpu::DeviceType::Cpu => 4,
    }
}

fn summary(a: &wgpu::Adapter) -> AdapterSummary {
    let i = a.get_info();
    AdapterSummary {
        name: i.name.clone(),
        backend: format!("{:?}", i.backend),
        device_type: format!("{:?}", i.device_type),
        hardware: is_hardware(i.device_type),
        driver: format!("{} {}", i.driver, i.driver_info).trim().to_string(),
        limits: a.limits(),
        subgroups: a.features().contains(wgpu::Features::SUBGROUP),
    }
}

/// Compute-capable adapters (filtered by `WGPU_BACKEND` and
/// `WGPU_ADAPTER_NAME`), best first. The kernels also read halves
/// (`unpack2x16float`, the head's support map): every Vulkan, Metal and
/// DX12 adapter can; wgpu's GL ES ones may not.
fn adapters() -> Vec<wgpu::Adapter> {
    let inst = instance();
    let backends = wgpu::Backends::from_env().unwrap_or(wgpu::Backends::all());
    let mut list = pollster::block_on(inst.enumerate_adapters(backends));
    if let Ok(want) = std::env::var("WGPU_ADAPTER_NAME") {
        let want = want.to_lowercase();
        list.retain(|a| a.get_info().name.to_lowercase().contains(&want));
    }
    list.retain(|a| {
        a.get_downlevel_capabilities().flags.contains(
            wgpu::DownlevelFlags::COMPUTE_SHADERS | wgpu::DownlevelFlags::SHADER_F16_IN_F32,
        )
    });
    list.sort_by_key(|a| rank(a.get_info().device_type));
    list
}

/// Every usable adapter, best first.
pub fn list_adapters() -> Vec<AdapterSummary> {
    adapters().iter().map(summary).collect()
}

/// Storage buffers the collision kernel binds.
pub const STORAGE_BUFFERS: u32 = 14;

impl GpuContext {
    /// Open the best adapter; with `hardware_only`, `Ok(None)` when there is
    /// no real GPU (for `--backend auto`).
    pub fn open(hardware_only: bool) -> Result<Option<GpuContext>, CollideError> {
        let list = adapters();
        let Some(adapter) = list
            .into_iter()
            .find(|a| !hardware_only || is_hardware(a.get_info().device_type))
        else {
            return Ok(None);
        };
        let s = summary(&adapter);
        let have = &s.limits;
        if have.max_storage_buffers_per_shader_stage < STORAGE_BUFFERS {
            return Err(CollideError::Unavailable(format!(
                "GPU adapter {} allows {} storage buffers per shader stage, the kernel needs {STORAGE_BUFFERS}: use --backend cpu",
                s.name, have.max_storage_buffers_per_shader_stage
            )));
        }
        let required_limits = wgpu::Limits {
            max_storage_buffers_per_shader_stage: STORAGE_BUFFERS,
            max_storage_buffer_binding_size: have.max_storage_buffer_binding_size,
            max_buffer_size: have.max_buffer_size,
            max_compute_workgroups_per_dimension: have.max_compute_workgroups_per_dimension,
            ..wgpu::Limits::downlevel_defaults()
        };
        let required_features = if s.subgroups {
            wgpu::Features::SUBGROUP
        } else {
            wgpu::Features::empty()
        };
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("maamplan"),
            required_features,
            required_limits,
            ..Default::default()
        }))
        .map_err(|e| CollideError::Unavailable(format!("cannot open GPU {}: {e}", s.name)))?;
        Ok(Some(GpuContext {
            device,
            queue,
            summary: s,
        }))
    }
}

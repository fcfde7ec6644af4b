//! Offscreen pictures with the project's GPU stack (wgpu: a hardware GPU,
//! or Mesa's lavapipe): triangles lit from the camera, lines, and
//! highlighted triangles drawn over everything, rendered into a texture,
//! read back and written as PNG (`shaders/render.wgsl`).

use crate::collide::gpu::context::GpuContext;
use glam::{Mat4, Vec3};

/// The shader.
const RENDER_WGSL: &str = include_str!("../../shaders/render.wgsl");

/// Samples per pixel.
const SAMPLES: u32 = 4;

/// The picture's colour format.
const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;

/// What to draw, in the part frame. Colours are RGBA bytes; an alpha of 0
/// draws unlit at full colour, else lit from the camera.
#[derive(Clone, Debug, Default)]
pub struct DrawList {
    /// Triangles (three vertices each) with their colours.
    pub triangles: Vec<([f32; 3], [u8; 4])>,
    /// Line segments (two vertices each).
    pub lines: Vec<([f32; 3], [u8; 4])>,
    /// Triangles drawn last, over everything (highlights).
    pub overlay: Vec<([f32; 3], [u8; 4])>,
}

impl DrawList {
    /// Add a triangle of colour `c`.
    pub fn triangle(&mut self, t: [[f32; 3]; 3], c: [u8; 4]) {
        self.triangles.extend(t.map(|p| (p, c)));
    }

    /// Add a triangle drawn over everything.
    pub fn overlay_triangle(&mut self, t: [[f32; 3]; 3], c: [u8; 4]) {
        self.overlay.extend(t.map(|p| (p, c)));
    }

    /// Add a line segment.
    pub fn line(&mut self, a: [f32; 3], b: [f32; 3], c: [u8; 4]) {
        self.lines.extend([(a, c), (b, c)]);
    }
}

/// A perspective camera.
#[derive(Clone, Copy, Debug)]
pub struct Camera {
    /// Where it stands (part frame, mm).
    pub eye: Vec3,
    /// What it looks at.
    pub target: Vec3,
    /// Which way is up in the picture.
    pub up: Vec3,
    /// Vertical field of view (radians).
    pub fov_y: f32,
}

impl Camera {
    /// The camera looking at a sphere of `radius` around `target` from
    /// direction `from` (towards the camera), `up` up, filling the picture.
    pub fn framing(target: Vec3, radius: f32, from: Vec3, up: Vec3) -> Camera {
        let fov_y = 40f32.to_radians();
        let distance = radius / (fov_y / 2.0).sin();
        Camera {
            eye: target + from.normalize() * distance,
            target,
            up,
            fov_y,
        }
    }

    fn view_proj(&self, aspect: f32) -> Mat4 {
        let d = (self.target - self.eye).length();
        // WebGPU's clip space: depth in [0, 1], y up (DirectX's convention).
        let proj = glam::camera::rh::proj::directx::perspective(
            self.fov_y,
            aspect,
            (d * 0.01).max(0.01),
            d * 20.0,
        );
        proj * glam::camera::rh::view::look_at_mat4(self.eye, self.target, self.up)
    }
}

/// An opened device with the pipelines compiled.
pub struct Renderer {
    ctx: GpuContext,
    layout: wgpu::BindGroupLayout,
    lit: wgpu::RenderPipeline,
    lines: wgpu::RenderPipeline,
    overlay: wgpu::RenderPipeline,
}

/// A vertex as the shader reads it.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Vertex {
    position: [f32; 3],
    color: [u8; 4],
}

/// The shader's `View`.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct ViewUniform {
    view_proj: [[f32; 4]; 4],
    eye: [f32; 4],
}

impl Renderer {
    /// Open the best adapter (a hardware GPU if there is one) and compile
    /// the pipelines; `None` with the reason when there is no adapter.
    pub fn open() -> Result<Renderer, String> {
        let ctx = match GpuContext::open(false) {
            Ok(Some(c)) => c,
            Ok(None) => return Err("no Vulkan, Metal or DX12 adapter (on Linux: install mesa-vulkan-drivers for lavapipe)".into()),
            Err(e) => return Err(e.to_string()),
        };
        let device = &ctx.device;
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("render.wgsl"),
            source: wgpu::ShaderSource::Wgsl(RENDER_WGSL.into()),
        });
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("view"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            }],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("render"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = |topology, depth_compare, depth_write| {
            let attributes = wgpu::vertex_attr_array![0 => Float32x3, 1 => Unorm8x4];
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("render"),
                layout: Some(&pipeline_layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("vs_main"),
                    compilation_options: Default::default(),
                    buffers: &[Some(wgpu::VertexBufferLayout {
                        array_stride: std::mem::size_of::<Vertex>() as u64,
                        step_mode: wgpu::VertexStepMode::Vertex,
                        attributes: &attributes,
                    })],
                },
                primitive: wgpu::PrimitiveState {
                    topology,
                    ..Default::default()
                },
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: wgpu::TextureFormat::Depth32Float,
                    depth_write_enabled: Some(depth_write),
                    depth_compare: Some(depth_compare),
                    stencil: Default::default(),
                    bias: Default::default(),
                }),
                multisample: wgpu::MultisampleState {
                    count: SAMPLES,
                    ..Default::default()
                },
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some("fs_main"),
                    compilation_options: Default::default(),
                    targets: &[Some(FORMAT.into())],
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        use wgpu::{CompareFunction as C, PrimitiveTopology as P};
        let lit = pipeline(P::TriangleList, C::Less, true);
        let lines = pipeline(P::LineList, C::LessEqual, true);
        let overlay = pipeline(P::TriangleList, C::Always, false);
        Ok(Renderer {
            ctx,
            layout,
            lit,
            lines,
            overlay,
        })
    }

    /// The adapter's name.
    pub fn adapter(&self) -> &str {
        &self.ctx.summary.name
    }

    /// `list` seen by `camera`, `width` × `height` pixels (width a
    /// multiple of 64), as RGBA rows top to bottom; `Err` says why the
    /// device gave none.
    pub fn draw(
        &self,
        list: &DrawList,
        camera: &Camera,
        width: u32,
        height: u32,
    ) -> Result<Vec<u8>, String> {
        let size = wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        };
        let target = self.texture(size, FORMAT, 1, wgpu::TextureUsages::COPY_SRC);
        let uniform = ViewUniform {
            view_proj: camera
                .view_proj(width as f32 / height as f32)
                .to_cols_array_2d(),
            eye: camera.eye.extend(1.0).to_array(),
        };
        let mut enc = self.ctx.device.create_command_encoder(&Default::default());
        self.pass(&mut enc, list, &uniform, &target, size);
        self.read_back(enc, &target, size)
    }

    /// A 2-D texture `size` of `format` for attachment (and `usage`).
    fn texture(
        &self,
        size: wgpu::Extent3d,
        format: wgpu::TextureFormat,
        samples: u32,
        usage: wgpu::TextureUsages,
    ) -> wgpu::Texture {
        self.ctx.device.create_texture(&wgpu::TextureDescriptor {
            label: None,
            size,
            mip_level_count: 1,
            sample_count: samples,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | usage,
            view_formats: &[],
        })
    }

    /// Record the render pass drawing `list` into `target` (multisampled,
    /// then resolved): lit triangles, lines, then the overlay.
    fn pass(
        &self,
        enc: &mut wgpu::CommandEncoder,
        list: &DrawList,
        uniform: &ViewUniform,
        target: &wgpu::Texture,
        size: wgpu::Extent3d,
    ) {
        let none = wgpu::TextureUsages::empty();
        let msaa = self.texture(size, FORMAT, SAMPLES, none);
        let depth = self.texture(size, wgpu::TextureFormat::Depth32Float, SAMPLES, none);
        let (msaa, depth) = (
            msaa.create_view(&Default::default()),
            depth.create_view(&Default::default()),
        );
        let resolved = target.create_view(&Default::default());
        let ubuf = self.buffer(bytemuck::bytes_of(uniform), wgpu::BufferUsages::UNIFORM);
        let bind = self
            .ctx
            .device
            .create_bind_group(&wgpu::BindGroupDescriptor {
                label: None,
                layout: &self.layout,
                entries: &[wgpu::BindGroupEntry {
                    binding: 0,
                    resource: ubuf.as_entire_binding(),
                }],
            });
        let batches = [
            (&self.lit, &list.triangles),
            (&self.lines, &list.lines),
            (&self.overlay, &list.overlay),
        ];
        let buffers: Vec<Option<wgpu::Buffer>> = batches
            .iter()
            .map(|(_, v)| {
                let verts: Vec<Vertex> = v
                    .iter()
                    .map(|&(position, color)| Vertex { position, color })
                    .collect();
                (!v.is_empty())
                    .then(|| self.buffer(bytemuck::cast_slice(&verts), wgpu::BufferUsages::VERTEX))
            })
            .collect();
        let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("picture"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &msaa,
                depth_slice: None,
                resolve_target: Some(&resolved),
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::WHITE),
                    store: wgpu::StoreOp::Discard,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &depth,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(1.0),
                    store: wgpu::StoreOp::Discard,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_bind_group(0, &bind, &[]);
        for ((pipeline, verts), buf) in batches.iter().zip(&buffers) {
            if let Some(buf) = buf {
                pass.set_pipeline(pipeline);
                pass.set_vertex_buffer(0, buf.slice(..));
                pass.draw(0..verts.len() as u32, 0..1);
            }
        }
    }

    /// Submit `enc` with a copy of `target` out, wait, and return its rows.
    fn read_back(
        &self,
        mut enc: wgpu::CommandEncoder,
        target: &wgpu::Texture,
        size: wgpu::Extent3d,
    ) -> Result<Vec<u8>, String> {
        let row = size.width * 4;
        let out = self.ctx.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("picture readback"),
            size: (row * size.height) as u64,
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
            mapped_at_creation: false,
        });
        enc.copy_texture_to_buffer(
            target.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: &out,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(row),
                    rows_per_image: Some(size.height),
                },
            },
            size,
        );
        let index = self.ctx.queue.submit([enc.finish()]);
        let slice = out.slice(..);
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
            .map_err(|e| format!("the GPU stopped responding: {e}"))?;
        rx.recv()
            .map_err(|e| e.to_string())?
            .map_err(|e| format!("reading the picture back failed: {e}"))?;
        let pixels = slice
            .get_mapped_range()
            .map(|d| d.to_vec())
            .map_err(|e| format!("reading the picture back failed: {e}"))?;
        out.unmap();
        Ok(pixels)
    }

    /// A buffer holding `bytes`.
    fn buffer(&self, bytes: &[u8], usage: wgpu::BufferUsages) -> wgpu::Buffer {
        use wgpu::util::DeviceExt;
        self.ctx
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: None,
                contents: bytes,
                usage,
            })
    }
}

/// RGBA rows as a PNG file.
pub fn png(rgba: &[u8], width: u32, height: u32) -> Vec<u8> {
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, width, height);
        enc.set_color(png::ColorType::Rgba);
        enc.set_depth(png::BitDepth::Eight);
        let mut w = enc.write_header().expect("PNG header into memory");
        w.write_image_data(rgba).expect("PNG data into memory");
    }
    out
}

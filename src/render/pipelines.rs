//! Shaders, uniform layout and the two render pipelines (lit triangles, lines).

use std::borrow::Cow;

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use super::frame::Camera;
use super::geometry::{LineVertex, LitVertex};

const GLOBALS_WGSL: &str = include_str!("../../shaders/globals.wgsl");
const LIT_WGSL: &str = include_str!("../../shaders/lit.wgsl");
const LINE_WGSL: &str = include_str!("../../shaders/line.wgsl");

/// Depth buffer format.
pub(crate) const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// Uniforms shared by both pipelines (must match `shaders/globals.wgsl`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub(crate) struct Globals {
    view_proj: [[f32; 4]; 4],
    eye: [f32; 4],
    key_dir: [f32; 4],
    key_color: [f32; 4],
    fill_dir: [f32; 4],
    fill_color: [f32; 4],
    ambient: [f32; 4],
    params: [f32; 4],
}

impl Globals {
    /// Uniforms for `camera` at the given aspect ratio. Lights follow the camera (a head-light rig):
    /// a warm key light from the upper left behind the viewer and a cool, weaker fill from the lower right,
    /// so every view of the surface is readable.
    pub fn new(camera: &Camera, aspect: f32, encode_srgb: bool) -> Self {
        let (right, up, back) = (camera.right(), camera.true_up(), -camera.forward());
        let key = (0.6 * up - 0.6 * right + 0.5 * back).normalize_or(back);
        let fill = (-0.25 * up + 0.75 * right + 0.6 * back).normalize_or(back);
        let dir = |d: Vec3, w: f32| [d.x, d.y, d.z, w];
        Self {
            view_proj: camera.view_proj(aspect).to_cols_array_2d(),
            eye: camera.eye.extend(1.0).to_array(),
            key_dir: dir(key, 0.8),
            key_color: [1.0, 0.95, 0.88, 1.0],
            fill_dir: dir(fill, 0.22),
            fill_color: [0.80, 0.88, 1.0, 1.0],
            ambient: [0.08, 0.085, 0.10, 0.5],
            params: [if encode_srgb { 1.0 } else { 0.0 }, 0.3, 40.0, 0.0],
        }
    }
}

/// Everything created once per colour format and sample count.
#[derive(Debug)]
pub(crate) struct Pipelines {
    pub bind_group_layout: wgpu::BindGroupLayout,
    pub lit: wgpu::RenderPipeline,
    pub line: wgpu::RenderPipeline,
}

impl Pipelines {
    pub fn new(device: &wgpu::Device, color_format: wgpu::TextureFormat, sample_count: u32) -> Self {
        let bind_group_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("shellwarp globals layout"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: wgpu::BufferSize::new(size_of::<Globals>() as u64),
                },
                count: None,
            }],
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("shellwarp pipeline layout"),
            bind_group_layouts: &[Some(&bind_group_layout)],
            immediate_size: 0,
        });
        let make = |label: &str, source: &str, stride: usize, attributes: &[wgpu::VertexAttribute], lines: bool| {
            let vertex = wgpu::VertexBufferLayout {
                array_stride: stride as u64,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes,
            };
            let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(label),
                source: wgpu::ShaderSource::Wgsl(Cow::Owned(format!("{GLOBALS_WGSL}\n{source}"))),
            });
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(label),
                layout: Some(&layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("vs_main"),
                    compilation_options: Default::default(),
                    buffers: &[Some(vertex)],
                },
                primitive: wgpu::PrimitiveState {
                    topology: if lines {
                        wgpu::PrimitiveTopology::LineList
                    } else {
                        wgpu::PrimitiveTopology::TriangleList
                    },
                    front_face: wgpu::FrontFace::Ccw,
                    // Shells are two-sided: never cull.
                    cull_mode: None,
                    ..Default::default()
                },
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: DEPTH_FORMAT,
                    // Lines may be translucent (faint grids): test against depth but do not write it.
                    depth_write_enabled: Some(!lines),
                    depth_compare: Some(wgpu::CompareFunction::LessEqual),
                    stencil: Default::default(),
                    bias: Default::default(),
                }),
                multisample: wgpu::MultisampleState { count: sample_count, ..Default::default() },
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some("fs_main"),
                    compilation_options: Default::default(),
                    targets: &[Some(wgpu::ColorTargetState {
                        format: color_format,
                        blend: Some(wgpu::BlendState::ALPHA_BLENDING),
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        let lit_attrs = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x4, 3 => Float32x4];
        let lit = make("shellwarp lit", LIT_WGSL, size_of::<LitVertex>(), &lit_attrs, false);
        let line_attrs = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32, 2 => Float32x4];
        let line = make("shellwarp lines", LINE_WGSL, size_of::<LineVertex>(), &line_attrs, true);
        Self { bind_group_layout, lit, line }
    }
}

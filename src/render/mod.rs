//! Frames drawn the way an engine draws them: the level's triangles rasterised with wgpu
//! and every pixel shaded by the exported shader (`shaders/warpfit.wgsl`'s
//! `surface_vertex` / `surface_fragment`, which call `specular` and `irradiance` as an
//! engine's pixel shader does) over an export folder's textures and buffers. The sky is
//! added where no surface is drawn. [`frames`] sets these frames beside traced references
//! and box projection and judges them with ꟻLIP (`warpfit render`).

pub mod frames;
pub mod gpu;

use crate::perceptual::CameraPose;
use crate::scene::Scene;
use crate::trace::Tracer;
use glam::{Vec3, Vec4};
use gpu::{Gpu, GridBindings};
use std::path::Path;
use wgpu::util::DeviceExt as _;

/// Why a frame could not be drawn: the graphics adapter, or an export file (named).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct RenderError(pub String);

/// How every visible surface is shaded.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shading {
    /// A glossy reflector of this perceptual roughness: `specular(b, reflected view ray, r)`.
    Specular(f32),
    /// A diffuse one: `irradiance(b, n)` × the material's albedo / π.
    Diffuse,
}

impl Shading {
    /// As the shader's `camera.shading` reads it, with location 0 holding the radiance
    /// (`directions` false) or the query's direction.
    fn words(self, directions: bool) -> [f32; 4] {
        let z = if directions { 1.0 } else { 0.0 };
        match self {
            Shading::Specular(r) => [r, 0.0, z, 0.0],
            Shading::Diffuse => [0.0, 1.0, z, 0.0],
        }
    }
}

/// Where a frame is seen from: the pose, the horizontal field of view and the image size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub pose: CameraPose,
    pub fov_deg: f32,
    pub size: (u32, u32),
}

/// A drawn frame, row-major from the top row.
#[derive(Clone, Debug)]
pub struct Frame {
    pub width: u32,
    pub height: u32,
    /// Radiance of each pixel: the shaded surface, black on a back face of a one-sided
    /// material, the sky where nothing is drawn.
    pub radiance: Vec<Vec3>,
    /// Per pixel, the point the shader shaded (off the surface as the tracer offsets it);
    /// `None` where the pixel shows sky or a back face. [`Rasteriser::queries`] adds each
    /// pixel's direction.
    pub points: Vec<Option<Vec3>>,
}

/// A shaded point (xyz, w 1 where shaded) as read back.
fn shaded_point(p: &[f32; 4]) -> Option<Vec3> {
    (p[3] > 0.0).then(|| Vec3::new(p[0], p[1], p[2]))
}

/// Floats per vertex of the shader's vertex buffer 0.
const VERTEX_FLOATS: usize = 14;

/// The scene as the shader's vertex buffer: every triangle's three corners with its
/// geometric normal, and every sphere as the 36 corners of a box around it.
fn vertices(scene: &Scene) -> Vec<f32> {
    let t = &scene.triangles;
    let mut out = Vec::with_capacity((t.len() * 3 + scene.spheres.len() * 36) * VERTEX_FLOATS);
    let mut push = |p: Vec3, n: Vec3, material: u32, sphere: Vec4| {
        let m = &scene.materials[material as usize];
        out.extend_from_slice(&[p.x, p.y, p.z, n.x, n.y, n.z, m.albedo.x, m.albedo.y, m.albedo.z]);
        out.push(if m.two_sided { 1.0 } else { 0.0 });
        out.extend_from_slice(&sphere.to_array());
    };
    for k in 0..t.len() {
        let (a, b, c) = (t.v0[k], t.v1[k], t.v2[k]);
        let n = (b - a).cross(c - a).normalize_or_zero();
        for p in [a, b, c] {
            push(p, n, t.material[k], Vec4::ZERO);
        }
    }
    let s = &scene.spheres;
    // the box's 12 triangles; a sliver wider than the sphere so its silhouette is covered
    const FACES: [[usize; 4]; 6] = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]];
    for k in 0..s.len() {
        let (c, r) = (s.center[k], s.radius[k]);
        let h = r * 1.001;
        let corner = |i: usize| {
            c + Vec3::new(
                if i & 4 != 0 { h } else { -h },
                if i & 2 != 0 { h } else { -h },
                if i & 1 != 0 { h } else { -h },
            )
        };
        let sphere = c.extend(if s.inward[k] { -r } else { r });
        for f in FACES {
            for i in [f[0], f[1], f[2], f[0], f[2], f[3]] {
                push(corner(i), Vec3::ZERO, s.material[k], sphere);
            }
        }
    }
    out
}

/// An export folder and a scene on the GPU, ready to draw frames.
pub struct Rasteriser<'a> {
    gpu: &'a Gpu,
    grid: GridBindings,
    camera_layout: wgpu::BindGroupLayout,
    pipeline: wgpu::RenderPipeline,
    vertices: wgpu::Buffer,
    vertex_count: u32,
    /// The tracer's offset frame (centre, scale) and the near plane's distance.
    offset: (Vec3, f32),
    near: f32,
}

/// The colour targets' format: both hold four f32 (WebGPU's 32 bytes per sample).
const TARGET: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
const DEPTH: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

impl<'a> Rasteriser<'a> {
    /// The export in `export_dir` (`warpfit export`: its textures, buffers, WGSL and
    /// specialisation constants) and the triangles and spheres of `scene`.
    pub fn new(gpu: &'a Gpu, export_dir: &Path, scene: &Scene, tracer: &Tracer) -> Result<Self, RenderError> {
        let d = &gpu.device;
        let stages = wgpu::ShaderStages::VERTEX_FRAGMENT;
        let grid = GridBindings::load(gpu, export_dir, stages)?;
        let camera_layout = d.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("camera"),
            entries: &[gpu::buffer_entry(0, wgpu::BufferBindingType::Uniform, stages)],
        });
        let module = gpu::shader_module(gpu, export_dir)?;
        let layout = d.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: None,
            bind_group_layouts: &[Some(&grid.layout), None, None, Some(&camera_layout)],
            immediate_size: 0,
        });
        let owned = gpu::constants(export_dir)?;
        let constants: Vec<(&str, f64)> = owned.iter().map(|(k, v)| (k.as_str(), *v)).collect();
        let compilation_options = wgpu::PipelineCompilationOptions { constants: &constants, ..Default::default() };
        let attributes =
            wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x3, 3 => Float32, 4 => Float32x4];
        let target = Some(wgpu::ColorTargetState { format: TARGET, blend: None, write_mask: wgpu::ColorWrites::ALL });
        let pipeline = d.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("surfaces"),
            layout: Some(&layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("surface_vertex"),
                compilation_options: compilation_options.clone(),
                buffers: &[Some(wgpu::VertexBufferLayout {
                    array_stride: (VERTEX_FLOATS * 4) as u64,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes: &attributes,
                })],
            },
            primitive: wgpu::PrimitiveState { cull_mode: None, ..Default::default() },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: DEPTH,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Greater),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("surface_fragment"),
                compilation_options,
                targets: &[target.clone(), target],
            }),
            multiview_mask: None,
            cache: None,
        });
        let data = vertices(scene);
        let vertices = d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("vertices"),
            contents: &data.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>(),
            usage: wgpu::BufferUsages::VERTEX,
        });
        let (lo, hi) = scene.bounds();
        let near = ((hi - lo).length() * 1e-5).max(f32::MIN_POSITIVE);
        Ok(Rasteriser {
            gpu,
            grid,
            camera_layout,
            pipeline,
            vertices,
            vertex_count: (data.len() / VERTEX_FLOATS) as u32,
            offset: tracer.offset_frame(),
            near,
        })
    }

    /// Draws the level from `camera` with every surface shaded by `shading`; the sky
    /// (`scene`'s) where nothing is drawn.
    #[must_use]
    pub fn draw(&self, scene: &Scene, camera: &Camera, shading: Shading) -> Frame {
        let (colour, points) = self.pass(camera, shading, false);
        let (w, h) = camera.size;
        let rays = camera.pose.rays(camera.fov_deg, camera.size);
        let radiance = colour
            .iter()
            .zip(&rays)
            .map(|(c, ray)| if c[3] > 0.0 { Vec3::new(c[0], c[1], c[2]) } else { scene.sky.radiance(*ray) })
            .collect();
        Frame { width: w, height: h, radiance, points: points.iter().map(shaded_point).collect() }
    }

    /// Per pixel of [`Rasteriser::draw`], the query the shader answers: the shaded point and
    /// the unit direction (the reflected view ray; diffuse: the normal), `None` where the
    /// pixel shows sky or a back face. One more draw, with the shader writing directions
    /// instead of radiance: for checking the shader against the CPU.
    #[must_use]
    pub fn queries(&self, camera: &Camera, shading: Shading) -> Vec<Option<(Vec3, Vec3)>> {
        let (directions, points) = self.pass(camera, shading, true);
        points.iter().zip(&directions).map(|(p, d)| Some((shaded_point(p)?, Vec3::new(d[0], d[1], d[2])))).collect()
    }

    /// One draw: location 0 (radiance, or with `directions` the queries' directions) and
    /// location 1 (the shaded points), read back.
    fn pass(&self, camera: &Camera, shading: Shading, directions: bool) -> (Vec<[f32; 4]>, Vec<[f32; 4]>) {
        let (gpu, d) = (self.gpu, &self.gpu.device);
        let (w, h) = camera.size;
        let view_proj = camera.pose.view_projection(camera.fov_deg, camera.size, self.near);
        let mut words: Vec<f32> = view_proj.to_cols_array().to_vec();
        words.extend_from_slice(&camera.pose.eye.extend(0.0).to_array());
        words.extend_from_slice(&self.offset.0.extend(self.offset.1).to_array());
        words.extend_from_slice(&shading.words(directions));
        let uniform = d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("camera"),
            contents: &words.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>(),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let camera_group = d.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &self.camera_layout,
            entries: &[wgpu::BindGroupEntry { binding: 0, resource: uniform.as_entire_binding() }],
        });
        let size = wgpu::Extent3d { width: w, height: h, depth_or_array_layers: 1 };
        let texture = |format, usage| {
            d.create_texture(&wgpu::TextureDescriptor {
                label: None,
                size,
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage,
                view_formats: &[],
            })
        };
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC;
        let targets = [texture(TARGET, usage), texture(TARGET, usage)];
        let depth = texture(DEPTH, wgpu::TextureUsages::RENDER_ATTACHMENT);
        let views: Vec<wgpu::TextureView> = targets.iter().map(|t| t.create_view(&Default::default())).collect();
        let depth_view = depth.create_view(&Default::default());
        // rows of a texture copy are padded to 256 bytes
        let row = (w * 16).div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
        let staging: Vec<wgpu::Buffer> = (0..2)
            .map(|_| {
                d.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("frame"),
                    size: u64::from(row * h),
                    usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                })
            })
            .collect();
        let mut enc = d.create_command_encoder(&Default::default());
        {
            let attachment = |view| {
                Some(wgpu::RenderPassColorAttachment {
                    view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                        store: wgpu::StoreOp::Store,
                    },
                })
            };
            let mut pass = enc.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("surfaces"),
                color_attachments: &[attachment(&views[0]), attachment(&views[1])],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &depth_view,
                    depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(0.0), store: wgpu::StoreOp::Discard }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &self.grid.group, &[]);
            pass.set_bind_group(3, &camera_group, &[]);
            pass.set_vertex_buffer(0, self.vertices.slice(..));
            pass.draw(0..self.vertex_count, 0..1);
        }
        for (t, b) in targets.iter().zip(&staging) {
            enc.copy_texture_to_buffer(
                t.as_image_copy(),
                wgpu::TexelCopyBufferInfo {
                    buffer: b,
                    layout: wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(row),
                        rows_per_image: Some(h),
                    },
                },
                size,
            );
        }
        gpu.queue.submit([enc.finish()]);
        let read = |b: &wgpu::Buffer| -> Vec<[f32; 4]> {
            let padded = gpu.read_vec4s(b);
            let per_row = (row / 16) as usize;
            // a lost device reads back nothing: a frame of zeros, no surface drawn
            (0..h as usize)
                .flat_map(|y| {
                    padded.get(y * per_row..y * per_row + w as usize).map_or(vec![[0.0; 4]; w as usize], <[_]>::to_vec)
                })
                .collect()
        };
        (read(&staging[0]), read(&staging[1]))
    }
}

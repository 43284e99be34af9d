//! The reference shader on a real graphics API: an export folder (`warpfit export`) loaded
//! as an engine would load it (the KTX2 textures through an independent reader, the two
//! buffers as bytes, the WGSL as shipped) and its query kernels run through wgpu on whatever
//! adapter exists (Mesa's lavapipe software Vulkan on machines without a GPU). Shared by
//! `tests/gpu.rs` and `benches/gpu.rs`.
#![allow(dead_code)]

use std::collections::HashMap;
use std::path::Path;
use std::time::{Duration, Instant};
use wgpu::util::DeviceExt as _;

pub use warpfit::render::gpu::Gpu;
use warpfit::render::gpu::{GridBindings, buffer_entry as buffer_entry_of, texture_entry as texture_entry_of_stage};

/// The adapter (the library's `render::gpu::Gpu`), or why there is none.
pub fn gpu_device() -> Result<Gpu, String> {
    Gpu::new().map_err(|e| e.to_string())
}

/// A texture from a KTX2 file, read by the library's independent reader.
pub fn ktx2_texture(gpu: &Gpu, path: &Path) -> wgpu::Texture {
    gpu.ktx2_texture(path).unwrap_or_else(|e| panic!("{e}"))
}

fn texture_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    texture_entry_of(binding, wgpu::TextureViewDimension::D2)
}

fn texture_entry_of(binding: u32, view_dimension: wgpu::TextureViewDimension) -> wgpu::BindGroupLayoutEntry {
    texture_entry_of_stage(binding, view_dimension, wgpu::ShaderStages::COMPUTE)
}

fn buffer_entry(binding: u32, ty: wgpu::BufferBindingType) -> wgpu::BindGroupLayoutEntry {
    buffer_entry_of(binding, ty, wgpu::ShaderStages::COMPUTE)
}

/// An export folder on the GPU, ready to run the shader's query kernels.
pub struct Lookup {
    group0: wgpu::BindGroup,
    layout1: wgpu::BindGroupLayout,
    pipelines: HashMap<&'static str, wgpu::ComputePipeline>,
}

/// The shader's query kernels.
pub const KERNELS: [&str; 4] = ["specular_queries", "irradiance_queries", "warp1_queries", "box_queries"];

/// Query and result buffers for `n` queries.
pub struct Batch {
    n: usize,
    group1: wgpu::BindGroup,
    queries: wgpu::Buffer,
    results: wgpu::Buffer,
    staging: wgpu::Buffer,
}

/// Which pipeline to build.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pipeline {
    /// The specialisation constants left at their defaults: every setting read from `params`.
    Generic,
    /// The constants set to the grid's values from `export.json`.
    Specialised,
}

/// The export's specialisation constants (`export.json`'s `shader.constants`).
pub fn constants(dir: &Path) -> Vec<(String, f64)> {
    warpfit::render::gpu::constants(dir).unwrap_or_else(|e| panic!("{e}"))
}

impl Lookup {
    pub fn load(gpu: &Gpu, dir: &Path, pipeline: Pipeline) -> Lookup {
        let d = &gpu.device;
        let grid = GridBindings::load(gpu, dir, wgpu::ShaderStages::COMPUTE).unwrap_or_else(|e| panic!("{e}"));
        let (layout0, group0) = (grid.layout, grid.group);
        let layout1 = queries_layout(d);
        let source = std::fs::read_to_string(dir.join("warpfit.wgsl")).expect("warpfit.wgsl exported");
        let module = d.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("warpfit.wgsl"),
            source: wgpu::ShaderSource::Wgsl(source.into()),
        });
        let layout = d.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: None,
            bind_group_layouts: &[Some(&layout0), Some(&layout1)],
            immediate_size: 0,
        });
        let owned = match pipeline {
            Pipeline::Generic => Vec::new(),
            Pipeline::Specialised => constants(dir),
        };
        let constants: Vec<(&str, f64)> = owned.iter().map(|(k, v)| (k.as_str(), *v)).collect();
        let pipelines = KERNELS
            .iter()
            .map(|&k| {
                let p = d.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some(k),
                    layout: Some(&layout),
                    module: &module,
                    entry_point: Some(k),
                    compilation_options: wgpu::PipelineCompilationOptions {
                        constants: &constants,
                        ..Default::default()
                    },
                    cache: None,
                });
                (k, p)
            })
            .collect();
        Lookup { group0, layout1, pipelines }
    }

    /// Buffers for the queries (two vec4 each, as the kernels read them).
    pub fn batch(&self, gpu: &Gpu, queries: &[[f32; 4]]) -> Batch {
        batch(gpu, &self.layout1, queries)
    }

    /// Runs kernel `kernel` over the batch and waits for it; returns the time from submit
    /// to completion.
    pub fn dispatch(&self, gpu: &Gpu, kernel: &str, batch: &Batch, copy_out: bool) -> Duration {
        dispatch(gpu, &self.pipelines[kernel], (0, &self.group0), batch, copy_out)
    }

    /// The kernel's results for `queries` (two vec4 per query): one vec4 per query.
    pub fn run(&self, gpu: &Gpu, kernel: &str, queries: &[[f32; 4]]) -> Vec<[f32; 4]> {
        let batch = self.batch(gpu, queries);
        self.dispatch(gpu, kernel, &batch, true);
        gpu.read_vec4s(&batch.staging)
    }
}

/// Runs `pipeline` over `batch` (group 1) with `other` bound beside it (the grid's group 0
/// or a surface atlas's group 2) and waits for it; returns the time from submit to
/// completion. With `copy_out` the results land in the batch's staging buffer.
fn dispatch(
    gpu: &Gpu,
    pipeline: &wgpu::ComputePipeline,
    other: (u32, &wgpu::BindGroup),
    batch: &Batch,
    copy_out: bool,
) -> Duration {
    let mut enc = gpu.device.create_command_encoder(&Default::default());
    {
        let mut pass = enc.begin_compute_pass(&Default::default());
        pass.set_pipeline(pipeline);
        pass.set_bind_group(other.0, other.1, &[]);
        pass.set_bind_group(1, &batch.group1, &[]);
        // 64 queries per workgroup, along x only (the kernels read the x invocation id)
        let groups = batch.n.div_ceil(64);
        assert!(groups <= 65535, "at most 65535·64 queries per dispatch");
        pass.dispatch_workgroups(groups as u32, 1, 1);
    }
    if copy_out {
        enc.copy_buffer_to_buffer(&batch.results, 0, &batch.staging, 0, (batch.n * 16) as u64);
    }
    let start = Instant::now();
    gpu.queue.submit([enc.finish()]);
    gpu.wait();
    start.elapsed()
}

/// The query kernels' group 1 layout: queries (read) and results (read-write).
fn queries_layout(d: &wgpu::Device) -> wgpu::BindGroupLayout {
    d.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: None,
        entries: &[
            buffer_entry(0, wgpu::BufferBindingType::Storage { read_only: true }),
            buffer_entry(1, wgpu::BufferBindingType::Storage { read_only: false }),
        ],
    })
}

/// Query and result buffers for `queries` (two vec4 each), bound as group 1.
fn batch(gpu: &Gpu, layout1: &wgpu::BindGroupLayout, queries: &[[f32; 4]]) -> Batch {
    let d = &gpu.device;
    let n = queries.len() / 2;
    let bytes: Vec<u8> = queries.iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
    let queries = d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("queries"),
        contents: &bytes,
        usage: wgpu::BufferUsages::STORAGE,
    });
    let size = (n * 16) as u64;
    let results = d.create_buffer(&wgpu::BufferDescriptor {
        label: Some("results"),
        size,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let staging = d.create_buffer(&wgpu::BufferDescriptor {
        label: Some("staging"),
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let group1 = d.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: layout1,
        entries: &[
            wgpu::BindGroupEntry { binding: 0, resource: queries.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 1, resource: results.as_entire_binding() },
        ],
    });
    Batch { n, group1, queries, results, staging }
}

/// The shader's surface-atlas kernels: seed 003's lookup and its warped variant.
pub const SURFACE_KERNELS: [&str; 2] = ["surface_queries", "surface_warped_queries"];

/// One exported surface-probe atlas on the GPU (group 2: its radiance array, its
/// `SurfaceParams` and its inverse distances), ready to run the shader's surface kernels.
/// They do not touch the grid's group 0, so the pipeline layout leaves it empty, as a
/// renderer that shades only a surface would.
pub struct SurfaceLookup {
    group2: wgpu::BindGroup,
    layout1: wgpu::BindGroupLayout,
    pipelines: HashMap<&'static str, wgpu::ComputePipeline>,
}

impl SurfaceLookup {
    /// Atlas `k` of the export folder `dir` (`export.json` → `surfaces[k]`).
    pub fn load(gpu: &Gpu, dir: &Path, k: usize) -> SurfaceLookup {
        let d = &gpu.device;
        let text = std::fs::read_to_string(dir.join("export.json")).expect("export.json");
        let v: serde_json::Value = serde_json::from_str(&text).expect("export.json parses");
        let section = &v["surfaces"][k];
        let radiance = ktx2_texture(gpu, &dir.join(section["radiance"].as_str().expect("surfaces[k].radiance")));
        let view = radiance.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        });
        let inv = ktx2_texture(gpu, &dir.join(section["inv_distance"].as_str().expect("surfaces[k].inv_distance")));
        let inv_view = inv.create_view(&Default::default());
        let params_file = dir.join(section["params"].as_str().expect("surfaces[k].params"));
        let params = d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("surface params"),
            contents: &std::fs::read(&params_file).unwrap_or_else(|e| panic!("{}: {e}", params_file.display())),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let layout2 = d.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: None,
            entries: &[
                texture_entry_of(0, wgpu::TextureViewDimension::D2Array),
                buffer_entry(1, wgpu::BufferBindingType::Uniform),
                texture_entry(2),
            ],
        });
        let group2 = d.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &layout2,
            entries: &[
                wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&view) },
                wgpu::BindGroupEntry { binding: 1, resource: params.as_entire_binding() },
                wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::TextureView(&inv_view) },
            ],
        });
        let layout1 = queries_layout(d);
        let source = std::fs::read_to_string(dir.join("warpfit.wgsl")).expect("warpfit.wgsl exported");
        let module = d.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("warpfit.wgsl"),
            source: wgpu::ShaderSource::Wgsl(source.into()),
        });
        let layout = d.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: None,
            bind_group_layouts: &[None, Some(&layout1), Some(&layout2)],
            immediate_size: 0,
        });
        let pipelines = SURFACE_KERNELS
            .iter()
            .map(|&k| {
                let p = d.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some(k),
                    layout: Some(&layout),
                    module: &module,
                    entry_point: Some(k),
                    compilation_options: Default::default(),
                    cache: None,
                });
                (k, p)
            })
            .collect();
        SurfaceLookup { group2, layout1, pipelines }
    }

    /// Surface kernel `kernel` for `queries` (two vec4 each): one vec4 per query.
    pub fn run(&self, gpu: &Gpu, kernel: &str, queries: &[[f32; 4]]) -> Vec<[f32; 4]> {
        let b = batch(gpu, &self.layout1, queries);
        dispatch(gpu, &self.pipelines[kernel], (2, &self.group2), &b, true);
        gpu.read_vec4s(&b.staging)
    }
}

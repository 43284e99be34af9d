//! A graphics device and an export folder on it: the first adapter wgpu finds (Mesa's
//! lavapipe software Vulkan on machines without a GPU), the export's KTX2 textures read
//! with the independent `ktx2` reader and its two buffers uploaded as bytes, bound as the
//! shader's group 0, as an engine binds them.

use super::RenderError;
use std::path::Path;
use wgpu::util::DeviceExt as _;

/// A device on the first adapter found.
pub struct Gpu {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub adapter: wgpu::AdapterInfo,
}

/// How to get an adapter where none exists.
pub const NO_ADAPTER: &str =
    "no graphics adapter: install a Vulkan driver (on Debian, Mesa's lavapipe: apt-get install mesa-vulkan-drivers)";

impl Gpu {
    /// The first adapter of the native backends (Vulkan, Metal, DX12; `WGPU_BACKEND` picks
    /// another), with `FLOAT32_FILTERABLE` when it has it.
    pub fn new() -> Result<Gpu, RenderError> {
        let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
        desc.backends = wgpu::Backends::from_env().unwrap_or(wgpu::Backends::PRIMARY);
        let instance = wgpu::Instance::new(desc);
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions::default()))
            .map_err(|e| RenderError(format!("{NO_ADAPTER} ({e})")))?;
        let features = adapter.features() & wgpu::Features::FLOAT32_FILTERABLE;
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("warpfit"),
            required_features: features,
            required_limits: wgpu::Limits::downlevel_defaults().using_resolution(adapter.limits()),
            ..Default::default()
        }))
        .map_err(|e| RenderError(format!("the adapter {:?} gave no device: {e}", adapter.get_info().name)))?;
        Ok(Gpu { device, queue, adapter: adapter.get_info() })
    }

    /// A texture from a KTX2 file (every mip and array layer).
    pub fn ktx2_texture(&self, path: &Path) -> Result<wgpu::Texture, RenderError> {
        let fail = |what: String| RenderError(format!("{}: {what}", path.display()));
        let bytes = std::fs::read(path).map_err(|e| fail(e.to_string()))?;
        let r = ktx2::Reader::new(bytes.as_slice()).map_err(|e| fail(format!("not a KTX2 file ({e:?})")))?;
        let h = r.header();
        let format = match h.format.map(|f| f.value()) {
            Some(97) => wgpu::TextureFormat::Rgba16Float,
            Some(109) => wgpu::TextureFormat::Rgba32Float,
            Some(100) => wgpu::TextureFormat::R32Float,
            Some(103) => wgpu::TextureFormat::Rg32Float,
            f => return Err(fail(format!("vkFormat {f:?} is none the export writes"))),
        };
        let layers = h.layer_count.max(1);
        if layers > 1 && h.level_count > 1 {
            return Err(fail("layered textures with mips are none the export writes".into()));
        }
        let data: Vec<u8> = r.levels().flat_map(|l| l.data.iter().copied()).collect();
        Ok(self.device.create_texture_with_data(
            &self.queue,
            &wgpu::TextureDescriptor {
                label: path.file_name().and_then(|n| n.to_str()),
                size: wgpu::Extent3d { width: h.pixel_width, height: h.pixel_height, depth_or_array_layers: layers },
                mip_level_count: h.level_count.max(1),
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage: wgpu::TextureUsages::TEXTURE_BINDING,
                view_formats: &[],
            },
            wgpu::util::TextureDataOrder::LayerMajor,
            &data,
        ))
    }

    /// A 1×1 R32F texture: what an absent file binds.
    pub fn dummy_texture(&self) -> wgpu::Texture {
        self.device.create_texture_with_data(
            &self.queue,
            &wgpu::TextureDescriptor {
                label: Some("absent"),
                size: wgpu::Extent3d { width: 1, height: 1, depth_or_array_layers: 1 },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: wgpu::TextureFormat::R32Float,
                usage: wgpu::TextureUsages::TEXTURE_BINDING,
                view_formats: &[],
            },
            wgpu::util::TextureDataOrder::LayerMajor,
            &[0; 4],
        )
    }

    /// Waits until the queue has finished.
    pub fn wait(&self) {
        // a lost device shows as zeros in the read-back, which the callers' checks catch
        let _ = self.device.poll(wgpu::PollType::wait_indefinitely());
    }

    /// The vec4s in `buffer` (MAP_READ), once the queue has finished.
    pub fn read_vec4s(&self, buffer: &wgpu::Buffer) -> Vec<[f32; 4]> {
        let slice = buffer.slice(..);
        slice.map_async(wgpu::MapMode::Read, |_| ());
        self.wait();
        let Ok(range) = slice.get_mapped_range() else { return Vec::new() };
        let out = range
            .chunks_exact(16)
            .map(|c| std::array::from_fn(|k| f32::from_le_bytes([c[4 * k], c[4 * k + 1], c[4 * k + 2], c[4 * k + 3]])))
            .collect();
        drop(range);
        buffer.unmap();
        out
    }
}

/// The texture files of an export, in binding order (absent: a 1×1 dummy).
pub const TEXTURES: [&str; 7] = [
    "probe_radiance.ktx2",
    "probe_inv_distance.ktx2",
    "correctives.ktx2",
    "irradiance.ktx2",
    "moments.ktx2",
    "irradiance_scale.ktx2",
    "roughness_lookup.ktx2",
];

/// A texture binding of the shader (read with `textureLoad`: not filterable).
#[must_use]
pub fn texture_entry(
    binding: u32,
    view_dimension: wgpu::TextureViewDimension,
    visibility: wgpu::ShaderStages,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable: false },
            view_dimension,
            multisampled: false,
        },
        count: None,
    }
}

/// A buffer binding of the shader.
#[must_use]
pub fn buffer_entry(
    binding: u32,
    ty: wgpu::BufferBindingType,
    visibility: wgpu::ShaderStages,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer { ty, has_dynamic_offset: false, min_binding_size: None },
        count: None,
    }
}

/// An export folder's group 0 (`shaders/warpfit.wgsl`'s grid bindings) and its layout.
pub struct GridBindings {
    pub layout: wgpu::BindGroupLayout,
    pub group: wgpu::BindGroup,
}

impl GridBindings {
    /// The textures and buffers of the export folder `dir`, visible to `visibility`.
    pub fn load(gpu: &Gpu, dir: &Path, visibility: wgpu::ShaderStages) -> Result<GridBindings, RenderError> {
        let d = &gpu.device;
        let textures = TEXTURES
            .iter()
            .map(|f| if dir.join(f).is_file() { gpu.ktx2_texture(&dir.join(f)) } else { Ok(gpu.dummy_texture()) })
            .collect::<Result<Vec<_>, _>>()?;
        let views: Vec<wgpu::TextureView> = textures.iter().map(|t| t.create_view(&Default::default())).collect();
        let file = |name: &str| {
            let path = dir.join(name);
            std::fs::read(&path).map_err(|e| RenderError(format!("{}: {e}", path.display())))
        };
        let params = d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("params"),
            contents: &file("warpfit_params.bin")?,
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let cells = d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("cells"),
            contents: &file("warpfit_cells.bin")?,
            usage: wgpu::BufferUsages::STORAGE,
        });
        let mut entries: Vec<_> =
            (0..7).map(|b| texture_entry(b, wgpu::TextureViewDimension::D2, visibility)).collect();
        entries.push(buffer_entry(7, wgpu::BufferBindingType::Uniform, visibility));
        entries.push(buffer_entry(8, wgpu::BufferBindingType::Storage { read_only: true }, visibility));
        let layout = d.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: None, entries: &entries });
        let mut bind: Vec<wgpu::BindGroupEntry> = views
            .iter()
            .enumerate()
            .map(|(k, v)| wgpu::BindGroupEntry { binding: k as u32, resource: wgpu::BindingResource::TextureView(v) })
            .collect();
        bind.push(wgpu::BindGroupEntry { binding: 7, resource: params.as_entire_binding() });
        bind.push(wgpu::BindGroupEntry { binding: 8, resource: cells.as_entire_binding() });
        let group = d.create_bind_group(&wgpu::BindGroupDescriptor { label: None, layout: &layout, entries: &bind });
        Ok(GridBindings { layout, group })
    }
}

/// The export's specialisation constants (`export.json`'s `shader.constants`).
pub fn constants(dir: &Path) -> Result<Vec<(String, f64)>, RenderError> {
    let path = dir.join("export.json");
    let fail = |what: String| RenderError(format!("{}: {what}", path.display()));
    let text = std::fs::read_to_string(&path).map_err(|e| fail(e.to_string()))?;
    let v: serde_json::Value = serde_json::from_str(&text).map_err(|e| fail(e.to_string()))?;
    let Some(constants) = v["shader"]["constants"].as_object() else {
        return Err(fail("no shader.constants".into()));
    };
    constants
        .iter()
        .map(|(k, n)| {
            n.as_f64().map(|n| (k.clone(), n)).ok_or_else(|| fail(format!("shader.constants.{k} is not a number")))
        })
        .collect()
}

/// The export's shader source (`warpfit.wgsl`) as a module.
pub fn shader_module(gpu: &Gpu, dir: &Path) -> Result<wgpu::ShaderModule, RenderError> {
    let path = dir.join("warpfit.wgsl");
    let source = std::fs::read_to_string(&path).map_err(|e| RenderError(format!("{}: {e}", path.display())))?;
    Ok(gpu.device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("warpfit.wgsl"),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    }))
}

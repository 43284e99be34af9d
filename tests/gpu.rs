//! The reference shader (`shaders/warpfit.wgsl`) run through wgpu on a real graphics API
//! (Mesa's lavapipe Vulkan where there is no GPU; `.ci/run` installs it) over an exported
//! grid, loaded as an engine loads it, agrees with the CPU sampler `FittedGrid` on thousands
//! of random and degenerate queries, on the committed `fits/tiny` and `fits/tiny_probes`
//! (two specular probes, a probe chosen per texel) and on a lit torture grid
//! with stored warp maps and diffuse corrections. And the atlases' gutters make plain
//! hardware bilinear filtering equal the CPU's seam-aware bilinear.
//!
//! Tolerance: radiance and irradiance are exported as half floats (RGBA16F), so each texel
//! carries a relative rounding of at most 2⁻¹¹ ≈ 4.9e-4, and a blend of positive texels no
//! more; the GPU computes in f32 with its own rounding of divisions and square roots (WGSL
//! allows a few ulp), which moves fetch directions by ~1e-7 and radiance by that times its
//! gradient. The bound is 1e-3 of the value, with values below 1e-3 of the scene's mean
//! radiance compared against that floor (half floats lose relative precision below 6e-5).
//! No NaN, no infinity and nothing negative leaves the shader.

mod common;
#[path = "gpu_harness/mod.rs"]
mod gpu_harness;

use common::*;
use glam::{Vec2, Vec3};
use gpu_harness::{Gpu, Lookup, Pipeline};
use std::path::Path;
use warpfit::runtime::FittedGrid;
use warpfit::sampling::{Sampler, uniform_sphere};

/// The adapter, or the test's failure (in CI) / skip (elsewhere) with the reason.
fn gpu() -> Option<&'static Gpu> {
    static G: std::sync::OnceLock<Result<Gpu, String>> = std::sync::OnceLock::new();
    match G.get_or_init(gpu_harness::gpu_device) {
        Ok(g) => Some(g),
        Err(e) => {
            tool_missing("the shader on a graphics API", "a graphics adapter", e);
            None
        }
    }
}

/// A lit torture grid: stored warp maps, relocated probes and diffuse corrections.
fn torture_fit() -> &'static Path {
    static D: std::sync::OnceLock<TestDir> = std::sync::OnceLock::new();
    D.get_or_init(|| {
        let dir = fixture_dir("gpu-torture");
        SmallTorture::fit_into(&dir);
        dir
    })
}

/// Random queries in and around the grid (10% beyond each face), directions of random
/// length, every roughness bucket and random roughness; then the degenerate ones: at the
/// probe, zero, tiny, huge and NaN directions, NaN and infinite positions, roughness NaN,
/// below 0 and above 1. Two vec4 per query: (position, roughness), (direction, 0).
fn queries(g: &FittedGrid, n: u32) -> Vec<[f32; 4]> {
    let geo = &g.irradiance_grid().geometry;
    let mut out = Vec::new();
    let mut push = |p: Vec3, d: Vec3, r: f32| {
        out.push([p.x, p.y, p.z, r]);
        out.push([d.x, d.y, d.z, 0.0]);
    };
    for k in 0..n {
        let mut s = Sampler::new(31, 0, k);
        let t = Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) * 1.2 - 0.1;
        let p = geo.min + (geo.max - geo.min) * t;
        let d = uniform_sphere(s.next_2d()) * (0.25 + 4.0 * s.next_1d());
        let r = [0.0, 0.125, 0.25, 0.5, 0.75, 1.0, s.next_1d()][k as usize % 7];
        push(p, d, r);
    }
    let a = g.warp().probe.position;
    let (nan, inf) = (f32::NAN, f32::INFINITY);
    let centre = (geo.min + geo.max) * 0.5;
    for (k, d) in [Vec3::Y, Vec3::new(0.3, -0.2, 0.9), -Vec3::Z, Vec3::new(-1.0, 1.0, 0.0)].into_iter().enumerate() {
        let r = [0.0, 0.3, 1.0, 0.6][k];
        push(a, d, r);
        push(centre, Vec3::ZERO, r);
        push(centre, d * 1e-30, r);
        push(centre, d * 1e30, r);
        push(centre, Vec3::new(nan, d.y, d.z), r);
        push(Vec3::new(nan, 1.0, 0.0), d, r);
        push(Vec3::new(inf, -inf, 0.0), d, r);
        push(centre + d * 1e6, d, r);
        push(centre, d, nan);
        push(centre, d, -0.5);
        push(centre, d, 7.0);
    }
    out
}

/// `f(position, direction, roughness)` for every query: the CPU's answers.
fn on_cpu(q: &[[f32; 4]], f: impl Fn(Vec3, Vec3, f32) -> Vec3) -> Vec<Vec3> {
    q.chunks_exact(2).map(|c| f(Vec3::from_slice(&c[0][..3]), Vec3::from_slice(&c[1][..3]), c[0][3])).collect()
}

/// Checks that every GPU value is finite and ≥ 0 and that the worst relative difference of
/// `gpu` against `cpu` (denominators floored at `floor`, see the module docs) is at most
/// 1e-3; returns it and its query.
fn assert_agrees(what: &str, gpu: &[[f32; 4]], cpu: &[Vec3], floor: f32, q: &[[f32; 4]]) -> (f32, usize) {
    assert_eq!(gpu.len(), cpu.len());
    let mut worst = (0.0f32, 0usize);
    for (k, (g, c)) in gpu.iter().zip(cpu).enumerate() {
        let g = Vec3::new(g[0], g[1], g[2]);
        assert!(g.is_finite() && g.min_element() >= 0.0, "{what} {k}: the shader returned {g}");
        let rel = (g - *c).abs().max_element() / c.abs().max_element().max(floor);
        if rel > worst.0 {
            worst = (rel, k);
        }
    }
    let (rel, at) = worst;
    assert!(rel <= 1e-3, "{what}: query {at}: shader {:?} vs CPU {} ({:?})", gpu[at], cpu[at], &q[2 * at..2 * at + 2]);
    worst
}

fn mean_radiance(g: &FittedGrid) -> f32 {
    let t = &g.warp().probe.radiance.levels[0].texels;
    t.iter().map(|v| v.max_element()).sum::<f32>() / t.len() as f32
}

fn check_grid(name: &str, g: &FittedGrid) {
    let Some(gpu) = gpu() else { return };
    let dir = tmp_dir(&format!("gpu-export-{name}"));
    warpfit::export::export(g, &dir).unwrap();
    for pipeline in [Pipeline::Generic, Pipeline::Specialised] {
        check_pipeline(&format!("{name} ({pipeline:?})"), gpu, g, &Lookup::load(gpu, &dir, pipeline));
    }
}

fn check_pipeline(name: &str, gpu: &Gpu, g: &FittedGrid, lookup: &Lookup) {
    let q = queries(g, 6000);
    let shader = lookup.run(gpu, "specular_queries", &q);
    let cpu = on_cpu(&q, |p, d, r| g.specular(p, d, r));
    let (worst, at) = assert_agrees(&format!("{name}: specular"), &shader, &cpu, 1e-3 * mean_radiance(g), &q);
    eprintln!(
        "{name}: specular worst relative difference {worst:.2e} (query {at}) on {} queries ({})",
        cpu.len(),
        gpu.adapter.name
    );
    // the degenerate queries answer exactly as the CPU's: black where the CPU is black
    for (k, c) in cpu.iter().enumerate() {
        if *c == Vec3::ZERO {
            assert_eq!(shader[k][..3], [0.0; 3], "{name}: query {k} must be black");
        }
    }

    let shader = lookup.run(gpu, "irradiance_queries", &q);
    let cpu = on_cpu(&q, |p, n, _| g.irradiance(p, n));
    let floor = 1e-3 * cpu.iter().map(|v| v.max_element()).sum::<f32>() / cpu.len() as f32;
    let (worst, at) = assert_agrees(&format!("{name}: irradiance"), &shader, &cpu, floor, &q);
    eprintln!("{name}: irradiance worst relative difference {worst:.2e} (query {at})");
}

#[test]
fn the_shader_answers_as_the_cpu_sampler_on_the_committed_grid() {
    check_grid("tiny", &FittedGrid::load(repo().join("fits/tiny")).unwrap());
}

#[test]
fn the_shader_reads_the_probe_each_texel_chose_as_the_cpu_sampler_does() {
    // the committed grid of two probes: lookups read either
    let g = FittedGrid::load(repo().join("fits/tiny_probes")).unwrap();
    assert_eq!(g.warp().probe_count(), 2);
    assert!(g.correctives().probe_maps.contains(&1), "some texels read the second probe");
    check_grid("tiny_probes", &g);
    // blended near cell faces: where the near cells read different probes, both are read
    let faces = g.clone().with_lookup(|_, blend, _| *blend = warpfit::warp::corrective::Blend::Faces);
    check_grid("tiny_probes-faces", &faces);
    // every other cell without its map, reading probe 1 through the proxy (`cell_probes`)
    let unmapped = g.with_lookup(|_, _, c| {
        let n = c.slot.len();
        c.cell_probes = (0..n).map(|k| (k % 2) as u8).collect();
        for k in (1..n).step_by(2) {
            c.slot[k] = warpfit::warp::corrective::NO_MAP;
        }
    });
    check_grid("tiny_probes-cell-probes", &unmapped);
    let faces = unmapped.with_lookup(|_, blend, _| *blend = warpfit::warp::corrective::Blend::Faces);
    check_grid("tiny_probes-cell-probes-faces", &faces);
}

#[test]
fn the_shader_answers_as_the_cpu_sampler_on_a_torture_grid_with_maps_and_corrections() {
    let dir = torture_fit();
    let mut g = FittedGrid::load(dir).unwrap();
    assert!(g.correctives().stored_cells() > 0, "the check needs stored warp maps");
    assert!(g.irradiance_grid().correction.stored_cells() > 0, "the check needs diffuse corrections");
    // the irradiance blend's surface bias as fitted, or a tenth of a cell where the fit
    // chose none, so the shader's is always checked
    if g.irradiance_grid().correction.surface_bias == 0.0 {
        g = g.with_irradiance(|ir| {
            ir.correction.surface_bias = 0.1;
            false
        });
    }
    // the rough lookups' irradiance blend as fitted, or weights rising to 1 where the fit
    // kept none, so the shader's blend is always checked
    let c = g.roughness().cloned().expect("the fit stores a roughness correction");
    if c.irradiance_nodes().is_empty() {
        let n = c.alphas.len();
        let fit = warpfit::roughness::RoughnessFit {
            irradiance_weight: (0..n).map(|i| i as f32 / (n - 1) as f32).collect(),
            ..c.into()
        };
        g = g.with_roughness(Some(warpfit::roughness::RoughnessCorrection::try_from(fit).unwrap()));
    }
    // the blend's smooth read must blend neighbours here, not only each cell alone
    let linked = g.irradiance_sh().links.iter().filter(|l| l.count_ones() > 1).count();
    assert!(linked > g.irradiance_sh().links.len() / 2, "only {linked} cells link to a neighbour");
    check_grid("torture", &g);
    // blended near cell faces, the irradiance blend too (each near cell's read)
    let faces = g.clone().with_lookup(|_, blend, _| *blend = warpfit::warp::corrective::Blend::Faces);
    check_grid("torture-faces", &faces);
    // exported to read probe A alone, the shader answers as the grid read so
    check_grid("torture-probe-only", &g.with_read(warpfit::runtime::SpecularRead::ProbeOnly));
}

#[test]
fn the_baseline_kernels_answer_as_the_cpu_methods() {
    let Some(gpu) = gpu() else { return };
    let g = FittedGrid::load(torture_fit()).unwrap();
    let dir = tmp_dir("gpu-export-baselines");
    warpfit::export::export(&g, &dir).unwrap();
    let lookup = Lookup::load(gpu, &dir, Pipeline::Generic);
    let q = queries(&g, 2000);
    let floor = 1e-3 * mean_radiance(&g);
    for (kernel, method) in
        [("warp1_queries", warpfit::warp::Method::Warp1), ("box_queries", warpfit::warp::Method::Box)]
    {
        let shader = lookup.run(gpu, kernel, &q);
        let cpu = on_cpu(&q, |b, d, _| match (warpfit::octa::unit_direction(d), b.is_finite()) {
            (Some(d), true) => g.warp().lookup(method, b, d),
            (Some(d), false) => g.warp().probe.radiance(d),
            (None, _) => Vec3::ZERO,
        });
        assert_agrees(kernel, &shader, &cpu, floor, &q);
    }
}

/// Samples `atlas` with hardware bilinear at texel coordinates `xy` (the sidecar's uv rule).
const FILTER_KERNEL: &str = r#"
@group(0) @binding(0) var atlas: texture_2d<f32>;
@group(0) @binding(1) var linear: sampler;
@group(0) @binding(2) var<storage, read> coords: array<vec2<f32>>;
@group(0) @binding(3) var<storage, read_write> out: array<vec4<f32>>;
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    if id.x >= arrayLength(&out) {
        return;
    }
    let size = vec2<f32>(textureDimensions(atlas));
    out[id.x] = textureSampleLevel(atlas, linear, coords[id.x] / size, 0.0);
}
"#;

fn hardware_filtered(gpu: &Gpu, texture: &wgpu::Texture, coords: &[Vec2]) -> Vec<[f32; 4]> {
    use wgpu::util::DeviceExt as _;
    let d = &gpu.device;
    let module = d.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some("filter"),
        source: wgpu::ShaderSource::Wgsl(FILTER_KERNEL.into()),
    });
    let pipeline = d.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("filter"),
        layout: None,
        module: &module,
        entry_point: Some("main"),
        compilation_options: Default::default(),
        cache: None,
    });
    let sampler = d.create_sampler(&wgpu::SamplerDescriptor {
        mag_filter: wgpu::FilterMode::Linear,
        min_filter: wgpu::FilterMode::Linear,
        ..Default::default()
    });
    let bytes: Vec<u8> = coords.iter().flat_map(|c| [c.x, c.y]).flat_map(f32::to_le_bytes).collect();
    let input = d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: None,
        contents: &bytes,
        usage: wgpu::BufferUsages::STORAGE,
    });
    let size = (coords.len() * 16) as u64;
    let out = d.create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let staging = d.create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let view = texture.create_view(&Default::default());
    let group = d.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&view) },
            wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::Sampler(&sampler) },
            wgpu::BindGroupEntry { binding: 2, resource: input.as_entire_binding() },
            wgpu::BindGroupEntry { binding: 3, resource: out.as_entire_binding() },
        ],
    });
    let mut enc = d.create_command_encoder(&Default::default());
    {
        let mut pass = enc.begin_compute_pass(&Default::default());
        pass.set_pipeline(&pipeline);
        pass.set_bind_group(0, &group, &[]);
        pass.dispatch_workgroups(coords.len().div_ceil(64) as u32, 1, 1);
    }
    enc.copy_buffer_to_buffer(&out, 0, &staging, 0, size);
    gpu.queue.submit([enc.finish()]);
    gpu.read_vec4s(&staging)
}

/// The hardware filter's weights carry `SUBTEXEL_BITS` bits (Vulkan's
/// `subTexelPrecisionBits`: 8 on lavapipe and on current desktop GPUs, at least 4 by the
/// specification), so a filtered value may differ from exact bilinear by up to
/// 2·2⁻⁽ᵇⁱᵗˢ⁺¹⁾ of the spread of the four texels it blends.
const SUBTEXEL_BITS: i32 = 8;

#[test]
fn hardware_bilinear_of_the_exported_atlases_is_the_cpu_seam_aware_bilinear() {
    let Some(gpu) = gpu() else { return };
    let g = FittedGrid::load(torture_fit()).unwrap();
    let dir = tmp_dir("gpu-export-filter");
    let s = warpfit::export::export(&g, &dir).unwrap();
    let ir = &g.irradiance_grid();
    let n = ir.resolution;
    let n2 = (n * n) as usize;
    let tiles = ir.irradiance.len() / n2;
    let layout = &s.irradiance;
    let texture = gpu_harness::ktx2_texture(gpu, &dir.join(&layout.file));
    let (mut coords, mut expected, mut spread) = (Vec::new(), Vec::new(), Vec::new());
    for q in 0..4000u32 {
        let mut smp = Sampler::new(41, 0, q);
        let tile = (smp.next_1d() * tiles as f32) as usize % tiles;
        // uv everywhere, the edges and corners (the seams) included
        let uv = Vec2::new(smp.next_1d(), smp.next_1d()) * 1.02 - 0.01;
        let uv = uv.clamp(Vec2::ZERO, Vec2::ONE);
        let (x0, y0) = ((tile as u32 % layout.columns) * (n + 2), (tile as u32 / layout.columns) * (n + 2));
        coords.push(Vec2::new(x0 as f32 + 1.0 + uv.x * n as f32, y0 as f32 + 1.0 + uv.y * n as f32));
        // the CPU's seam-aware bilinear of the tile as exported (half floats)
        let texels: Vec<Vec3> = ir.irradiance[tile * n2..(tile + 1) * n2]
            .iter()
            .map(|v| v.to_array().map(|x| half::f16::from_f32(x).to_f32()).into())
            .collect();
        let taps = warpfit::octa::bilinear_taps(n, uv);
        expected.push(warpfit::octa::OctMap::new(n, texels.clone()).bilinear_uv(uv));
        let (lo, hi) = taps.iter().fold((Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)), |(lo, hi), &(t, _)| {
            (lo.min(texels[t as usize]), hi.max(texels[t as usize]))
        });
        spread.push(hi - lo);
    }
    let got = hardware_filtered(gpu, &texture, &coords);
    let step = 2.0f32.powi(-SUBTEXEL_BITS);
    let mut worst = 0.0f32;
    for k in 0..coords.len() {
        let gv = Vec3::new(got[k][0], got[k][1], got[k][2]);
        let tol = spread[k] * step + expected[k].abs() * 1e-6 + Vec3::splat(1e-9);
        assert!(
            (gv - expected[k]).abs().cmple(tol).all(),
            "texel {:?}: hardware {gv} vs CPU {} (tolerance {tol})",
            coords[k],
            expected[k]
        );
        worst = worst.max(((gv - expected[k]).abs() / spread[k].max(Vec3::splat(1e-9))).max_element());
    }
    eprintln!(
        "hardware bilinear of the irradiance atlas: worst difference {worst:.2e} of the texels' spread ({})",
        gpu.adapter.name
    );
}

#[test]
fn every_fallback_blend_and_relaxation_answers_as_the_cpu_sampler() {
    // the torture grid re-exported with each proxy, corrective blend and UV relaxation the
    // format can hold, and without a roughness correction (the CPU sampler reads the same
    // settings; a map fitted for the box, read through the k-DOP, is a different lookup but
    // still one both must answer alike)
    use warpfit::warp::Method;
    use warpfit::warp::corrective::Blend;
    let Some(gpu) = gpu() else { return };
    let base = FittedGrid::load(torture_fit()).unwrap();
    let q = queries(&base, 1500);
    let floor = 1e-3 * mean_radiance(&base);
    let variants = [Method::Warp1, Method::Box, Method::Kdop]
        .into_iter()
        .flat_map(|f| [Blend::Cell, Blend::Trilinear, Blend::Faces].map(|b| (f, b)))
        .flat_map(|(f, b)| [0.0, 0.7].map(|r| (f, b, r, true)))
        // and once without a roughness correction (the plain mip of r)
        .chain([(Method::Box, Blend::Cell, 0.0, false)]);
    for (fallback, blend, relax, correction) in variants {
        let mut g = base.clone().with_lookup(|w, b, c| {
            c.fallback = fallback;
            *b = blend;
            w.options.relax_texels = relax;
        });
        if !correction {
            g = g.with_roughness(None);
        }
        let dir = tmp_dir("gpu-export-variant");
        warpfit::export::export(&g, &dir).unwrap();
        let cpu = on_cpu(&q, |p, d, r| g.specular(p, d, r));
        for pipeline in [Pipeline::Generic, Pipeline::Specialised] {
            let shader = Lookup::load(gpu, &dir, pipeline).run(gpu, "specular_queries", &q);
            let what =
                format!("{} / {blend:?} / relax {relax} / correction {correction} / {pipeline:?}", fallback.name());
            assert_agrees(&what, &shader, &cpu, floor, &q);
        }
    }
}

/// Seed 003's surface-probe atlas through the shader's `surface_specular` and
/// `surface_specular_warped` (group 2 only, as a renderer shading just that surface binds
/// it) agrees with `SurfaceAtlas::radiance` and `radiance_warped` on
/// points on, beside and off a lit torture floor, every roughness bucket and random ones,
/// directions above and below the surface, and the degenerate queries (at a probe, zero and
/// NaN directions, NaN and infinite positions, roughness NaN, < 0 and > 1).
#[test]
fn the_surface_shader_answers_as_the_cpu_atlas() {
    let Some(gpu) = gpu() else { return };
    let scene = load("torture");
    let spec = warpfit::scene::SurfaceProbeSpec {
        corner: Vec3::new(-5.5, 0.0, -5.5),
        edge_u: Vec3::new(0.0, 0.0, 11.0),
        edge_v: Vec3::new(11.0, 0.0, 0.0),
        counts: [10, 7],
        resolution: 8,
        samples_per_texel: 2,
    };
    let tracer = warpfit::trace::Tracer::new(&scene);
    let renderer = warpfit::trace::Renderer::new(&scene, &tracer);
    let quiet = warpfit::progress::Progress::quiet();
    let (atlas, _) = warpfit::bake::surface::bake_surface_atlas(&renderer, &spec, 0, 1, &quiet);
    let g = FittedGrid::load(repo().join("fits/tiny")).unwrap();
    let dir = tmp_dir("gpu-export-surface");
    warpfit::export::export_with_surfaces(&g, std::slice::from_ref(&atlas), &dir).unwrap();
    let lookup = gpu_harness::SurfaceLookup::load(gpu, &dir, 0);

    let mut q = Vec::new();
    let mut push = |p: Vec3, d: Vec3, r: f32| {
        q.push([p.x, p.y, p.z, r]);
        q.push([d.x, d.y, d.z, 0.0]);
    };
    for k in 0..6000u32 {
        let mut s = Sampler::new(37, 0, k);
        // (s, t) over the patch and 10% beyond each edge, a little above the floor
        let (u, v) = (s.next_1d() * 1.2 - 0.1, s.next_1d() * 1.2 - 0.1);
        let p = spec.corner + spec.edge_u * u + spec.edge_v * v + Vec3::Y * (0.01 * s.next_1d());
        let d = uniform_sphere(s.next_2d()) * (0.5 + 2.0 * s.next_1d());
        let r = [0.0, 0.125, 0.25, 0.5, 0.75, 1.0, s.next_1d()][k as usize % 7];
        push(p, d, r);
    }
    let at_probe = atlas.probe_position(3, 2);
    let centre = spec.corner + (spec.edge_u + spec.edge_v) * 0.5;
    let (nan, inf) = (f32::NAN, f32::INFINITY);
    for (k, d) in [Vec3::Y, Vec3::new(0.3, 0.2, 0.9), -Vec3::Y, Vec3::new(1.0, 0.0, 0.0)].into_iter().enumerate() {
        let r = [0.0, 0.3, 1.0, 0.6][k];
        push(at_probe, d, r);
        push(centre, Vec3::ZERO, r);
        push(centre, Vec3::new(nan, d.y, d.z), r);
        push(centre, d * 1e-30, r);
        push(Vec3::new(nan, 0.0, 0.0), d, r);
        push(Vec3::new(inf, 0.0, -inf), d, r);
        push(centre, d, nan);
        push(centre, d, -0.5);
        push(centre, d, 7.0);
    }

    let texels = &atlas.radiance[0];
    let mean = texels.iter().map(|v| v.max_element()).sum::<f32>() / texels.len() as f32;
    let warped = |p, d, r| atlas.radiance_warped(p, d, r);
    let plain = |p, d, r| atlas.radiance(p, d, r);
    type SurfaceFn<'a> = &'a dyn Fn(Vec3, Vec3, f32) -> Vec3;
    let kernels: [(&str, SurfaceFn); 2] = [("surface_queries", &plain), ("surface_warped_queries", &warped)];
    for (kernel, f) in kernels {
        let shader = lookup.run(gpu, kernel, &q);
        let cpu = on_cpu(&q, f);
        let (worst, at) = assert_agrees(kernel, &shader, &cpu, 1e-3 * mean, &q);
        eprintln!("{kernel}: worst relative difference {worst:.2e} (query {at}) on {} queries", cpu.len());
        for (k, c) in cpu.iter().enumerate() {
            if *c == Vec3::ZERO {
                assert_eq!(shader[k][..3], [0.0; 3], "{kernel}: query {k} must be black");
            }
        }
        assert!(cpu.iter().filter(|c| c.max_element() > 0.0).count() > 5000, "the atlas must be lit");
    }
    // the warp moves lookups: the two kernels must differ somewhere
    let (a, b) = (lookup.run(gpu, "surface_queries", &q), lookup.run(gpu, "surface_warped_queries", &q));
    assert!(a.iter().zip(&b).filter(|(x, y)| x != y).count() > 1000, "the warped lookup must warp");
}

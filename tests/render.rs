//! Frames drawn the way an engine draws them (`warpfit render`): the level rasterised with
//! wgpu (Mesa's lavapipe in CI) and every pixel shaded by the exported shader's
//! `surface_fragment`. Each shaded pixel answers its query as the CPU sampler does, within
//! the f16 texels' bound (see tests/gpu.rs); the pixels are the CPU-drawn views' (the same
//! surface points and reflected rays, exact spheres included), and the command writes its
//! frames, figures and strips, refusing bad arguments by name.

mod common;

use common::*;
use glam::Vec3;
use std::path::Path;
use std::process::Command;
use warpfit::perceptual::{self, CameraPose};
use warpfit::render::frames::{self, RenderOptions};
use warpfit::render::gpu::Gpu;
use warpfit::render::{Camera, Rasteriser, Shading};
use warpfit::runtime::FittedGrid;

/// The adapter, or the test's failure (in CI) / skip (elsewhere) with the reason.
fn gpu() -> Option<&'static Gpu> {
    static G: std::sync::OnceLock<Result<Gpu, String>> = std::sync::OnceLock::new();
    match G.get_or_init(|| Gpu::new().map_err(|e| e.to_string())) {
        Ok(g) => Some(g),
        Err(e) => {
            tool_missing("frames drawn through the shader", "a graphics adapter", e);
            None
        }
    }
}

/// The lit torture grid of tests/gpu.rs, its scene, and its export.
struct Fitted {
    torture: SmallTorture,
    grid: FittedGrid,
    export: TestDir,
    _dir: TestDir,
}

fn fitted() -> &'static Fitted {
    static F: std::sync::OnceLock<Fitted> = std::sync::OnceLock::new();
    F.get_or_init(|| {
        let dir = fixture_dir("render-torture");
        let torture = SmallTorture::fit_into(&dir);
        let grid = FittedGrid::load(&dir).unwrap();
        let export = fixture_dir("render-export");
        warpfit::export::export(&grid, &export).unwrap();
        Fitted { torture, grid, export, _dir: dir }
    })
}

/// The placed cameras, and one from the grid's centre looking at the first sphere (the
/// spheres are drawn as exact intersections, not triangles).
fn cameras(f: &Fitted, size: (u32, u32)) -> Vec<Camera> {
    let opts = RenderOptions { size, cameras: 2, ..Default::default() };
    let mut out = frames::cameras(&f.torture.scene, &f.torture.tracer, &f.grid, &opts);
    let geo = &f.grid.irradiance_grid().geometry;
    let eye = (geo.min + geo.max) * 0.5;
    let s = &f.torture.scene.spheres;
    assert!(!s.is_empty(), "torture has spheres");
    let forward = (s.center[0] - eye).normalize();
    out.push(Camera { pose: CameraPose { eye, forward }, fov_deg: 60.0, size });
    out
}

fn relative(a: Vec3, b: Vec3, floor: f32) -> f32 {
    (a - b).abs().max_element() / b.abs().max_element().max(floor)
}

#[test]
fn every_shaded_pixel_answers_its_query_as_the_cpu_sampler_does() {
    let Some(gpu) = gpu() else { return };
    let f = fitted();
    // white materials: a diffuse pixel is irradiance / π, the CPU's answer at its query
    let mut white = f.torture.scene.clone();
    for m in &mut white.materials {
        m.albedo = Vec3::ONE;
    }
    let raster = Rasteriser::new(gpu, &f.export, &white, &f.torture.tracer).unwrap();
    let mean = {
        let t = &f.grid.warp().probe.radiance.levels[0].texels;
        t.iter().map(|v| v.max_element()).sum::<f32>() / t.len() as f32
    };
    let mut sphere_pixels = 0;
    for camera in cameras(f, (64, 40)) {
        let rays = camera.pose.rays(camera.fov_deg, camera.size);
        for shading in [Shading::Specular(0.0), Shading::Specular(0.4), Shading::Specular(1.0), Shading::Diffuse] {
            let frame = raster.draw(&white, &camera, shading);
            assert_eq!(frame.radiance.len(), 64 * 40);
            let queries = raster.queries(&camera, shading);
            assert_eq!(
                queries.iter().map(|q| q.map(|q| q.0)).collect::<Vec<_>>(),
                frame.points,
                "the query draw shades the frame's points"
            );
            let mut shaded = 0;
            for (p, q) in queries.iter().enumerate() {
                let c = frame.radiance[p];
                assert!(c.is_finite() && c.min_element() >= 0.0, "{shading:?} pixel {p}: {c}");
                let Some((b, dir)) = *q else {
                    // sky where nothing is drawn, black on a back face
                    let sky = white.sky.radiance(rays[p]);
                    assert!(c == sky || c == Vec3::ZERO, "{shading:?} pixel {p}: {c} is neither sky nor black");
                    continue;
                };
                shaded += 1;
                let cpu = match shading {
                    Shading::Specular(r) => f.grid.specular(b, dir, r),
                    Shading::Diffuse => f.grid.irradiance(b, dir) * std::f32::consts::FRAC_1_PI,
                };
                let rel = relative(c, cpu, 1e-3 * mean);
                assert!(rel <= 1e-3, "{shading:?} pixel {p}: shader {c} vs CPU {cpu} at ({b}, {dir})");
            }
            assert!(shaded > 64 * 40 / 2, "{shading:?}: only {shaded} pixels shaded");
        }
        sphere_pixels += rays
            .iter()
            .filter(|&&d| f.torture.tracer.closest_hit(camera.pose.eye, d, f32::INFINITY).is_some_and(|h| h.sphere))
            .count();
    }
    eprintln!("{sphere_pixels} pixels show a sphere");
    assert!(sphere_pixels > 50, "the cameras must see the spheres ({sphere_pixels} pixels)");
}

#[test]
fn the_rasterised_pixels_are_the_cpu_drawn_views() {
    let Some(gpu) = gpu() else { return };
    let f = fitted();
    let (scene, tracer) = (&f.torture.scene, &f.torture.tracer);
    let raster = Rasteriser::new(gpu, &f.export, scene, tracer).unwrap();
    let size = (96, 60);
    let diagonal = {
        let (lo, hi) = scene.bounds();
        (hi - lo).length()
    };
    for camera in cameras(f, size) {
        let settings =
            perceptual::RenderSettings { camera: size, fov_deg: camera.fov_deg, ..perceptual::RenderSettings::quick() };
        let view = perceptual::camera_view(scene, tracer, &f.grid.warp().probe_positions(), &camera.pose, &settings);
        let (points, dirs) = view.queries();
        let frame = raster.queries(&camera, Shading::Specular(0.0));
        // the same surface point and reflected ray, but where a pixel's centre grazes an
        // edge or a silhouette (the rasteriser's coverage rule and the tracer's watertight
        // test may pick the other side)
        let (mut both, mut same) = (0, 0);
        for (p, q) in frame.iter().enumerate() {
            if let (Some((b, d)), true) = (q, dirs[p] != Vec3::ZERO) {
                both += 1;
                if (*b - points[p]).length() <= 1e-4 * diagonal && d.dot(dirs[p]) >= 1.0 - 1e-4 {
                    same += 1;
                }
            }
        }
        let shaded_cpu = dirs.iter().filter(|d| **d != Vec3::ZERO).count();
        eprintln!(
            "camera at {}: {both} of the CPU's {shaded_cpu} shaded pixels drawn, {same} asking its query",
            camera.pose.eye
        );
        assert!(both as f64 >= 0.98 * shaded_cpu as f64, "{both} of the CPU's {shaded_cpu} shaded pixels drawn");
        assert!(same as f64 >= 0.98 * both as f64, "only {same} of {both} pixels ask the CPU's query");
    }
}

#[test]
fn render_writes_frames_figures_and_strips_beside_the_references() {
    let Some(_) = gpu() else { return };
    let f = fitted();
    let out = tmp_dir("render-frames");
    let opts = RenderOptions { size: (64, 40), cameras: 1, roughness: vec![0.0, 0.5], spp: 8, ..Default::default() };
    let r = frames::render((&f.torture.scene, &f.torture.tracer), &f.grid, &f.export, &out, &opts).unwrap();
    assert_eq!(r.frames.len(), 3, "two specular frames and a diffuse one");
    for fr in &r.frames {
        assert!(fr.agreement.within_bound >= 0.97, "{}: {:?}", fr.image, fr.agreement);
        assert!((fr.flip.shader - fr.flip.cpu).abs() <= 0.01, "{}: {:?}", fr.image, fr.flip);
        assert!(fr.flip.shader > 0.0 && fr.flip.shader < 1.0);
        assert_eq!(fr.flip.box_projection.is_some(), fr.roughness.is_some());
        let img = image::open(out.join(&fr.image)).unwrap();
        assert_eq!((img.width(), img.height()), (4 * 64 + 3 * 4, 40), "reference | shader | box | ꟻLIP");
    }
    let json: serde_json::Value = serde_json::from_slice(&std::fs::read(out.join("render.json")).unwrap()).unwrap();
    assert_eq!(json["frames"].as_array().unwrap().len(), 3);
    assert!(std::fs::read_to_string(out.join("render.md")).unwrap().contains("| specular r = 0.5 |"));
}

fn warpfit(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_warpfit")).args(args).current_dir(repo()).output().expect("warpfit runs")
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap().flatten() {
        std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
    }
}

#[test]
fn the_render_command_draws_a_committed_grid_and_names_what_is_wrong() {
    let Some(_) = gpu() else { return };
    let run = tmp_dir("render-cli");
    copy_dir(&repo().join("fits/tiny"), &run);
    let out = run.to_str().unwrap();
    let scene = "data/scenes/tiny.toml";
    let o = warpfit(&["render", "--scene", scene, "--out", out, "--size", "48x32", "--spp", "4", "--cameras", "1"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("render.json"), "{stdout}");
    for f in [
        "render/render.json",
        "render/render.md",
        "render/frame_c0_r0.png",
        "render/frame_c0_diffuse.png",
        "render/export/warpfit.wgsl",
    ] {
        assert!(run.join(f).is_file(), "{f} written");
    }
    // no grid in the folder, a bad size, a roughness out of range: named, no panic
    let empty = tmp_dir("render-empty");
    let cases: [(&[&str], &str); 3] = [
        (&["--out", empty.to_str().unwrap()], "no fitted grid to draw"),
        (&["--out", out, "--size", "0x10"], "from 1 to 4096"),
        (&["--out", out, "--roughness", "0,2"], "--roughness 2"),
    ];
    for (args, want) in cases {
        let mut all = vec!["render", "--scene", scene];
        all.extend_from_slice(args);
        let o = warpfit(&all);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && stderr.contains(want), "{args:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{args:?}: {stderr}");
    }
}

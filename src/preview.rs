//! PNG previews a person can open: tone-mapped radiance (auto exposure, Reinhard, sRGB) and
//! log-scaled distance (misses in sky blue). Previews are for looking, never for reading back.

use crate::bake::Bake;
use crate::files::{FileError, write_atomic};
use glam::Vec3;
use std::path::Path;

/// Log-scaled distance preview: near is white, far is dark, misses are sky blue.
pub fn distance_pixels(dist: &[f32]) -> Vec<u8> {
    let finite: Vec<f32> = dist.iter().copied().filter(|d| d.is_finite() && *d > 0.0).collect();
    let lo = finite.iter().copied().fold(f32::INFINITY, f32::min);
    let hi = finite.iter().copied().fold(0.0f32, f32::max);
    let span = libm::logf(hi / lo.max(1e-30)).max(1e-6);
    let mut out = Vec::with_capacity(dist.len() * 3);
    for &d in dist {
        if !d.is_finite() {
            out.extend([110, 160, 235]);
        } else {
            let t = (libm::logf(d.max(lo) / lo) / span).clamp(0.0, 1.0);
            let g = (255.0 * (1.0 - 0.85 * t)) as u8;
            out.extend([g, g, g]);
        }
    }
    out
}

/// Encodes RGB8 pixels as PNG and writes it atomically.
pub fn write_png(path: &Path, width: u32, height: u32, rgb: &[u8]) -> Result<(), FileError> {
    let mut bytes = Vec::new();
    let enc = image::codecs::png::PngEncoder::new(&mut bytes);
    image::ImageEncoder::write_image(enc, rgb, width, height, image::ExtendedColorType::Rgb8)
        .map_err(|e| FileError::Invalid { path: path.to_path_buf(), field: "png".into(), message: e.to_string() })?;
    write_atomic(path, &bytes)
}

/// `probe_radiance.png` (mips side by side), `probe_distance.png`, `grid_irradiance.png`.
pub fn write_bake_previews(dir: &Path, bake: &Bake) -> Result<(), FileError> {
    let levels = &bake.probe.radiance.levels;
    let n = levels[0].res as usize;
    let exposure = crate::tonemap::key_exposure(&levels[0].texels);
    // Mip strip: level 0 at full size, then each further level upscaled (nearest) to n.
    let width = n * levels.len();
    let mut strip = vec![Vec3::ZERO; width * n];
    for (m, level) in levels.iter().enumerate() {
        let r = level.res as usize;
        for y in 0..n {
            for x in 0..n {
                strip[y * width + m * n + x] = level.texels[(y * r / n) * r + x * r / n];
            }
        }
    }
    write_png(&dir.join("probe_radiance.png"), width as u32, n as u32, &crate::tonemap::to_srgb8(&strip, exposure))?;
    let d = &bake.probe.depth.levels[0];
    write_png(&dir.join("probe_distance.png"), d.res, d.res, &distance_pixels(&d.texels))?;
    let g = &bake.grid;
    let r = g.irradiance_resolution as usize;
    let (nx, ny, nz) = (g.geometry.counts.x as usize, g.geometry.counts.y as usize, g.geometry.counts.z as usize);
    let (w, h) = (nx * r, ny * nz * r);
    let mut atlas = vec![Vec3::ZERO; w * h];
    for cell in 0..g.geometry.cell_count() {
        let c = g.geometry.cell_coords(cell);
        let (tx, ty) = (c.x as usize, c.y as usize + ny * c.z as usize);
        for j in 0..r {
            for i in 0..r {
                atlas[(ty * r + j) * w + tx * r + i] = g.irradiance[cell * r * r + j * r + i];
            }
        }
    }
    let e = crate::tonemap::key_exposure(&atlas);
    write_png(&dir.join("grid_irradiance.png"), w as u32, h as u32, &crate::tonemap::to_srgb8(&atlas, e))
}

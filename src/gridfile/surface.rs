//! The surface-probe atlas folder (`warpfit-surface`, see the runtime's reader) and its
//! writer.

pub use warpfit_runtime::gridfile::surface::*;

use super::schema::Payload;
use crate::files::FileError;
use crate::warp::surface::SurfaceAtlas;
use std::path::Path;

/// Writes `atlas` into the folder `dir` (created if needed), payload first, manifest last,
/// each atomically. Returns the manifest.
pub fn write(dir: &Path, atlas: &SurfaceAtlas) -> Result<SurfaceManifest, FileError> {
    use super::exr::ExrLayer as Layer;
    use super::schema::{LayerEntry, Precision};
    std::fs::create_dir_all(dir).map_err(FileError::io(dir))?;
    let p = &atlas.patch;
    let (w, h) = ((p.counts[0] * p.resolution) as usize, (p.counts[1] * p.resolution) as usize);
    let mut layers = Vec::new();
    for (m, level) in atlas.radiance.iter().enumerate() {
        let image = atlas.packed(level);
        let channel = |c: usize| image.iter().map(|v| v[c]).collect::<Vec<f32>>();
        layers.push(Layer {
            name: radiance_layer(m),
            width: w,
            height: h,
            channels: vec![("R".into(), channel(0)), ("G".into(), channel(1)), ("B".into(), channel(2))],
        });
    }
    layers.push(Layer {
        name: "inv_distance".into(),
        width: w,
        height: h,
        channels: vec![("W".into(), atlas.packed(&atlas.inv_distance))],
    });
    let entries = layers.iter().map(|l| LayerEntry::of(l, Precision::F32)).collect();
    let path = dir.join(SURFACE_ATLAS_FILE);
    let (bytes, checksum) = super::exr::write_payload(&path, layers, |_| false)?;
    let manifest = SurfaceManifest {
        format: SURFACE_FORMAT.into(),
        version: SURFACE_VERSION,
        surface: SurfaceDescription::of(atlas),
        payload: Payload { file: SURFACE_ATLAS_FILE.into(), bytes, checksum, layers: entries },
    };
    crate::files::write_json(&dir.join(SURFACE_MANIFEST), &manifest)?;
    Ok(manifest)
}

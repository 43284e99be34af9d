//! EXR layers as plain data: named layers of named f32 channels. Decoding is always built
//! (the runtime loader reads payloads with it); encoding (ZIP, lossless, so distances
//! survive bit-exactly; radiance optionally f16) is part of the offline tool. The bake
//! folder's EXR files use the same codec.
//!
//! The exr crate panics when a channel's sample count does not match its layer size, so
//! sizes are validated here first; decoding validates the same on the way in.

use crate::files::FileError;
use std::path::Path;

/// One layer: `width × height` pixels, row 0 first, each channel a flat row-major array.
#[derive(Clone, Debug, PartialEq)]
pub struct ExrLayer {
    pub name: String,
    pub width: usize,
    pub height: usize,
    pub channels: Vec<(String, Vec<f32>)>,
}

impl ExrLayer {
    /// The samples of channel `name`.
    #[must_use]
    pub fn channel(&self, name: &str) -> Option<&[f32]> {
        self.channels.iter().find(|(n, _)| n == name).map(|(_, v)| v.as_slice())
    }
}

/// Largest finite f16: radiance above it keeps its layer in f32.
pub const F16_MAX: f32 = 65504.0;

/// Decodes every layer of EXR bytes (largest resolution level, flat samples as f32); `path`
/// only names the file in errors.
pub fn decode(path: &Path, bytes: &[u8]) -> Result<Vec<ExrLayer>, FileError> {
    use exr::prelude::{ReadChannels, ReadLayers, read};
    let image = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .all_layers()
        .all_attributes()
        .non_parallel()
        .from_buffered(std::io::Cursor::new(bytes))
        .map_err(|e| FileError::Exr { path: path.to_path_buf(), message: e.to_string() })?;
    let mut out = Vec::new();
    for layer in image.layer_data {
        let name = layer.attributes.layer_name.as_ref().map(|n| n.to_string()).unwrap_or_default();
        let (width, height) = (layer.size.0, layer.size.1);
        let mut channels = Vec::new();
        for ch in layer.channel_data.list {
            let v: Vec<f32> = ch.sample_data.values_as_f32().collect();
            if v.len() != width * height {
                return Err(FileError::invalid(path, format!("{name}.{}", ch.name), "wrong sample count"));
            }
            channels.push((ch.name.to_string(), v));
        }
        out.push(ExrLayer { name, width, height, channels });
    }
    Ok(out)
}

/// Encodes layers into EXR bytes; layers for which `half(name)` holds are stored as f16
/// (values clamped to ±65504 first, so nothing becomes +inf; the grid writer only asks for
/// f16 where every value fits).
#[cfg(feature = "bake")]
pub fn encode(path: &Path, layers: Vec<ExrLayer>, half: impl Fn(&str) -> bool) -> Result<Vec<u8>, FileError> {
    let mut bytes = Vec::new();
    encode_into(path, layers, half, std::io::Cursor::new(&mut bytes))?;
    Ok(bytes)
}

/// Writes the payload `path` atomically from `layers` ([`encode`]'s layout), the encoder
/// writing straight into the temporary file, so no encoded copy of the payload is held in
/// memory; returns its length and checksum for the manifest.
#[cfg(feature = "bake")]
pub fn write_payload(
    path: &Path,
    layers: Vec<ExrLayer>,
    half: impl Fn(&str) -> bool,
) -> Result<(u64, String), FileError> {
    crate::files::write_atomic_with(path, |f| encode_into(path, layers, half, f))
}

/// [`encode`] into `out`.
#[cfg(feature = "bake")]
fn encode_into(
    path: &Path,
    layers: Vec<ExrLayer>,
    half: impl Fn(&str) -> bool,
    out: impl std::io::Write + std::io::Seek,
) -> Result<(), FileError> {
    use exr::prelude::*;
    let bad = |m: String| FileError::invalid(path, "layers", m);
    if layers.is_empty() {
        return Err(bad("no layers to write".into()));
    }
    let mut exr_layers = Vec::with_capacity(layers.len());
    let (mut max_w, mut max_h) = (1usize, 1usize);
    for l in &layers {
        if l.width == 0 || l.height == 0 || l.channels.is_empty() {
            return Err(bad(format!("layer {:?} is empty", l.name)));
        }
        for (c, v) in &l.channels {
            if v.len() != l.width * l.height {
                return Err(bad(format!(
                    "layer {:?} channel {c:?} has {} samples, expected {}",
                    l.name,
                    v.len(),
                    l.width * l.height
                )));
            }
        }
    }
    // the layers' samples move into the encoder: no copy of a payload is made
    for l in layers {
        max_w = max_w.max(l.width);
        max_h = max_h.max(l.height);
        let to_half = half(&l.name);
        let samples = |v: Vec<f32>| {
            if to_half {
                FlatSamples::F16(v.iter().map(|&x| f16::from_f32(x.clamp(-F16_MAX, F16_MAX))).collect())
            } else {
                FlatSamples::F32(v)
            }
        };
        let channels: SmallVec<[AnyChannel<FlatSamples>; 4]> =
            l.channels.into_iter().map(|(name, v)| AnyChannel::new(name.as_str(), samples(v))).collect();
        exr_layers.push(Layer::new(
            (l.width, l.height),
            LayerAttributes::named(l.name.as_str()),
            Encoding::SMALL_LOSSLESS,
            AnyChannels::sort(channels),
        ));
    }
    let image = Image::from_layers(ImageAttributes::new(IntegerBounds::from_dimensions((max_w, max_h))), exr_layers);
    image.write().to_unbuffered(out).map_err(|e| FileError::Exr { path: path.to_path_buf(), message: e.to_string() })
}

/// Writes layers (all f32) to `path` atomically; returns the bytes written.
#[cfg(feature = "bake")]
pub fn write(path: &Path, layers: &[ExrLayer]) -> Result<u64, FileError> {
    Ok(write_payload(path, layers.to_vec(), |_| false)?.0)
}

/// Reads every layer of an EXR file as f32 channels.
#[cfg(feature = "bake")]
pub fn read(path: &Path) -> Result<Vec<ExrLayer>, FileError> {
    let bytes = std::fs::read(path).map_err(FileError::io(path))?;
    decode(path, &bytes)
}

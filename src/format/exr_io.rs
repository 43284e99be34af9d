//! Multi-layer f32 EXR payloads: named layers of named channels, ZIP compressed (lossless, so
//! distances survive bit-exactly), written through [`write_atomic`](super::write_atomic).
//!
//! The exr crate panics when a channel's sample count does not match its layer size, so sizes
//! are validated here first; reading validates the same on the way in.

use super::FormatError;
use exr::prelude::*;
use std::path::Path;

pub use crate::runtime::exr_layers::ExrLayer;

impl ExrLayer {
    pub fn channel(&self, name: &str) -> Option<&[f32]> {
        self.channels.iter().find(|(n, _)| n == name).map(|(_, v)| v.as_slice())
    }
}

/// Encodes layers into EXR bytes (all f32).
pub fn encode_exr(path: &Path, layers: &[ExrLayer]) -> std::result::Result<Vec<u8>, FormatError> {
    encode_exr_with(path, layers, |_| false)
}

/// Encodes layers into EXR bytes; layers for which `half(name)` holds are stored as f16
/// (values clamped to ±65504 first, so a bright sun saturates instead of becoming +inf).
pub fn encode_exr_with(
    path: &Path,
    layers: &[ExrLayer],
    half: impl Fn(&str) -> bool,
) -> std::result::Result<Vec<u8>, FormatError> {
    let bad = |m: String| FormatError::Invalid { path: path.to_path_buf(), field: "layers".into(), message: m };
    if layers.is_empty() {
        return Err(bad("no layers to write".into()));
    }
    let mut exr_layers = Vec::with_capacity(layers.len());
    let (mut max_w, mut max_h) = (1usize, 1usize);
    for l in layers {
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
        max_w = max_w.max(l.width);
        max_h = max_h.max(l.height);
        let to_half = half(&l.name);
        let samples = |v: &Vec<f32>| {
            if to_half {
                FlatSamples::F16(v.iter().map(|&x| f16::from_f32(x.clamp(-65504.0, 65504.0))).collect())
            } else {
                FlatSamples::F32(v.clone())
            }
        };
        let channels: SmallVec<[AnyChannel<FlatSamples>; 4]> =
            l.channels.iter().map(|(name, v)| AnyChannel::new(name.as_str(), samples(v))).collect();
        exr_layers.push(Layer::new(
            (l.width, l.height),
            LayerAttributes::named(l.name.as_str()),
            Encoding::SMALL_LOSSLESS,
            AnyChannels::sort(channels),
        ));
    }
    let image = Image::from_layers(ImageAttributes::new(IntegerBounds::from_dimensions((max_w, max_h))), exr_layers);
    let mut bytes = Vec::new();
    image
        .write()
        .to_buffered(std::io::Cursor::new(&mut bytes))
        .map_err(|e| FormatError::Exr { path: path.to_path_buf(), message: e.to_string() })?;
    Ok(bytes)
}

/// Writes layers to `path` atomically.
pub fn write_exr(path: &Path, layers: &[ExrLayer]) -> std::result::Result<u64, FormatError> {
    let bytes = encode_exr(path, layers)?;
    super::write_atomic(path, &bytes).map_err(|source| FormatError::Io { path: path.to_path_buf(), source })?;
    Ok(bytes.len() as u64)
}

/// Reads every layer of an EXR file as f32 channels.
pub fn read_exr(path: &Path) -> std::result::Result<Vec<ExrLayer>, FormatError> {
    let bytes = std::fs::read(path).map_err(|source| FormatError::Io { path: path.to_path_buf(), source })?;
    decode_exr(path, &bytes)
}

/// Decodes EXR bytes (the path only names the file in errors).
pub fn decode_exr(path: &Path, bytes: &[u8]) -> std::result::Result<Vec<ExrLayer>, FormatError> {
    crate::runtime::exr_layers::decode_layers(bytes).map_err(|e| match e.field {
        Some(field) => FormatError::Invalid { path: path.to_path_buf(), field, message: e.message },
        None => FormatError::Exr { path: path.to_path_buf(), message: e.message },
    })
}

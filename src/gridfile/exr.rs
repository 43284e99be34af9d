//! EXR encoding of the offline tool (ZIP, lossless, so distances survive bit-exactly;
//! radiance optionally f16), beside the runtime's decoding (`ExrLayer`, `decode`), which
//! this module re-exports. The bake folder's EXR files use the same codec.

pub use warpfit_runtime::gridfile::exr::*;

use crate::files::FileError;
use std::path::Path;

/// A channel's samples as the encoder reads them: held, or computed from their flat
/// row-major index when the encoder asks for their line. A layer gathered from other arrays
/// (a grid's per-cell maps packed into an atlas) is then never copied whole: the encoder
/// holds one block of lines at a time.
pub enum Samples<'a> {
    Held(Vec<f32>),
    Computed(Box<dyn Fn(usize) -> f32 + Sync + 'a>),
}

impl Samples<'_> {
    /// Sample `i` (row-major).
    #[inline]
    #[must_use]
    pub fn get(&self, i: usize) -> f32 {
        match self {
            Samples::Held(v) => v[i],
            Samples::Computed(f) => f(i),
        }
    }
}

/// A layer the encoder takes: held samples ([`ExrLayer`], what decoding returns) or
/// [`Samples`] already.
pub trait IntoLayer<'a> {
    /// The layer with its channels as [`Samples`].
    fn into_layer(self) -> ExrLayer<Samples<'a>>;
}

impl<'a> IntoLayer<'a> for ExrLayer {
    fn into_layer(self) -> ExrLayer<Samples<'a>> {
        let channels = self.channels.into_iter().map(|(n, v)| (n, Samples::Held(v))).collect();
        ExrLayer { name: self.name, width: self.width, height: self.height, channels }
    }
}

impl<'a> IntoLayer<'a> for ExrLayer<Samples<'a>> {
    fn into_layer(self) -> ExrLayer<Samples<'a>> {
        self
    }
}

/// Encodes layers into EXR bytes; layers for which `half(name)` holds are stored as f16
/// (values clamped to ±65504 first, so nothing becomes +inf; the grid writer only asks for
/// f16 where every value fits).
pub fn encode<'a, L: IntoLayer<'a>>(
    path: &Path,
    layers: impl IntoIterator<Item = L>,
    half: impl Fn(&str) -> bool,
) -> Result<Vec<u8>, FileError> {
    let mut bytes = Vec::new();
    let layers = layers.into_iter().map(IntoLayer::into_layer).collect();
    encode_into(path, layers, half, std::io::Cursor::new(&mut bytes))?;
    Ok(bytes)
}

/// Writes the payload `path` atomically from `layers` ([`encode`]'s layout), the encoder
/// writing straight into the temporary file, so no encoded copy of the payload is held in
/// memory; returns its length and checksum for the manifest.
pub fn write_payload<'a, L: IntoLayer<'a>>(
    path: &Path,
    layers: impl IntoIterator<Item = L>,
    half: impl Fn(&str) -> bool,
) -> Result<(u64, String), FileError> {
    let layers: Vec<ExrLayer<Samples>> = layers.into_iter().map(IntoLayer::into_layer).collect();
    crate::files::write_atomic_with(path, |f| encode_into(path, layers, half, f))
}

/// [`encode`] into `out`.
fn encode_into(
    path: &Path,
    layers: Vec<ExrLayer<Samples>>,
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
            if let Samples::Held(v) = v
                && v.len() != l.width * l.height
            {
                return Err(bad(format!(
                    "layer {:?} channel {c:?} has {} samples, expected {}",
                    l.name,
                    v.len(),
                    l.width * l.height
                )));
            }
        }
    }
    // the layers' samples move into the encoder, which reads them a line at a time: no
    // copy of a payload is made
    for l in layers {
        max_w = max_w.max(l.width);
        max_h = max_h.max(l.height);
        let half = half(&l.name);
        let channels: SmallVec<[AnyChannel<LineSamples>; 4]> = l
            .channels
            .into_iter()
            .map(|(name, samples)| AnyChannel::new(name.as_str(), LineSamples { samples, width: l.width, half }))
            .collect();
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

/// One channel as the exr crate's encoder reads it: a line of samples at a time, as f16
/// (clamped to ±65504 first) or f32.
struct LineSamples<'a> {
    samples: Samples<'a>,
    width: usize,
    half: bool,
}

impl<'s, 'a: 's> exr::image::write::samples::WritableSamples<'s> for LineSamples<'a> {
    type Writer = &'s Self;

    fn sample_type(&self) -> exr::meta::attribute::SampleType {
        if self.half { exr::meta::attribute::SampleType::F16 } else { exr::meta::attribute::SampleType::F32 }
    }

    fn infer_level_modes(&self) -> (exr::meta::attribute::LevelMode, exr::math::RoundingMode) {
        (exr::meta::attribute::LevelMode::Singular, exr::math::RoundingMode::Down)
    }

    fn create_samples_writer(&'s self, _: &exr::meta::header::Header) -> &'s Self {
        self
    }
}

impl exr::image::write::samples::SamplesWriter for &LineSamples<'_> {
    fn extract_line(&self, line: exr::block::lines::LineRefMut<'_>) {
        let start = line.location.position.y() * self.width + line.location.position.x();
        let s = &self.samples;
        let written = if self.half {
            line.write_samples(|i| exr::prelude::f16::from_f32(s.get(start + i).clamp(-F16_MAX, F16_MAX)))
        } else {
            line.write_samples(|i| s.get(start + i))
        };
        // the line's bytes are sized by the encoder for exactly these samples
        written.expect("writing a line of samples into its own buffer");
    }
}

/// Writes layers (all f32) to `path` atomically; returns the bytes written.
pub fn write(path: &Path, layers: &[ExrLayer]) -> Result<u64, FileError> {
    Ok(write_payload(path, layers.iter().cloned(), |_| false)?.0)
}

/// Reads every layer of an EXR file as f32 channels.
pub fn read(path: &Path) -> Result<Vec<ExrLayer>, FileError> {
    let bytes = std::fs::read(path).map_err(FileError::io(path))?;
    decode(path, &bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn layer(name: &str, w: usize, h: usize, f: impl Fn(usize) -> f32) -> ExrLayer {
        let channels =
            vec![("A".into(), (0..w * h).map(&f).collect()), ("B".into(), (0..w * h).map(|i| -f(i)).collect())];
        ExrLayer { name: name.into(), width: w, height: h, channels }
    }

    #[test]
    fn computed_samples_encode_to_the_bytes_of_held_ones() {
        let p = Path::new("test.exr");
        let value = |i: usize| libm::sinf(i as f32 * 0.37) * 1e5;
        let held = vec![layer("x", 37, 21, value), layer("radiance_mip0", 5, 3, |i| i as f32)];
        let computed: Vec<ExrLayer<Samples>> = held
            .iter()
            .map(|l| {
                let channels = l
                    .channels
                    .iter()
                    .map(|(n, v)| {
                        let v = v.clone();
                        (n.clone(), Samples::Computed(Box::new(move |i| v[i])))
                    })
                    .collect();
                ExrLayer { name: l.name.clone(), width: l.width, height: l.height, channels }
            })
            .collect();
        let half = |n: &str| n.starts_with("radiance");
        let a = encode(p, held.clone(), half).unwrap();
        let b = encode(p, computed, half).unwrap();
        assert_eq!(a, b);
        // decoding puts samples where the placement says; f16 layers come back rounded
        let reversed = decode_routed(p, std::io::Cursor::new(&a), |name, _, w, h| {
            Destination::Own((name == "x").then(|| -> Placement { std::sync::Arc::new(move |k| w * h - 1 - k) }))
        })
        .unwrap();
        let x = reversed.iter().find(|l| l.name == "x").unwrap();
        let want: Vec<f32> = (0..37 * 21).rev().map(value).collect();
        assert_eq!(x.channel("A").unwrap(), want.as_slice());
        let plain = decode(p, &a).unwrap();
        for l in &held {
            let got = plain.iter().find(|g| g.name == l.name).unwrap();
            assert_eq!(got, l, "{}", l.name);
        }
    }

    #[test]
    fn an_rgb_sink_gathers_the_placed_triples_and_leaves_the_channels_empty() {
        let p = Path::new("rgb.exr");
        let (w, h) = (5, 3);
        let ch = |c: f32| (0..w * h).map(|i| i as f32 + c / 4.0).collect::<Vec<f32>>();
        let channels = vec![("R".into(), ch(1.0)), ("G".into(), ch(2.0)), ("B".into(), ch(3.0)), ("Z".into(), ch(0.0))];
        let layer = ExrLayer { name: "irr".into(), width: w, height: h, channels };
        let bytes = encode(p, [layer.clone()], |_| false).unwrap();
        let sink = RgbSink::new(w * h, std::sync::Arc::new(move |k| w * h - 1 - k));
        let route = route_to_sinks(sink.sinks("irr"), |_, _, _| None);
        let got = decode_routed(p, std::io::Cursor::new(&bytes), route).unwrap();
        let triples = sink.take();
        for k in 0..w * h {
            let i = w * h - 1 - k;
            assert_eq!(triples[k], glam::Vec3::new(ch(1.0)[i], ch(2.0)[i], ch(3.0)[i]));
        }
        let l = &got[0];
        assert!(l.channel("R").unwrap().is_empty() && l.channel("B").unwrap().is_empty());
        assert_eq!(l.channel("Z").unwrap(), ch(0.0).as_slice(), "a channel without a sink keeps its own array");
    }
}

//! EXR layers as plain data: named layers of named f32 channels. Decoding is always built
//! (the runtime loader reads payloads with it); encoding (ZIP, lossless, so distances
//! survive bit-exactly; radiance optionally f16) is part of the offline tool. The bake
//! folder's EXR files use the same codec.
//!
//! The exr crate panics when a channel's sample count does not match its layer size, so
//! sizes are validated here first; decoding validates the same on the way in.

use crate::files::FileError;
use std::path::Path;

/// One layer: `width × height` pixels, row 0 first, each channel a flat row-major array
/// (`S = Vec<f32>`, what decoding returns) or, for encoding, [`Samples`].
#[derive(Clone, Debug, PartialEq)]
pub struct ExrLayer<S = Vec<f32>> {
    pub name: String,
    pub width: usize,
    pub height: usize,
    pub channels: Vec<(String, S)>,
}

/// A channel's samples as the encoder reads them: held, or computed from their flat
/// row-major index when the encoder asks for their line. A layer gathered from other arrays
/// (a grid's per-cell maps packed into an atlas) is then never copied whole: the encoder
/// holds one block of lines at a time.
#[cfg(feature = "bake")]
pub enum Samples<'a> {
    Held(Vec<f32>),
    Computed(Box<dyn Fn(usize) -> f32 + Sync + 'a>),
}

#[cfg(feature = "bake")]
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

#[cfg(feature = "bake")]
impl<'a> From<ExrLayer> for ExrLayer<Samples<'a>> {
    fn from(l: ExrLayer) -> Self {
        let channels = l.channels.into_iter().map(|(n, v)| (n, Samples::Held(v))).collect();
        ExrLayer { name: l.name, width: l.width, height: l.height, channels }
    }
}

impl<S> ExrLayer<S> {
    /// The names of its channels, in order.
    pub fn channel_names(&self) -> impl Iterator<Item = &str> {
        self.channels.iter().map(|(n, _)| n.as_str())
    }
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
    decode_routed(path, std::io::Cursor::new(bytes), |_, _, _, _| Destination::Own(None))
}

/// Where each decoded sample of a layer goes: its row-major index in the file's layer →
/// its index in the channel's samples (a permutation of `0..width·height`).
pub type Placement = std::sync::Arc<dyn Fn(usize) -> usize + Send + Sync>;

/// A caller's receiver of one channel's samples: called for each decoded line with the
/// row-major index of the line's first sample in the file's layer and the line's samples.
pub type Sink = Box<dyn FnMut(usize, &[f32])>;

/// Where one channel's decoded samples go.
pub enum Destination {
    /// An array of the channel's own, each sample at its placed index (row-major where
    /// `None`).
    Own(Option<Placement>),
    /// The caller's [`Sink`]; the channel's own array stays empty. The caller keeps what it
    /// needs in the form it needs (three channels as one array of triples, counts in bytes),
    /// so no f32 array of the channel is ever held.
    Sink(Sink),
}

/// [`decode`] from a reader, each channel's samples sent where `route(layer, channel,
/// width, height)` says as its lines are decoded: a layer stored as an atlas of tiles arrives
/// in its owner's order without a second copy, and the file's bytes are never held whole.
pub fn decode_routed(
    path: &Path,
    reader: impl std::io::Read + std::io::Seek,
    route: impl Fn(&str, &str, usize, usize) -> Destination + 'static,
) -> Result<Vec<ExrLayer>, FileError> {
    use exr::prelude::{ReadChannels, ReadLayers};
    let image = exr::image::read::any_channels::ReadAnyChannels { read_samples: RoutedSamples { route } }
        .all_layers()
        .all_attributes()
        .non_parallel()
        .from_buffered(std::io::BufReader::new(reader))
        .map_err(|e| FileError::Exr { path: path.to_path_buf(), message: e.to_string() })?;
    let mut out = Vec::new();
    for layer in image.layer_data {
        let name = layer.attributes.layer_name.as_ref().map(|n| n.to_string()).unwrap_or_default();
        let (width, height) = (layer.size.0, layer.size.1);
        let channels = layer.channel_data.list.into_iter().map(|ch| (ch.name.to_string(), ch.sample_data)).collect();
        out.push(ExrLayer { name, width, height, channels });
    }
    Ok(out)
}

/// A route for [`decode_routed`]: each listed (layer, channel, sink) takes that channel
/// (once), every other channel gets an array of its own placed by `place`.
pub fn route_to_sinks(
    sinks: Vec<(String, String, Sink)>,
    place: impl Fn(&str, usize, usize) -> Option<Placement> + 'static,
) -> impl Fn(&str, &str, usize, usize) -> Destination + 'static {
    let sinks = std::cell::RefCell::new(sinks);
    move |layer, channel, w, h| {
        let mut sinks = sinks.borrow_mut();
        match sinks.iter().position(|(l, c, _)| l == layer && c == channel) {
            Some(k) => Destination::Sink(sinks.swap_remove(k).2),
            None => Destination::Own(place(layer, w, h)),
        }
    }
}

/// A layer's R, G and B channels decoded into one array of triples, each texel at its
/// placed index: the layer is never held as three channels and a copy.
pub struct RgbSink {
    rgb: std::sync::Arc<std::sync::Mutex<Vec<glam::Vec3>>>,
    place: Placement,
}

impl RgbSink {
    /// `len` texels (zero until decoded), placed by `place`.
    #[must_use]
    pub fn new(len: usize, place: Placement) -> RgbSink {
        RgbSink { rgb: std::sync::Arc::new(std::sync::Mutex::new(vec![glam::Vec3::ZERO; len])), place }
    }

    /// The sinks of layer `layer`'s R, G and B channels, for [`route_to_sinks`].
    #[must_use]
    pub fn sinks(&self, layer: &str) -> Vec<(String, String, Sink)> {
        ["R", "G", "B"]
            .iter()
            .enumerate()
            .map(|(c, &name)| (layer.to_string(), name.to_string(), self.channel(c)))
            .collect()
    }

    /// The sink of component `c` (0 = R, 1 = G, 2 = B).
    fn channel(&self, c: usize) -> Sink {
        let (rgb, place) = (self.rgb.clone(), self.place.clone());
        Box::new(move |start: usize, line: &[f32]| {
            let mut rgb = rgb.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
            let n = rgb.len();
            for (i, &v) in line.iter().enumerate() {
                if let Some(t) = rgb.get_mut(place(start + i).min(n.saturating_sub(1))) {
                    t[c] = v;
                }
            }
        })
    }

    /// The triples decoded (a channel the file lacked stays 0: the caller checks the
    /// channels' presence in the decoded layer).
    #[must_use]
    pub fn take(self) -> Vec<glam::Vec3> {
        std::mem::take(&mut *self.rgb.lock().unwrap_or_else(std::sync::PoisonError::into_inner))
    }
}

/// The exr crate's sample reading for [`decode_routed`]: flat f16/f32 channels of the
/// largest level, each sample converted to f32 and sent where the route says.
struct RoutedSamples<F> {
    route: F,
}

enum Target {
    Own { place: Option<Placement>, samples: Vec<f32> },
    Sink(Sink),
}

struct RoutedReader {
    width: usize,
    len: usize,
    half: bool,
    target: Target,
    /// The line being read, as f32.
    line: Vec<f32>,
}

impl<F: Fn(&str, &str, usize, usize) -> Destination> exr::image::read::any_channels::ReadSamples for RoutedSamples<F> {
    type Reader = RoutedReader;

    fn create_sample_reader(
        &self,
        header: &exr::meta::header::Header,
        channel: &exr::meta::attribute::ChannelDescription,
    ) -> exr::error::Result<RoutedReader> {
        use exr::error::Error;
        use exr::meta::attribute::SampleType;
        if header.deep {
            return Err(Error::NotSupported("deep data".into()));
        }
        if channel.sampling != exr::math::Vec2(1, 1) {
            return Err(Error::NotSupported("subsampled channels".into()));
        }
        let half = match channel.sample_type {
            SampleType::F16 => true,
            SampleType::F32 => false,
            SampleType::U32 => return Err(Error::NotSupported("u32 channels".into())),
        };
        let (width, height) = (header.layer_size.width(), header.layer_size.height());
        let name = header.own_attributes.layer_name.as_ref().map(|n| n.to_string()).unwrap_or_default();
        let target = match (self.route)(&name, &channel.name.to_string(), width, height) {
            Destination::Own(place) => Target::Own { place, samples: vec![0.0; width * height] },
            Destination::Sink(sink) => Target::Sink(sink),
        };
        Ok(RoutedReader { width, len: width * height, half, target, line: Vec::with_capacity(width) })
    }
}

impl exr::image::read::any_channels::SamplesReader for RoutedReader {
    type Samples = Vec<f32>;

    fn filter_block(&self, tile: exr::block::chunk::TileCoordinates) -> bool {
        tile.level_index == exr::math::Vec2(0, 0)
    }

    fn read_line(&mut self, line: exr::block::lines::LineRef<'_>) -> exr::error::UnitResult {
        use exr::error::Error;
        let at = line.location;
        let start = at.position.y() * self.width + at.position.x();
        if at.position.x() + at.sample_count > self.width || start + at.sample_count > self.len {
            return Err(Error::Invalid("a line outside its layer".into()));
        }
        self.line.clear();
        if self.half {
            for v in line.read_samples::<exr::prelude::f16>() {
                self.line.push(v?.to_f32());
            }
        } else {
            for v in line.read_samples::<f32>() {
                self.line.push(v?);
            }
        }
        match &mut self.target {
            Target::Own { place, samples } => {
                let n = samples.len();
                for (i, &v) in self.line.iter().enumerate() {
                    samples[place.as_ref().map_or(start + i, |p| p(start + i)).min(n - 1)] = v;
                }
            }
            Target::Sink(sink) => sink(start, &self.line),
        }
        Ok(())
    }

    fn into_samples(self) -> Vec<f32> {
        match self.target {
            Target::Own { samples, .. } => samples,
            Target::Sink(_) => Vec::new(),
        }
    }
}

/// Encodes layers into EXR bytes; layers for which `half(name)` holds are stored as f16
/// (values clamped to ±65504 first, so nothing becomes +inf; the grid writer only asks for
/// f16 where every value fits).
#[cfg(feature = "bake")]
pub fn encode<'a, L: Into<ExrLayer<Samples<'a>>>>(
    path: &Path,
    layers: impl IntoIterator<Item = L>,
    half: impl Fn(&str) -> bool,
) -> Result<Vec<u8>, FileError> {
    let mut bytes = Vec::new();
    let layers = layers.into_iter().map(Into::into).collect();
    encode_into(path, layers, half, std::io::Cursor::new(&mut bytes))?;
    Ok(bytes)
}

/// Writes the payload `path` atomically from `layers` ([`encode`]'s layout), the encoder
/// writing straight into the temporary file, so no encoded copy of the payload is held in
/// memory; returns its length and checksum for the manifest.
#[cfg(feature = "bake")]
pub fn write_payload<'a, L: Into<ExrLayer<Samples<'a>>>>(
    path: &Path,
    layers: impl IntoIterator<Item = L>,
    half: impl Fn(&str) -> bool,
) -> Result<(u64, String), FileError> {
    let layers: Vec<ExrLayer<Samples>> = layers.into_iter().map(Into::into).collect();
    crate::files::write_atomic_with(path, |f| encode_into(path, layers, half, f))
}

/// [`encode`] into `out`.
#[cfg(feature = "bake")]
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
#[cfg(feature = "bake")]
struct LineSamples<'a> {
    samples: Samples<'a>,
    width: usize,
    half: bool,
}

#[cfg(feature = "bake")]
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

#[cfg(feature = "bake")]
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
#[cfg(feature = "bake")]
pub fn write(path: &Path, layers: &[ExrLayer]) -> Result<u64, FileError> {
    Ok(write_payload(path, layers.iter().cloned(), |_| false)?.0)
}

/// Reads every layer of an EXR file as f32 channels.
#[cfg(feature = "bake")]
pub fn read(path: &Path) -> Result<Vec<ExrLayer>, FileError> {
    let bytes = std::fs::read(path).map_err(FileError::io(path))?;
    decode(path, &bytes)
}

#[cfg(all(test, feature = "bake"))]
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

//! EXR layers as plain data: named layers of named f32 channels, and their decoding (the
//! loader reads payloads with it). Encoding is the offline tool's (`warpfit::gridfile::exr`).
//!
//! The exr crate panics when a channel's sample count does not match its layer size, so
//! sizes are validated here first; decoding validates the same on the way in.

use crate::files::FileError;
use std::path::Path;

/// One layer: `width × height` pixels, row 0 first, each channel a flat row-major array
/// (`S = Vec<f32>`, what decoding returns) or, for the offline tool's encoder, samples
/// computed on demand.
#[derive(Clone, Debug, PartialEq)]
pub struct ExrLayer<S = Vec<f32>> {
    pub name: String,
    pub width: usize,
    pub height: usize,
    pub channels: Vec<(String, S)>,
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

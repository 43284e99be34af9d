//! A KTX 2.0 writer for uncompressed float textures (Khronos KTX 2.0 specification): one
//! 2-D image with a mip chain, no supercompression, a basic data format descriptor
//! (RGBSDA colour model, BT.709 primaries, linear transfer, float samples) and the
//! `KTXwriter` key. Levels are stored smallest first, each aligned to lcm(texel size, 4),
//! as the specification requires.

/// The texel formats the export writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// VK_FORMAT_R16G16B16A16_SFLOAT
    Rgba16F,
    /// VK_FORMAT_R32G32B32A32_SFLOAT
    Rgba32F,
    /// VK_FORMAT_R32_SFLOAT
    R32F,
    /// VK_FORMAT_R32G32_SFLOAT
    Rg32F,
}

impl Format {
    /// The Vulkan format number.
    pub fn vk_format(self) -> u32 {
        match self {
            Format::Rgba16F => 97,
            Format::Rgba32F => 109,
            Format::R32F => 100,
            Format::Rg32F => 103,
        }
    }
    /// Bytes per channel.
    pub fn type_size(self) -> u32 {
        match self {
            Format::Rgba16F => 2,
            Format::Rgba32F | Format::R32F | Format::Rg32F => 4,
        }
    }
    /// Channels per texel, in order (KTX channel ids of the RGBSDA model).
    fn channels(self) -> &'static [u8] {
        match self {
            Format::Rgba16F | Format::Rgba32F => &[0, 1, 2, 15],
            Format::R32F => &[0],
            Format::Rg32F => &[0, 1],
        }
    }
    /// Bytes per texel.
    pub fn texel_bytes(self) -> u32 {
        self.type_size() * self.channels().len() as u32
    }
    /// The name engines use.
    pub fn name(self) -> &'static str {
        match self {
            Format::Rgba16F => "RGBA16F",
            Format::Rgba32F => "RGBA32F",
            Format::R32F => "R32F",
            Format::Rg32F => "RG32F",
        }
    }
}

/// One mip level: width, height and `width · height · channels` values, row 0 first.
pub struct Level {
    pub width: u32,
    pub height: u32,
    pub values: Vec<f32>,
}

const IDENTIFIER: [u8; 12] = [0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A];

fn align(n: usize, to: usize) -> usize {
    n.div_ceil(to) * to
}

fn u32s(out: &mut Vec<u8>, values: &[u32]) {
    for v in values {
        out.extend_from_slice(&v.to_le_bytes());
    }
}

/// The data format descriptor of `format`.
fn dfd(format: Format) -> Vec<u8> {
    let channels = format.channels();
    let block = 24 + 16 * channels.len() as u32;
    let mut d = Vec::new();
    u32s(&mut d, &[4 + block, 0, 2 | (block << 16)]);
    // colour model RGBSDA (1), primaries BT.709 (1), transfer linear (1), flags 0
    d.extend_from_slice(&[1, 1, 1, 0]);
    d.extend_from_slice(&[0, 0, 0, 0]); // texel block 1×1×1×1
    d.extend_from_slice(&[format.texel_bytes() as u8, 0, 0, 0, 0, 0, 0, 0]);
    let bits = format.type_size() * 8;
    for (k, &id) in channels.iter().enumerate() {
        let offset = k as u32 * bits;
        // channel id with the float (0x80) and signed (0x40) qualifiers
        let word0 = offset | ((bits - 1) << 16) | (((id | 0xC0) as u32) << 24);
        u32s(&mut d, &[word0, 0, (-1.0f32).to_bits(), 1.0f32.to_bits()]);
    }
    d
}

/// The texel bytes of `values` in `format`.
fn encode_values(format: Format, values: &[f32]) -> Vec<u8> {
    match format {
        Format::Rgba16F => values.iter().flat_map(|&x| half::f16::from_f32(x).to_bits().to_le_bytes()).collect(),
        Format::Rgba32F | Format::R32F | Format::Rg32F => values.iter().flat_map(|x| x.to_le_bytes()).collect(),
    }
}

/// A KTX2 file of `levels` (level 0 the largest) in `format`.
pub fn encode(format: Format, levels: &[Level]) -> Vec<u8> {
    encode_array(format, 0, levels)
}

/// A KTX2 file of `levels` in `format` with `layers` array layers (0: not an array); each
/// level's values hold every layer's image, one after the other.
pub fn encode_array(format: Format, layers: u32, levels: &[Level]) -> Vec<u8> {
    let n = levels.len();
    let dfd = dfd(format);
    let mut kvd = Vec::new();
    let kv = format!("KTXwriter\0warpfit {}\0", env!("CARGO_PKG_VERSION"));
    u32s(&mut kvd, &[kv.len() as u32]);
    kvd.extend_from_slice(kv.as_bytes());
    while kvd.len() % 4 != 0 {
        kvd.push(0);
    }
    let dfd_offset = 80 + 24 * n;
    let kvd_offset = dfd_offset + dfd.len();
    // lcm(texel size, 4): every texel size here is a multiple of 4
    let level_align = (format.texel_bytes() as usize).max(4);
    let data: Vec<Vec<u8>> = levels.iter().map(|l| encode_values(format, &l.values)).collect();
    // smallest level first in the file
    let mut offsets = vec![0usize; n];
    let mut at = kvd_offset + kvd.len();
    for k in (0..n).rev() {
        at = align(at, level_align);
        offsets[k] = at;
        at += data[k].len();
    }
    let mut out = Vec::with_capacity(at);
    out.extend_from_slice(&IDENTIFIER);
    let (w, h) = levels.first().map_or((0, 0), |l| (l.width, l.height));
    u32s(&mut out, &[format.vk_format(), format.type_size(), w, h, 0, layers, 1, n as u32, 0]);
    u32s(&mut out, &[dfd_offset as u32, dfd.len() as u32, kvd_offset as u32, kvd.len() as u32]);
    out.extend_from_slice(&0u64.to_le_bytes());
    out.extend_from_slice(&0u64.to_le_bytes());
    for k in 0..n {
        for v in [offsets[k] as u64, data[k].len() as u64, data[k].len() as u64] {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    out.extend_from_slice(&dfd);
    out.extend_from_slice(&kvd);
    for k in (0..n).rev() {
        out.resize(offsets[k], 0);
        out.extend_from_slice(&data[k]);
    }
    out
}

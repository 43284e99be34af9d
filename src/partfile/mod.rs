//! `warpfit-part`: what one shard of a bake or a fit writes and `warpfit merge` reads.
//!
//! A part is one file: the line `warpfit-part`, the header's length (8 bytes, little
//! endian), the header as JSON (what made the part: scene and its content key, settings,
//! shard K of N, the cells and points it covers, its time; the body's size and checksum),
//! then the body in CBOR (binary serde, RFC 8949: every float bit for bit, so a merge
//! computes with exactly the values the shard computed). Written atomically; a reader
//! checks the magic, version, sizes and checksum before it decodes the body, and names the
//! file in every error.

use crate::bake::SpecularProbe;
use crate::bake::grid::CellBake;
use crate::files::{FileError, checksum, write_atomic};
use crate::fit::CellOutcome;
use crate::fit::irradiance::{PointRanges, References};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

pub const PART_FORMAT: &str = "warpfit-part";
/// 2: a bake part's cells count each distance texel's hits in a byte (1 stored fractions);
/// a fit part's irradiance references carry their rays as one total. 3: a fit part's cells
/// come with their model selected and keep only the maps they store.
pub const PART_VERSION: u32 = 4;
const MAGIC: &[u8] = b"warpfit-part\n";
/// Largest header accepted (the header lists no per-cell data).
const MAX_HEADER: u64 = 1 << 20;
/// Largest part accepted (a fit part holds about 1 KB per cell).
pub const MAX_PART_BYTES: u64 = 64 << 30;

/// What a part holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PartKind {
    Bake,
    Fit,
}

impl PartKind {
    pub fn name(self) -> &'static str {
        match self {
            PartKind::Bake => "bake",
            PartKind::Fit => "fit",
        }
    }
}

/// What made a part; parts merge only when everything but the shard and its work agrees.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PartHeader {
    pub format: String,
    pub version: u32,
    /// warpfit's version that wrote the part.
    pub tool_version: String,
    pub kind: PartKind,
    pub scene: String,
    /// The scene file, absolute (the merge of a fit loads it again).
    pub scene_file: PathBuf,
    /// The scene's content key (tool version, settings, bytes of every input file).
    pub scene_key: String,
    /// Fit parts: the checksums of the bake's payloads they were fitted on.
    #[serde(default)]
    pub bake_checksums: Vec<String>,
    /// The settings of the job (fit settings, warp options, storage), as JSON.
    pub settings: serde_json::Value,
    pub shard: u32,
    pub shards: u32,
    /// Bake parts: the grid cells covered; fit parts: the range of the active-cell list.
    pub cells: std::ops::Range<usize>,
    /// Fit parts: the diffuse fit's surface points whose references the part traced.
    #[serde(default)]
    pub points: Option<PointRanges>,
    /// Seconds the shard worked, and the host it ran on.
    pub seconds: f64,
    /// Fit parts: the wall seconds of the shard's steps (its cells, the surface points and
    /// its share of their references), which the merge sums into the fit's time line.
    #[serde(default)]
    pub fit_times: Option<crate::fit::FitTimes>,
    pub host: String,
    pub body_bytes: u64,
    pub body_checksum: String,
}

/// A bake shard's work: probe A (shard 0), the other probes it baked (probe k ≥ 1 is
/// baked by shard k mod n, with the index k and its rays), where every probe stands (each
/// shard places them alike), and its grid cells, in order.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BakePart {
    pub probe: Option<(SpecularProbe, u64)>,
    pub others: Vec<(usize, SpecularProbe, u64)>,
    pub placement: crate::bake::placement::Placement,
    pub cells: Vec<CellBake>,
}

/// A fit shard's work: its cells' outcomes (in active-cell order) and the irradiance
/// references of its surface points.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FitPart {
    pub cells: Vec<CellOutcome>,
    pub references: References,
}

/// The body of a part.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub enum PartBody {
    Bake(BakePart),
    Fit(FitPart),
}

/// The file name of shard `k` of `n` of a job.
pub fn part_name(kind: PartKind, k: u32, n: u32) -> String {
    format!("{}-{k:04}-of-{n:04}.part", kind.name())
}

/// Writes a part atomically; fills in the header's body size and checksum.
pub fn write_part(path: &Path, mut header: PartHeader, body: &PartBody) -> Result<(), FileError> {
    let mut bytes = Vec::new();
    ciborium::into_writer(body, &mut bytes).map_err(|e| FileError::invalid(path, "body", e.to_string()))?;
    let body = bytes;
    header.body_bytes = body.len() as u64;
    header.body_checksum = checksum(&body);
    let head = serde_json::to_vec(&header)
        .map_err(|e| FileError::Json { path: path.to_path_buf(), message: e.to_string() })?;
    let mut bytes = Vec::with_capacity(MAGIC.len() + 8 + head.len() + body.len());
    bytes.extend_from_slice(MAGIC);
    bytes.extend_from_slice(&(head.len() as u64).to_le_bytes());
    bytes.extend_from_slice(&head);
    bytes.extend_from_slice(&body);
    write_atomic(path, &bytes)
}

/// Parses the header at the start of a part whose whole size is `file_len`: checks magic,
/// format, version and that the body has the size the header gives. Returns the header and
/// where the body starts.
fn parse_header(path: &Path, start: &[u8], file_len: u64) -> Result<(PartHeader, usize), FileError> {
    let bad = |field: &str, message: String| FileError::invalid(path, field, message);
    if !start.starts_with(MAGIC) {
        return Err(bad("magic", "is not a warpfit part (it does not start with `warpfit-part`)".into()));
    }
    let rest = &start[MAGIC.len()..];
    let Some((len, rest)) = rest.split_first_chunk::<8>() else {
        return Err(bad("header", "is truncated before its header".into()));
    };
    let len = u64::from_le_bytes(*len);
    if len > MAX_HEADER || len > rest.len() as u64 {
        return Err(bad("header", format!("claims a header of {len} bytes; the file has {} after it", rest.len())));
    }
    let head = &rest[..len as usize];
    // the version first, so a newer part says so rather than failing on a field
    let value: serde_json::Value = serde_json::from_slice(head)
        .map_err(|e| FileError::Json { path: path.to_path_buf(), message: e.to_string() })?;
    let version = value.get("version").and_then(serde_json::Value::as_u64);
    if value.get("format").and_then(serde_json::Value::as_str) != Some(PART_FORMAT) {
        return Err(bad("format", format!("is not {PART_FORMAT}")));
    }
    if version != Some(PART_VERSION as u64) {
        return Err(bad("version", format!("is version {version:?}; this warpfit reads version {PART_VERSION}")));
    }
    let header: PartHeader = serde_json::from_value(value)
        .map_err(|e| FileError::Json { path: path.to_path_buf(), message: e.to_string() })?;
    let body_start = MAGIC.len() + 8 + len as usize;
    let body_len = file_len - body_start as u64;
    if header.body_bytes != body_len {
        return Err(bad(
            "body",
            format!("is {body_len} bytes, the header says {} (truncated or appended to)", header.body_bytes),
        ));
    }
    Ok((header, body_start))
}

/// Reads a part's header alone: the start of the file, checked as `parse_header` does (the
/// body's checksum is checked when the body is read).
pub fn read_header(path: &Path) -> Result<PartHeader, FileError> {
    use std::io::Read as _;
    let file = std::fs::File::open(path).map_err(FileError::io(path))?;
    let meta = file.metadata().map_err(FileError::io(path))?;
    if !meta.is_file() {
        return Err(FileError::invalid(path, "file", "is not a regular file"));
    }
    let mut start = Vec::new();
    file.take(MAGIC.len() as u64 + 8 + MAX_HEADER).read_to_end(&mut start).map_err(FileError::io(path))?;
    Ok(parse_header(path, &start, meta.len())?.0)
}

/// Reads a part: header and body, checked. The body's checksum is read through the file in
/// pieces before any of it is decoded, and the body is decoded from the file as a stream:
/// a damaged part costs a buffer to refuse, not its size.
pub fn read_part(path: &Path) -> Result<(PartHeader, PartBody), FileError> {
    use std::io::{Read as _, Seek as _, SeekFrom};
    let (mut f, len) = crate::files::open_regular(path, MAX_PART_BYTES)?;
    let mut start = Vec::new();
    (&mut f).take(MAGIC.len() as u64 + 8 + MAX_HEADER).read_to_end(&mut start).map_err(FileError::io(path))?;
    let (header, body_start) = parse_header(path, &start, len)?;
    drop(start);
    f.seek(SeekFrom::Start(body_start as u64)).map_err(FileError::io(path))?;
    let mut sum = crate::files::Fnv::new();
    let mut buf = vec![0u8; 1 << 20];
    loop {
        let k = f.read(&mut buf).map_err(FileError::io(path))?;
        if k == 0 {
            break;
        }
        sum.update(&buf[..k]);
    }
    if sum.finish() != header.body_checksum {
        return Err(FileError::invalid(path, "body", format!("does not match its checksum {}", header.body_checksum)));
    }
    f.seek(SeekFrom::Start(body_start as u64)).map_err(FileError::io(path))?;
    let body: PartBody = ciborium::from_reader(std::io::BufReader::new(f))
        .map_err(|e| FileError::invalid(path, "body", e.to_string()))?;
    let kind = match body {
        PartBody::Bake(_) => PartKind::Bake,
        PartBody::Fit(_) => PartKind::Fit,
    };
    if kind != header.kind {
        return Err(FileError::invalid(
            path,
            "kind",
            format!("header says {}, body holds {}", header.kind.name(), kind.name()),
        ));
    }
    Ok((header, body))
}

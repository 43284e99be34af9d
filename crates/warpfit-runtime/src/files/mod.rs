//! File plumbing every format shares: the one error type for files warpfit reads or writes
//! (naming the file and the field), bounded reads, JSON, and the checksum payloads carry.
//! Knows no domain type. The writing side (atomic writes, staged folders) is the offline
//! tool's (`warpfit::files`).

use std::fmt;
use std::path::{Path, PathBuf};

/// Everything that can be wrong with a file warpfit reads or writes, naming the file (and
/// the field where there is one). The runtime calls it `LoadError`.
///
/// ```
/// let err = warpfit_runtime::FittedGrid::load("no/such/folder").unwrap_err();
/// assert!(matches!(err, warpfit_runtime::LoadError::Io { .. }));
/// assert!(err.to_string().contains("no/such/folder"));
/// ```
#[derive(Debug)]
pub enum FileError {
    /// The file could not be opened or read (missing, unreadable, not a regular file).
    Io {
        /// The file.
        path: PathBuf,
        /// What the operating system said.
        source: std::io::Error,
    },
    /// The JSON does not parse, or lacks a field.
    Json {
        /// The file.
        path: PathBuf,
        /// What was wrong.
        message: String,
    },
    /// Another format, or a version this build does not read.
    Version {
        /// The file.
        path: PathBuf,
        /// What the file says it is.
        found: String,
        /// The version the file says it has.
        version: u64,
        /// The format this build reads.
        expected: &'static str,
        /// The version this build reads.
        supported: u32,
    },
    /// A payload's bytes differ from the checksum its manifest lists (truncated or damaged).
    Checksum {
        /// The file.
        path: PathBuf,
        /// The checksum the manifest lists.
        expected: String,
        /// The checksum of the bytes found.
        found: String,
    },
    /// The EXR payload does not decode, or its layers are not the ones listed.
    Exr {
        /// The file.
        path: PathBuf,
        /// What was wrong.
        message: String,
    },
    /// A value outside what the writer produces (a size, a NaN, a range).
    Invalid {
        /// The file.
        path: PathBuf,
        /// The field or part of the file at fault.
        field: String,
        /// What was wrong.
        message: String,
    },
}

impl fmt::Display for FileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FileError::Io { path, source } => write!(f, "{}: {source}", path.display()),
            FileError::Json { path, message } => write!(f, "{}: invalid JSON: {message}", path.display()),
            FileError::Version { path, found, version, expected, supported } => write!(
                f,
                "{}: format {found:?} version {version} is not supported (this build reads {expected:?} version {supported})",
                path.display()
            ),
            FileError::Checksum { path, expected, found } => write!(
                f,
                "{}: checksum {found} does not match the manifest's {expected} (truncated or modified file)",
                path.display()
            ),
            FileError::Exr { path, message } => write!(f, "{}: not a readable EXR: {message}", path.display()),
            FileError::Invalid { path, field, message } => write!(f, "{}: {field}: {message}", path.display()),
        }
    }
}

impl std::error::Error for FileError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            FileError::Io { source, .. } => Some(source),
            _ => None,
        }
    }
}

impl FileError {
    /// An I/O error on `path`.
    pub fn io(path: &Path) -> impl FnOnce(std::io::Error) -> FileError + '_ {
        move |source| FileError::Io { path: path.to_path_buf(), source }
    }

    /// A value of `path` that breaks a rule: the field and why.
    pub fn invalid(path: &Path, field: impl Into<String>, message: impl Into<String>) -> FileError {
        FileError::Invalid { path: path.to_path_buf(), field: field.into(), message: message.into() }
    }
}

/// Reads `path`, which must be a regular file (a FIFO, device or folder could block, never
/// end or be huge) of at most `max` bytes, with the size checked before a byte is read.
pub fn read_regular(path: &Path, max: u64) -> Result<Vec<u8>, FileError> {
    let (f, len) = open_regular(path, max)?;
    let mut bytes = Vec::with_capacity(len as usize);
    use std::io::Read;
    f.take(max + 1).read_to_end(&mut bytes).map_err(FileError::io(path))?;
    if bytes.len() as u64 > max {
        return Err(FileError::invalid(path, "size", format!("more than the {max} bytes this reader accepts")));
    }
    Ok(bytes)
}

/// Opens `path`, which must be a regular file of at most `max` bytes (checked on the path
/// and again on what was opened); returns it with its length.
pub fn open_regular(path: &Path, max: u64) -> Result<(std::fs::File, u64), FileError> {
    let not_regular = |what: &str| FileError::invalid(path, "file", format!("is {what}, not a regular file"));
    let meta = std::fs::metadata(path).map_err(FileError::io(path))?;
    let kind = |m: &std::fs::Metadata| {
        if m.is_file() {
            None
        } else if m.is_dir() {
            Some("a folder")
        } else {
            Some("a FIFO, socket or device")
        }
    };
    if let Some(k) = kind(&meta) {
        return Err(not_regular(k));
    }
    if meta.len() > max {
        return Err(FileError::invalid(
            path,
            "size",
            format!("{} bytes, more than the {max} this reader accepts", meta.len()),
        ));
    }
    let f = std::fs::File::open(path).map_err(FileError::io(path))?;
    // the same checks on what was opened (the path may have changed in between)
    let meta = f.metadata().map_err(FileError::io(path))?;
    if let Some(k) = kind(&meta) {
        return Err(not_regular(k));
    }
    Ok((f, meta.len().min(max)))
}

/// Opens the payload `path` that a manifest lists with `bytes` and `checksum`: a regular
/// file of exactly that size whose contents hash to that checksum, read through once in
/// pieces (never held whole), then rewound for the decoder, which reads the same open file.
pub fn open_listed(path: &Path, bytes: u64, checksum: &str) -> Result<std::fs::File, FileError> {
    use std::io::{Read, Seek};
    let size_error = |n: u64| FileError::invalid(path, "size", format!("{n} bytes, the manifest says {bytes}"));
    let (mut f, len) = open_regular(path, u64::MAX)?;
    if len != bytes {
        return Err(size_error(len));
    }
    let mut h = Fnv::new();
    let mut buf = vec![0u8; 1 << 20];
    let mut n = 0u64;
    loop {
        let k = f.read(&mut buf).map_err(FileError::io(path))?;
        if k == 0 {
            break;
        }
        n += k as u64;
        if n > bytes {
            return Err(size_error(n));
        }
        h.update(&buf[..k]);
    }
    if n != bytes {
        return Err(size_error(n));
    }
    let found = h.finish();
    if found != checksum {
        return Err(FileError::Checksum { path: path.to_path_buf(), expected: checksum.to_string(), found });
    }
    f.rewind().map_err(FileError::io(path))?;
    Ok(f)
}

/// Largest JSON file [`read_json`] reads.
pub const MAX_JSON_BYTES: u64 = 256 << 20;

/// Reads and parses a JSON file (a regular file of at most [`MAX_JSON_BYTES`]).
pub fn read_json<T: for<'de> serde::Deserialize<'de>>(path: &Path) -> Result<T, FileError> {
    let bytes = read_regular(path, MAX_JSON_BYTES)?;
    serde_json::from_slice(&bytes).map_err(|e| FileError::Json { path: path.to_path_buf(), message: e.to_string() })
}

/// A byte count for people: `1,385,270 bytes (1.4 MB)` style, decimal units.
#[must_use]
pub fn human_bytes(n: u64) -> String {
    let digits = n.to_string();
    let mut grouped = String::new();
    for (k, c) in digits.chars().enumerate() {
        if k > 0 && (digits.len() - k).is_multiple_of(3) {
            grouped.push(',');
        }
        grouped.push(c);
    }
    let (v, unit) = match n {
        0..1_000 => return format!("{grouped} bytes"),
        1_000..1_000_000 => (n as f64 / 1e3, "kB"),
        1_000_000..1_000_000_000 => (n as f64 / 1e6, "MB"),
        _ => (n as f64 / 1e9, "GB"),
    };
    format!("{grouped} bytes ({v:.1} {unit})")
}

/// FNV-1a (64 bit) of `bytes` as `fnv1a64:` + 16 hex digits, the checksum payloads carry in
/// their manifests. Detects truncation and corruption; it is not a cryptographic hash.
#[must_use]
pub fn checksum(bytes: &[u8]) -> String {
    let mut h = Fnv::new();
    h.update(bytes);
    h.finish()
}

/// [`checksum`] over bytes that arrive in pieces.
#[derive(Clone, Debug)]
pub struct Fnv(u64);

impl Default for Fnv {
    fn default() -> Fnv {
        Fnv::new()
    }
}

impl Fnv {
    /// The hash of no bytes.
    #[must_use]
    pub fn new() -> Fnv {
        Fnv(0xcbf2_9ce4_8422_2325)
    }

    /// Hashes `bytes` after what came before.
    pub fn update(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 ^= b as u64;
            self.0 = self.0.wrapping_mul(0x0100_0000_01b3);
        }
    }

    /// As [`checksum`] prints it.
    #[must_use]
    pub fn finish(&self) -> String {
        format!("fnv1a64:{:016x}", self.0)
    }
}

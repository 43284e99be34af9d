//! File plumbing every format shares: the one error type for files warpfit reads or writes
//! (naming the file and the field), atomic writes, JSON, and the checksum payloads carry.
//! Knows no domain type; builds in the runtime-only configuration (std and serde_json).

#[cfg(feature = "bake")]
pub mod staged;

use serde::Serialize;
use std::fmt;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Everything that can be wrong with a file warpfit reads or writes. The runtime calls it
/// `runtime::LoadError`.
#[derive(Debug)]
pub enum FileError {
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    Json {
        path: PathBuf,
        message: String,
    },
    /// Another format, or a version this build does not read.
    Version {
        path: PathBuf,
        found: String,
        version: u64,
        expected: &'static str,
        supported: u32,
    },
    Checksum {
        path: PathBuf,
        expected: String,
        found: String,
    },
    Exr {
        path: PathBuf,
        message: String,
    },
    Invalid {
        path: PathBuf,
        field: String,
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

/// Writes `bytes` to `path` atomically, creating parent directories: a temporary file beside
/// the target, flushed to disk, renamed over it. A crash leaves the old file or the new one,
/// never half of one.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), FileError> {
    replace_with(path, |f| f.write_all(bytes).map_err(FileError::io(path)))
}

/// [`write_atomic`] with the contents written by `fill` straight into the temporary file
/// (no copy of them held in memory); returns the file's length and [`checksum`], read back
/// from the file before it replaces the target.
#[cfg(feature = "bake")]
pub fn write_atomic_with(
    path: &Path,
    fill: impl FnOnce(&mut std::fs::File) -> Result<(), FileError>,
) -> Result<(u64, String), FileError> {
    replace_with(path, |f| {
        fill(f)?;
        use std::io::{Read, Seek};
        f.seek(std::io::SeekFrom::Start(0)).map_err(FileError::io(path))?;
        let (mut hash, mut len, mut buf) = (Fnv::new(), 0u64, vec![0u8; 1 << 20]);
        loop {
            let n = f.read(&mut buf).map_err(FileError::io(path))?;
            if n == 0 {
                break;
            }
            hash.update(&buf[..n]);
            len += n as u64;
        }
        Ok((len, hash.finish()))
    })
}

/// The temporary file, filled, flushed and renamed over `path` (removed on failure); what
/// `fill` returns.
fn replace_with<R>(path: &Path, fill: impl FnOnce(&mut std::fs::File) -> Result<R, FileError>) -> Result<R, FileError> {
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).map_err(FileError::io(dir))?;
    let name = path.file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let tmp: PathBuf = dir.join(format!(".{name}.tmp-{}", std::process::id()));
    let result = (|| {
        let mut f = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(true)
            .open(&tmp)
            .map_err(FileError::io(path))?;
        let out = fill(&mut f)?;
        f.sync_all().map_err(FileError::io(path))?;
        drop(f);
        rename(&tmp, path).map_err(FileError::io(path))?;
        Ok(out)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// Renames through the offline build's test hook (see `staged::set_rename_fault`).
fn rename(from: &Path, to: &Path) -> std::io::Result<()> {
    #[cfg(feature = "bake")]
    return staged::rename(from, to);
    #[cfg(not(feature = "bake"))]
    std::fs::rename(from, to)
}

/// Pretty JSON of `value`, written atomically.
pub fn write_json<T: Serialize + ?Sized>(path: &Path, value: &T) -> Result<(), FileError> {
    // serialised straight into the temporary file: a big level's residuals are never held
    // as text
    replace_with(path, |f| {
        let mut w = std::io::BufWriter::new(f);
        serde_json::to_writer_pretty(&mut w, value)
            .map_err(|e| FileError::Json { path: path.to_path_buf(), message: e.to_string() })?;
        w.flush().map_err(FileError::io(path))
    })
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
fn open_regular(path: &Path, max: u64) -> Result<(std::fs::File, u64), FileError> {
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
struct Fnv(u64);

impl Fnv {
    fn new() -> Fnv {
        Fnv(0xcbf2_9ce4_8422_2325)
    }

    fn update(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 ^= b as u64;
            self.0 = self.0.wrapping_mul(0x0100_0000_01b3);
        }
    }

    fn finish(&self) -> String {
        format!("fnv1a64:{:016x}", self.0)
    }
}

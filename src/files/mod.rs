//! File plumbing of the offline tool: everything the runtime's `files` has (the one error
//! type, bounded reads, JSON, checksums) plus the writing side: atomic writes and folders
//! written as a whole ([`staged`]).

pub mod staged;

pub use warpfit_runtime::files::*;

use serde::Serialize;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Writes `bytes` to `path` atomically, creating parent directories: a temporary file beside
/// the target, flushed to disk, renamed over it. A crash leaves the old file or the new one,
/// never half of one.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), FileError> {
    replace_with(path, |f| f.write_all(bytes).map_err(FileError::io(path)))
}

/// [`write_atomic`] with the contents written by `fill` straight into the temporary file
/// (no copy of them held in memory); returns the file's length and [`checksum`], read back
/// from the file before it replaces the target.
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

/// Renames through the test hook (see `staged::set_rename_fault`).
fn rename(from: &Path, to: &Path) -> std::io::Result<()> {
    staged::rename(from, to)
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

//! Folders written as a whole (offline): a run writes everything into a staging folder beside
//! its target, and only a complete, validated result is swapped in. At every instant the
//! target holds the complete old folder or the complete new one: on Linux the swap is one
//! `renameat2(RENAME_EXCHANGE)`; elsewhere two renames leave a short window in which the
//! target is missing (never half-written).
//!
//! A lock file beside the target (`.<name>.lock`, holding the pid and host of its owner)
//! refuses a second concurrent writer with a clear message. Leftovers of killed runs (stale
//! locks, staging folders, `.tmp-<pid>` files of [`super::write_atomic`]) are removed by the
//! next writer when their process is gone.
//!
//! Every rename here goes through [`rename`], which a test hook can make fail or abort the
//! process at the n-th call ([`set_rename_fault`]): tests kill a run at every rename and check
//! that the target still loads.

use super::FileError;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// What the rename hook does when it triggers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fault {
    /// The rename fails with an I/O error (a full disk, a vanished folder).
    Error,
    /// The process aborts at once, as if killed (no destructors run).
    Abort,
}

/// Rename calls so far, and the call (1-based) the hook triggers at (0 = never), with its
/// fault in the top bit.
static RENAMES: AtomicU64 = AtomicU64::new(0);
static FAULT_AT: AtomicU64 = AtomicU64::new(0);
const ABORT_BIT: u64 = 1 << 63;

/// Test hook: the `n`-th rename from now (1-based) fails or aborts; `None` disarms it.
pub fn set_rename_fault(fault: Option<(u64, Fault)>) {
    RENAMES.store(0, Ordering::SeqCst);
    let v = match fault {
        None => 0,
        Some((n, Fault::Error)) => n,
        Some((n, Fault::Abort)) => n | ABORT_BIT,
    };
    FAULT_AT.store(v, Ordering::SeqCst);
}

/// Counts a rename and triggers the hook's fault when it is due.
fn hook() -> std::io::Result<()> {
    let at = FAULT_AT.load(Ordering::SeqCst);
    if at != 0 {
        let n = RENAMES.fetch_add(1, Ordering::SeqCst) + 1;
        if n == at & !ABORT_BIT {
            if at & ABORT_BIT != 0 {
                std::process::abort();
            }
            return Err(std::io::Error::other(format!("injected failure at rename {n}")));
        }
    }
    Ok(())
}

/// `std::fs::rename` through the test hook.
pub fn rename(from: &Path, to: &Path) -> std::io::Result<()> {
    hook()?;
    std::fs::rename(from, to)
}

/// This machine's name (lock files name their owner's host: a pid means nothing elsewhere).
fn host() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .or_else(|_| std::fs::read_to_string("/etc/hostname"))
        .map(|s| s.trim().to_string())
        .unwrap_or_default()
}

/// Whether process `pid` of this host may still run (unknown = yes: never steal a lock
/// that may be held).
fn alive(pid: u32) -> bool {
    if pid == std::process::id() {
        return true;
    }
    let proc = Path::new("/proc");
    if !proc.join("self").exists() {
        return true;
    }
    proc.join(pid.to_string()).exists()
}

/// `.<name>` + `suffix`, beside `target`.
fn sibling(target: &Path, suffix: &str) -> PathBuf {
    let name = target.file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "out".into());
    target.with_file_name(format!(".{name}{suffix}"))
}

/// The pid at the end of `name` after `marker` (`.x.staging-123` → 123).
fn pid_after(name: &str, marker: &str) -> Option<u32> {
    name.rsplit_once(marker).and_then(|(_, p)| p.parse().ok())
}

/// A lock file naming no owner is taken over once it is this old: a lock is written
/// whole since this version, and an older writer writes its owner within microseconds.
pub const UNOWNED_LOCK_SECONDS: u64 = 10;

/// Exclusive ownership of a folder for writing, released on drop.
#[derive(Debug)]
pub struct FolderLock {
    path: PathBuf,
}

impl FolderLock {
    /// Takes the lock of `target` (`.<name>.lock` beside it); a lock left by a process that is
    /// gone is taken over, a live one is an error naming its owner.
    pub fn acquire(target: &Path) -> Result<FolderLock, FileError> {
        let path = sibling(target, ".lock");
        if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
            std::fs::create_dir_all(parent).map_err(FileError::io(parent))?;
        }
        let me = format!("{} {}", std::process::id(), host());
        // the owner is written into a file of this process's own, which is then linked to
        // the lock's name: the lock appears whole or not at all (a full disk fails the
        // write, not the lock)
        let mine = sibling(target, &format!(".lock.tmp-{}", std::process::id()));
        std::fs::write(&mine, me.as_bytes()).map_err(|e| {
            let _ = std::fs::remove_file(&mine);
            FileError::io(&mine)(e)
        })?;
        let taken = Self::link_lock(target, &mine, &path);
        let _ = std::fs::remove_file(&mine);
        taken
    }

    /// [`acquire`](Self::acquire)'s loop: links `mine` (the owner, written) to `path`, taking
    /// over a stale lock: one of a process of this host that is gone, or one without an
    /// owner (left by a writer of an older version that failed half-way) older than
    /// [`UNOWNED_LOCK_SECONDS`].
    fn link_lock(target: &Path, mine: &Path, path: &Path) -> Result<FolderLock, FileError> {
        let path = path.to_path_buf();
        for _ in 0..3 {
            match std::fs::hard_link(mine, &path) {
                Ok(()) => return Ok(FolderLock { path }),
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                    let owner = std::fs::read_to_string(&path).unwrap_or_default();
                    let mut it = owner.split_whitespace();
                    let pid = it.next().and_then(|p| p.parse::<u32>().ok());
                    let owner_host = it.next().unwrap_or("").to_string();
                    let age = std::fs::metadata(&path)
                        .and_then(|m| m.modified())
                        .ok()
                        .and_then(|t| t.elapsed().ok())
                        .map_or(0, |d| d.as_secs());
                    let stale = match pid {
                        Some(pid) => owner_host == host() && !alive(pid),
                        None => age >= UNOWNED_LOCK_SECONDS,
                    };
                    if !stale {
                        return Err(FileError::invalid(
                            target,
                            "lock",
                            format!(
                                "another warpfit process ({}) is writing this folder; wait for it to finish, or remove {} if no such process runs",
                                if owner.trim().is_empty() {
                                    "unknown".to_string()
                                } else {
                                    format!("pid {}", owner.trim())
                                },
                                path.display()
                            ),
                        ));
                    }
                    tracing::info!(
                        "removing the stale lock {} ({})",
                        path.display(),
                        if pid.is_some() { format!("process {} is gone", owner.trim()) } else { "no owner".into() }
                    );
                    let _ = std::fs::remove_file(&path);
                }
                // a file system without hard links: create the lock and write it, removing
                // it again if the write fails
                Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                    let owner = std::fs::read(mine).map_err(FileError::io(mine))?;
                    let mut f = match std::fs::OpenOptions::new().write(true).create_new(true).open(&path) {
                        Ok(f) => f,
                        Err(e2) if e2.kind() == std::io::ErrorKind::AlreadyExists => continue,
                        Err(_) => return Err(FileError::io(&path)(e)),
                    };
                    use std::io::Write;
                    if let Err(e) = f.write_all(&owner).and_then(|()| f.sync_all()) {
                        drop(f);
                        let _ = std::fs::remove_file(&path);
                        return Err(FileError::io(&path)(e));
                    }
                    return Ok(FolderLock { path });
                }
                Err(e) => return Err(FileError::io(&path)(e)),
            }
        }
        Err(FileError::invalid(target, "lock", format!("could not take {}", path.display())))
    }
}

impl Drop for FolderLock {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.path);
    }
}

/// Removes what killed writers of `target` left: staging and swapped-out folders beside it
/// and `.tmp-<pid>` files inside it, of processes that are gone. Call with the lock held.
pub fn clean_leftovers(target: &Path) {
    let name = target.file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let parent = target.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    if let Ok(entries) = std::fs::read_dir(parent) {
        for e in entries.flatten() {
            let n = e.file_name().to_string_lossy().into_owned();
            for marker in [".staging-", ".old-"] {
                if n.starts_with(&format!(".{name}{marker}")) && pid_after(&n, marker).is_some_and(|p| !alive(p)) {
                    tracing::info!("removing {} left by a killed run", e.path().display());
                    let _ = std::fs::remove_dir_all(e.path());
                }
            }
            // a lock's owner file of a process killed while taking the lock
            let marker = ".lock.tmp-";
            if n.starts_with(&format!(".{name}{marker}")) && pid_after(&n, marker).is_some_and(|p| !alive(p)) {
                let _ = std::fs::remove_file(e.path());
            }
        }
    }
    let mut dirs = vec![target.to_path_buf()];
    while let Some(d) = dirs.pop() {
        let Ok(entries) = std::fs::read_dir(&d) else { continue };
        for e in entries.flatten() {
            let n = e.file_name().to_string_lossy().into_owned();
            let Ok(t) = e.file_type() else { continue };
            if t.is_dir() {
                dirs.push(e.path());
            } else if n.starts_with('.') && pid_after(&n, ".tmp-").is_some_and(|p| !alive(p)) {
                let _ = std::fs::remove_file(e.path());
            }
        }
    }
}

/// A folder being written as a whole (see the module docs).
#[derive(Debug)]
pub struct StagedDir {
    target: PathBuf,
    staging: PathBuf,
    committed: bool,
    _lock: FolderLock,
}

impl StagedDir {
    /// Locks `target`, cleans leftovers of killed runs, and opens an empty staging folder.
    pub fn begin(target: &Path) -> Result<StagedDir, FileError> {
        let lock = FolderLock::acquire(target)?;
        clean_leftovers(target);
        let staging = sibling(target, &format!(".staging-{}", std::process::id()));
        if staging.exists() {
            std::fs::remove_dir_all(&staging).map_err(FileError::io(&staging))?;
        }
        std::fs::create_dir_all(&staging).map_err(FileError::io(&staging))?;
        Ok(StagedDir { target: target.to_path_buf(), staging, committed: false, _lock: lock })
    }

    /// Where the new folder is written.
    pub fn dir(&self) -> &Path {
        &self.staging
    }

    /// The folder the commit replaces.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// Swaps the staging folder in and removes the old one.
    pub fn commit(mut self) -> Result<(), FileError> {
        sync_dir(&self.staging);
        if self.target.exists() {
            if !exchange(&self.staging, &self.target)? {
                // no atomic exchange here: move the old folder aside, then the new one in
                let old = sibling(&self.target, &format!(".old-{}", std::process::id()));
                rename(&self.target, &old).map_err(FileError::io(&self.target))?;
                if let Err(e) = rename(&self.staging, &self.target) {
                    let _ = rename(&old, &self.target);
                    return Err(FileError::io(&self.target)(e));
                }
                let _ = std::fs::remove_dir_all(&old);
                self.committed = true;
                return Ok(());
            }
            // the staging path now holds the old folder
            let _ = std::fs::remove_dir_all(&self.staging);
        } else {
            rename(&self.staging, &self.target).map_err(FileError::io(&self.target))?;
        }
        if let Some(parent) = self.target.parent() {
            sync_dir(parent);
        }
        self.committed = true;
        Ok(())
    }
}

impl Drop for StagedDir {
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_dir_all(&self.staging);
        }
    }
}

/// Flushes a folder's entries to disk (best effort).
fn sync_dir(dir: &Path) {
    if let Ok(f) = std::fs::File::open(dir) {
        let _ = f.sync_all();
    }
}

/// Atomically exchanges two paths. `Ok(false)` where the system has no such call.
#[cfg(target_os = "linux")]
fn exchange(a: &Path, b: &Path) -> Result<bool, FileError> {
    use std::ffi::CString;
    use std::os::unix::ffi::OsStrExt;
    // through the hook first, so tests can fail or kill at this rename too
    hook().map_err(FileError::io(b))?;
    let c =
        |p: &Path| CString::new(p.as_os_str().as_bytes()).map_err(|_| FileError::invalid(p, "path", "contains NUL"));
    let (ca, cb) = (c(a)?, c(b)?);
    // SAFETY: both are valid NUL-terminated paths; renameat2 only reads them.
    let r = unsafe { libc::renameat2(libc::AT_FDCWD, ca.as_ptr(), libc::AT_FDCWD, cb.as_ptr(), libc::RENAME_EXCHANGE) };
    if r == 0 {
        return Ok(true);
    }
    let e = std::io::Error::last_os_error();
    match e.raw_os_error() {
        // the filesystem or kernel does not support the exchange
        Some(libc::EINVAL) | Some(libc::ENOSYS) | Some(libc::EOPNOTSUPP) => Ok(false),
        _ => Err(FileError::io(b)(e)),
    }
}

#[cfg(not(target_os = "linux"))]
fn exchange(_a: &Path, _b: &Path) -> Result<bool, FileError> {
    Ok(false)
}

/// Copies folder `from` into `to` (created), hard-linking files where the filesystem allows
/// (a reused bake costs no space), copying otherwise. Only regular files and folders.
pub fn link_or_copy_dir(from: &Path, to: &Path) -> Result<(), FileError> {
    std::fs::create_dir_all(to).map_err(FileError::io(to))?;
    for e in std::fs::read_dir(from).map_err(FileError::io(from))? {
        let e = e.map_err(FileError::io(from))?;
        let (src, dst) = (e.path(), to.join(e.file_name()));
        let t = e.file_type().map_err(FileError::io(&src))?;
        if t.is_dir() {
            link_or_copy_dir(&src, &dst)?;
        } else if t.is_file() && std::fs::hard_link(&src, &dst).is_err() {
            std::fs::copy(&src, &dst).map_err(FileError::io(&src))?;
        }
    }
    Ok(())
}

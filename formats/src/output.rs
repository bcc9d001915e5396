//! Output files that appear only when complete.

use std::fs::File;
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use tempfile::{NamedTempFile, TempDir};

/// A file written under a temporary name in the target's directory and
/// renamed to the target by [`AtomicFile::commit`]. Dropped without a
/// commit (an error, a panic), the temporary file is removed, so a failed
/// write never leaves a partial file at the target path. A target that
/// exists and is not a regular file (`/dev/null`, a FIFO, a terminal) is
/// written in place: renaming over it would replace the device node.
pub struct AtomicFile {
    inner: Inner,
}

/// Where an [`AtomicFile`] writes.
enum Inner {
    /// A temporary file, renamed to `target` on commit.
    Temp {
        temp: NamedTempFile,
        target: PathBuf,
    },
    /// The target itself, a device or pipe.
    Direct(File),
}

/// Whether `target` exists and is not a regular file (nor a directory):
/// a device, FIFO or socket, written in place.
fn is_special(target: &Path) -> bool {
    std::fs::metadata(target).is_ok_and(|m| !m.is_file() && !m.is_dir())
}

impl AtomicFile {
    /// Start writing what will become `target`. Temporary files of earlier
    /// writes to the same target whose writers are gone (killed) are
    /// removed first; see [`temp_file_in`].
    pub fn create(target: &Path) -> io::Result<AtomicFile> {
        if is_special(target) {
            let file = std::fs::OpenOptions::new().write(true).open(target)?;
            return Ok(AtomicFile {
                inner: Inner::Direct(file),
            });
        }
        let dir = parent_dir(target);
        let temp = temp_file_in(&dir, &temp_prefix(target), PARTIAL).map_err(|e| {
            io::Error::new(
                e.kind(),
                format!("cannot create a file in {}: {}", dir.display(), e.kind()),
            )
        })?;
        Ok(AtomicFile {
            inner: Inner::Temp {
                temp,
                target: target.to_path_buf(),
            },
        })
    }

    /// Remove the temporary file now (instead of when dropped), reporting
    /// whether that worked: a caller that failed with a full disk says the
    /// partial output is gone.
    pub fn discard(self) -> io::Result<()> {
        match self.inner {
            Inner::Temp { temp, .. } => temp.close(),
            Inner::Direct(_) => Ok(()),
        }
    }

    /// The open temporary file.
    pub fn file(&mut self) -> &mut File {
        match &mut self.inner {
            Inner::Temp { temp, .. } => temp.as_file_mut(),
            Inner::Direct(f) => f,
        }
    }

    /// A second handle on the temporary file, sharing its position: for a
    /// writer (an encoder) that owns what it writes to while this waits
    /// for [`AtomicFile::commit`]. Whatever the handle buffers must be
    /// flushed before the commit.
    pub fn handle(&self) -> io::Result<File> {
        match &self.inner {
            Inner::Temp { temp, .. } => temp.as_file().try_clone(),
            Inner::Direct(f) => f.try_clone(),
        }
    }

    /// Flush, give the file ordinary permissions (those of the file it
    /// replaces, else read-write for the owner and readable by everyone,
    /// rather than the temporary file's owner-only mode), and rename into
    /// place.
    pub fn commit(self) -> io::Result<()> {
        let (mut temp, target) = match self.inner {
            Inner::Temp { temp, target } => (temp, target),
            Inner::Direct(mut f) => return f.flush(),
        };
        temp.as_file_mut().flush()?;
        let perms = match std::fs::metadata(&target) {
            Ok(m) => Some(m.permissions()),
            Err(_) => default_permissions(),
        };
        if let Some(p) = perms {
            temp.as_file().set_permissions(p)?;
        }
        temp.persist(&target).map(|_| ()).map_err(|e| e.error)
    }
}

/// The directory a file at `target` will be created in.
pub fn parent_dir(target: &Path) -> PathBuf {
    match target.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// The suffix of every temporary output (file or directory).
pub const PARTIAL: &str = ".partial";

/// The start of the names of `target`'s temporary outputs: a temporary
/// file or directory for `dir/NAME` is `dir/.NAME.XXXXXX.partial`.
pub fn temp_prefix(target: &Path) -> String {
    let name = target
        .components()
        .next_back()
        .map(|n| n.as_os_str().to_string_lossy().into_owned())
        .unwrap_or_default();
    format!(".{name}.")
}

/// A temporary file `dir/PREFIXxxxxxxSUFFIX`, locked (`flock`, exclusive)
/// for as long as it is open. A writer that is killed cannot remove its
/// temporary file, but the kernel drops its lock: before creating one,
/// every unlocked file or directory of the same prefix and suffix in `dir`
/// is removed ([`sweep`]), so leftovers of killed writes never pile up
/// beyond one per target.
pub fn temp_file_in(dir: &Path, prefix: &str, suffix: &str) -> io::Result<NamedTempFile> {
    create_locked(
        dir,
        prefix,
        suffix,
        |b| b.tempfile_in(dir),
        |t| {
            lock_exclusive(t.as_file())?;
            Ok(still_at(t.as_file(), t.path()))
        },
    )
}

/// A temporary directory, as [`temp_file_in`] makes files: the returned
/// file is the directory, opened and locked for as long as it is kept.
pub fn temp_dir_in(dir: &Path, prefix: &str, suffix: &str) -> io::Result<(TempDir, File)> {
    create_locked(
        dir,
        prefix,
        suffix,
        |b| {
            let temp = b.tempdir_in(dir)?;
            let handle = File::open(temp.path())?;
            Ok((temp, handle))
        },
        |(temp, handle)| {
            lock_exclusive(handle)?;
            Ok(still_at(handle, temp.path()))
        },
    )
}

/// Sweep `dir` of dead temporaries, then `make` a temporary named
/// `PREFIXxxxxxxSUFFIX` and `lock` it (true: it is still at its name).
/// Another process's sweep may remove a new temporary between its
/// creation and the lock: then another is made (up to 8 tries).
fn create_locked<T>(
    dir: &Path,
    prefix: &str,
    suffix: &str,
    make: impl Fn(&tempfile::Builder) -> io::Result<T>,
    lock: impl Fn(&T) -> io::Result<bool>,
) -> io::Result<T> {
    sweep(dir, prefix, suffix);
    let mut builder = tempfile::Builder::new();
    builder.prefix(prefix).suffix(suffix);
    let mut tries = 0;
    loop {
        let temp = make(&builder)?;
        tries += 1;
        if lock(&temp)? || tries >= 8 {
            return Ok(temp);
        }
    }
}

/// Remove the files and directories `dir/PREFIX*SUFFIX` that no live
/// process holds locked: the temporary outputs of writers that were
/// killed. Best effort: what cannot be removed stays.
pub fn sweep(dir: &Path, prefix: &str, suffix: &str) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let name = e.file_name();
        let name = name.to_string_lossy();
        if name.len() <= prefix.len() + suffix.len()
            || !name.starts_with(prefix)
            || !name.ends_with(suffix)
        {
            continue;
        }
        let path = e.path();
        let Ok(handle) = File::open(&path) else {
            continue;
        };
        if !try_lock_exclusive(&handle) || !still_at(&handle, &path) {
            continue;
        }
        let _ = if handle.metadata().is_ok_and(|m| m.is_dir()) {
            std::fs::remove_dir_all(&path)
        } else {
            std::fs::remove_file(&path)
        };
    }
}

/// Put the complete directory `new` in place of the existing directory
/// `target` (both in one directory), then remove the directory replaced.
///
/// Where the file system swaps two names in one step (`renameat2` with
/// `RENAME_EXCHANGE` on Linux, `RENAME_SWAP` on macOS), that swap is the
/// commit point: `target` names the whole old directory or the whole new
/// one at every moment, and the old one is left at `new`'s name. Elsewhere
/// the old one is renamed aside first (to `.NAME.XXXXXX.old.partial`
/// for a `new` named `.NAME.XXXXXX.partial`), then `new` to `target`: a kill between the two renames leaves no `target`, the old
/// directory whole under the aside name. Either way the old directory is
/// then removed; what a kill or an error leaves of it has a temporary
/// output's name, which the next write of `target` sweeps (see
/// [`temp_dir_in`]).
pub fn replace_dir(new: &Path, target: &Path) -> io::Result<()> {
    let old = match swap_names(new, target) {
        Ok(()) => new.to_path_buf(),
        Err(e) if swap_unsupported(&e) => replace_aside(new, target)?,
        Err(e) => return Err(e),
    };
    // After the commit point: a failure here loses nothing.
    let _ = std::fs::remove_dir_all(&old);
    Ok(())
}

/// [`replace_dir`]'s two renames where names cannot be swapped: the old
/// directory's name after them.
fn replace_aside(new: &Path, target: &Path) -> io::Result<PathBuf> {
    let aside = aside_name(new);
    std::fs::rename(target, &aside)?;
    if let Err(e) = std::fs::rename(new, target) {
        let _ = std::fs::rename(&aside, target);
        return Err(e);
    }
    Ok(aside)
}

/// Where [`replace_dir`] puts the old directory when it cannot swap:
/// `.NAME.XXXXXX.partial` becomes `.NAME.XXXXXX.old.partial`, a temporary
/// output's name for the same target.
fn aside_name(new: &Path) -> PathBuf {
    let name = new
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let stem = name.strip_suffix(PARTIAL).unwrap_or(&name);
    new.with_file_name(format!("{stem}.old{PARTIAL}"))
}

/// Exchange the names `a` and `b` in one step.
#[cfg(any(target_os = "linux", target_os = "android", target_vendor = "apple"))]
fn swap_names(a: &Path, b: &Path) -> io::Result<()> {
    use rustix::fs::{renameat_with, RenameFlags, CWD};
    Ok(renameat_with(CWD, a, CWD, b, RenameFlags::EXCHANGE)?)
}

#[cfg(not(any(target_os = "linux", target_os = "android", target_vendor = "apple")))]
fn swap_names(_: &Path, _: &Path) -> io::Result<()> {
    Err(io::ErrorKind::Unsupported.into())
}

/// Whether [`swap_names`] failed for want of support (an old kernel, a
/// file system without it) rather than for a reason a rename would share.
fn swap_unsupported(e: &io::Error) -> bool {
    if e.kind() == io::ErrorKind::Unsupported {
        return true;
    }
    #[cfg(unix)]
    {
        use rustix::io::Errno;
        matches!(
            Errno::from_io_error(e),
            Some(Errno::INVAL | Errno::NOSYS | Errno::OPNOTSUPP)
        )
    }
    #[cfg(not(unix))]
    {
        false
    }
}

/// Take `f`'s exclusive lock, waiting for it (a sweep holds it briefly).
fn lock_exclusive(f: &File) -> io::Result<()> {
    #[cfg(unix)]
    {
        rustix::fs::flock(f, rustix::fs::FlockOperation::LockExclusive)?;
    }
    #[cfg(not(unix))]
    let _ = f;
    Ok(())
}

/// Take `f`'s exclusive lock if nobody holds it.
fn try_lock_exclusive(f: &File) -> bool {
    #[cfg(unix)]
    {
        rustix::fs::flock(f, rustix::fs::FlockOperation::NonBlockingLockExclusive).is_ok()
    }
    #[cfg(not(unix))]
    {
        // No way to tell a live writer's file from a dead one's.
        let _ = f;
        false
    }
}

/// Whether `path` still names the file open as `f`.
fn still_at(f: &File, path: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        match (f.metadata(), std::fs::symlink_metadata(path)) {
            (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
            _ => false,
        }
    }
    #[cfg(not(unix))]
    {
        let _ = f;
        path.exists()
    }
}

/// Bytes free for this user on the file system that holds (or will hold)
/// `target`; `None` where that cannot be asked.
pub fn free_space(target: &Path) -> Option<u64> {
    #[cfg(unix)]
    {
        let v = rustix::fs::statvfs(parent_dir(target).as_path()).ok()?;
        Some(v.f_bavail.saturating_mul(v.f_frsize))
    }
    #[cfg(not(unix))]
    {
        let _ = target;
        None
    }
}

/// Refuse, before anything is written, an output of `bytes` that cannot fit
/// on the file system that holds `target`: an error of kind `StorageFull`
/// that gives both numbers. Where the free space cannot be asked, nothing
/// is refused (a full disk is still reported when a write fails).
pub fn check_space(target: &Path, bytes: u64) -> io::Result<()> {
    match free_space(target) {
        Some(free) if bytes > free => Err(io::Error::new(
            io::ErrorKind::StorageFull,
            format!(
                "the output needs {bytes} bytes ({}) but the file system holding {} has {free} bytes ({}) free",
                human_bytes(bytes),
                parent_dir(target).display(),
                human_bytes(free)
            ),
        )),
        _ => Ok(()),
    }
}

/// A byte count for people: `1.5 GiB`, `281.0 TiB`.
pub fn human_bytes(b: u64) -> String {
    const UNITS: [&str; 7] = ["bytes", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"];
    let mut v = b as f64;
    let mut u = 0;
    while v >= 1024.0 && u + 1 < UNITS.len() {
        v /= 1024.0;
        u += 1;
    }
    if u == 0 {
        format!("{b} bytes")
    } else {
        format!("{v:.1} {}", UNITS[u])
    }
}

/// Whether an I/O error says the disk (or the user's quota) is full.
pub fn is_disk_full(e: &io::Error) -> bool {
    matches!(
        e.kind(),
        io::ErrorKind::StorageFull | io::ErrorKind::QuotaExceeded | io::ErrorKind::FileTooLarge
    )
}

/// Permissions for a new output file: `rw-r--r--` on Unix (temporary
/// files start owner-only); elsewhere whatever the system gave it.
fn default_permissions() -> Option<std::fs::Permissions> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        Some(std::fs::Permissions::from_mode(0o644))
    }
    #[cfg(not(unix))]
    {
        None
    }
}

/// Where a writer sends its bytes.
pub enum Sink<'a> {
    /// A seekable file (headers are patched at the end).
    File(&'a mut File),
    /// A stream such as standard output (written once, front to back).
    Stream(&'a mut (dyn Write + Send)),
    /// A seekable file the writer owns, such as [`AtomicFile::handle`]
    /// (for a writer that owns its output and is committed after).
    OwnedFile(File),
    /// A stream the writer owns.
    OwnedStream(Box<dyn Write + Send + 'a>),
}

impl Sink<'_> {
    /// Whether the sink is seekable (a file).
    pub fn is_file(&self) -> bool {
        matches!(self, Sink::File(_) | Sink::OwnedFile(_))
    }

    /// The file, when the sink is one.
    pub fn file(&mut self) -> Option<&mut File> {
        match self {
            Sink::File(f) => Some(f),
            Sink::OwnedFile(f) => Some(f),
            Sink::Stream(_) | Sink::OwnedStream(_) => None,
        }
    }

    /// Where the bytes go.
    pub fn writer(&mut self) -> &mut (dyn Write + Send) {
        match self {
            Sink::File(f) => *f,
            Sink::OwnedFile(f) => f,
            Sink::Stream(s) => *s,
            Sink::OwnedStream(s) => s,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn space_is_checked_against_the_file_system() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("out.vvol");
        check_space(&target, 0).unwrap();
        let e = check_space(&target, u64::MAX).unwrap_err();
        assert_eq!(e.kind(), io::ErrorKind::StorageFull);
        assert!(
            e.to_string().contains("needs 18446744073709551615 bytes"),
            "{e}"
        );
        assert!(is_disk_full(&e));
        assert!(free_space(&target).is_some());
    }

    #[test]
    fn a_handle_writes_where_the_file_does_and_the_commit_keeps_it() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("h.raw");
        let mut f = AtomicFile::create(&target).unwrap();
        f.file().write_all(b"head ").unwrap();
        {
            let mut sink = Sink::OwnedFile(f.handle().unwrap());
            assert!(sink.is_file());
            sink.writer().write_all(b"body").unwrap();
        }
        f.file().write_all(b" tail").unwrap();
        assert!(!target.exists());
        f.commit().unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"head body tail");
        // Dropped uncommitted, a handle's writes go with the temporary.
        let f = AtomicFile::create(&dir.path().join("gone.raw")).unwrap();
        f.handle().unwrap().write_all(b"x").unwrap();
        drop(f);
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn byte_counts_for_people() {
        assert_eq!(human_bytes(512), "512 bytes");
        assert_eq!(human_bytes(1536), "1.5 KiB");
        assert_eq!(human_bytes(1 << 48), "256.0 TiB");
        assert_eq!(human_bytes(u64::MAX), "16.0 EiB");
    }

    #[test]
    fn leftovers_of_dead_writers_are_swept_live_ones_kept() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("a.raw");
        // A killed writer's file: nobody holds its lock.
        let (_, dead) = tempfile::Builder::new()
            .prefix(".a.raw.")
            .suffix(PARTIAL)
            .tempfile_in(dir.path())
            .unwrap()
            .keep()
            .unwrap();
        // A dead writer's staging directory, and another target's file.
        let dead_dir = tempfile::Builder::new()
            .prefix(".a.raw.")
            .suffix(PARTIAL)
            .tempdir_in(dir.path())
            .unwrap()
            .keep();
        std::fs::write(dead_dir.join("x"), b"x").unwrap();
        std::fs::write(dir.path().join(".b.raw.123456.partial"), b"b").unwrap();
        let live = AtomicFile::create(&target).unwrap();
        assert!(!dead.exists() && !dead_dir.exists());
        assert!(dir.path().join(".b.raw.123456.partial").exists());
        // A second writer of the same target leaves the live one alone.
        let second = AtomicFile::create(&target).unwrap();
        let temp = |f: &AtomicFile| match &f.inner {
            Inner::Temp { temp, .. } => temp.path().to_path_buf(),
            Inner::Direct(_) => unreachable!("a regular target"),
        };
        assert!(temp(&live).exists() && temp(&second).exists());
        second.commit().unwrap();
        assert!(temp(&live).exists());
    }

    /// `-o /dev/null` writes to the device: renaming over it would have
    /// replaced the device node with a regular file.
    #[test]
    fn a_device_target_is_written_in_place() {
        use std::os::unix::fs::FileTypeExt;
        let null = Path::new("/dev/null");
        let mut f = AtomicFile::create(null).unwrap();
        f.file().write_all(b"discarded").unwrap();
        f.commit().unwrap();
        let m = std::fs::metadata(null).unwrap();
        assert!(m.file_type().is_char_device());
        assert_eq!(m.len(), 0);
    }

    /// A directory of `files` (name, contents) at `dir`.
    fn tree(dir: &Path, files: &[(&str, &str)]) {
        std::fs::create_dir(dir).unwrap();
        for (n, t) in files {
            std::fs::write(dir.join(n), t).unwrap();
        }
    }

    fn names(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn a_directory_replaces_another_whole_and_the_old_one_goes() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("s.ome.zarr");
        let new = dir.path().join(".s.ome.zarr.abc123.partial");
        tree(&target, &[("old", "1"), ("both", "old")]);
        tree(&new, &[("new", "2"), ("both", "new")]);
        replace_dir(&new, &target).unwrap();
        assert_eq!(names(&target), ["both", "new"]);
        assert_eq!(std::fs::read_to_string(target.join("both")).unwrap(), "new");
        assert_eq!(names(dir.path()), ["s.ome.zarr"]);
        // Without the swap: aside, in, and the old one removed.
        let new = dir.path().join(".s.ome.zarr.def456.partial");
        tree(&new, &[("third", "3")]);
        assert_eq!(
            aside_name(&new),
            dir.path().join(".s.ome.zarr.def456.old.partial")
        );
        let old = replace_aside(&new, &target).unwrap();
        assert_eq!(names(&old), ["both", "new"]);
        assert_eq!(names(&target), ["third"]);
        std::fs::remove_dir_all(&old).unwrap();
        // A failed swap changes nothing.
        let missing = dir.path().join(".s.ome.zarr.none.partial");
        assert!(replace_dir(&missing, &target).is_err());
        assert_eq!(names(&target), ["third"]);
        assert_eq!(names(dir.path()), ["s.ome.zarr"]);
    }

    #[test]
    fn discard_removes_the_temporary_file() {
        let dir = tempfile::tempdir().unwrap();
        let mut f = AtomicFile::create(&dir.path().join("a.raw")).unwrap();
        f.file().write_all(b"partial").unwrap();
        f.discard().unwrap();
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }
}

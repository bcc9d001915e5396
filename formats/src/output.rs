//! Output files that appear only when complete.

use std::fs::File;
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use tempfile::NamedTempFile;

/// A file written under a temporary name in the target's directory and
/// renamed to the target by [`AtomicFile::commit`]. Dropped without a
/// commit (an error, a panic), the temporary file is removed, so a failed
/// write never leaves a partial file at the target path.
pub struct AtomicFile {
    temp: NamedTempFile,
    target: PathBuf,
}

impl AtomicFile {
    /// Start writing what will become `target`.
    pub fn create(target: &Path) -> io::Result<AtomicFile> {
        let dir = match target.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let name = target
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let temp = tempfile::Builder::new()
            .prefix(&format!(".{name}."))
            .suffix(".partial")
            .tempfile_in(&dir)
            .map_err(|e| {
                io::Error::new(
                    e.kind(),
                    format!("cannot create a file in {}: {}", dir.display(), e.kind()),
                )
            })?;
        Ok(AtomicFile {
            temp,
            target: target.to_path_buf(),
        })
    }

    /// Remove the temporary file now (instead of when dropped), reporting
    /// whether that worked: a caller that failed with a full disk says the
    /// partial output is gone.
    pub fn discard(self) -> io::Result<()> {
        self.temp.close()
    }

    /// The open temporary file.
    pub fn file(&mut self) -> &mut File {
        self.temp.as_file_mut()
    }

    /// Flush, give the file ordinary permissions (those of the file it
    /// replaces, else read-write for the owner and readable by everyone,
    /// rather than the temporary file's owner-only mode), and rename into
    /// place.
    pub fn commit(mut self) -> io::Result<()> {
        self.temp.as_file_mut().flush()?;
        let perms = match std::fs::metadata(&self.target) {
            Ok(m) => Some(m.permissions()),
            Err(_) => default_permissions(),
        };
        if let Some(p) = perms {
            self.temp.as_file().set_permissions(p)?;
        }
        self.temp
            .persist(&self.target)
            .map(|_| ())
            .map_err(|e| e.error)
    }
}

/// The directory a file at `target` will be created in.
fn parent_dir(target: &Path) -> PathBuf {
    match target.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
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
    fn byte_counts_for_people() {
        assert_eq!(human_bytes(512), "512 bytes");
        assert_eq!(human_bytes(1536), "1.5 KiB");
        assert_eq!(human_bytes(1 << 48), "256.0 TiB");
        assert_eq!(human_bytes(u64::MAX), "16.0 EiB");
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

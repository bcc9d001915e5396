//! Standard output as a file, for the tools that stream a volume to `-`.

/// Standard output as an unbuffered file (a duplicate of descriptor 1).
pub fn stdout_file() -> std::io::Result<std::fs::File> {
    use std::os::fd::AsFd;
    let fd = std::io::stdout().as_fd().try_clone_to_owned()?;
    Ok(std::fs::File::from(fd))
}

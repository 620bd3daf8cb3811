//! Reading input files: regular files only, opened without blocking (a FIFO would wait for a
//! writer, a device never end), and never more of them than their size says — a `/proc` file
//! reports a size of 0 and can hold gigabytes (`/proc/self/pagemap`), a file growing while
//! read could hold anything: either is an error, not read without bound. The size is what the
//! caller counted in its memory budget.

use std::fs::File;
use std::io::{Error, ErrorKind, Read};
use std::path::Path;

/// Opens `path` (symbolic links followed) for reading if it is a regular file; its size.
/// A directory or another kind of file is an error whose message says which.
pub fn open(path: &Path) -> std::io::Result<(File, u64)> {
    use std::os::unix::fs::OpenOptionsExt;
    let file = std::fs::OpenOptions::new().read(true).custom_flags(libc::O_NONBLOCK | libc::O_NOCTTY).open(path)?;
    // The open file's own metadata: what is read is what was checked.
    let meta = file.metadata()?;
    if meta.is_dir() {
        return Err(Error::new(ErrorKind::IsADirectory, "is a directory, expected a file"));
    }
    if !meta.is_file() {
        return Err(Error::other("is not a regular file (a FIFO, socket or device?)"));
    }
    Ok((file, meta.len()))
}

/// The bytes of `file`, whose size is `len`, read up to `len` and no further: a file that
/// holds more is an error.
pub fn read_opened(file: File, len: u64) -> std::io::Result<Vec<u8>> {
    // Preallocated only up to a modest size: `len` may be a lie in either direction.
    let mut bytes = Vec::with_capacity(len.min(1 << 26) as usize);
    file.take(len.saturating_add(1)).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > len {
        return Err(Error::other(format!(
            "holds more than the {len} bytes its size says (a file of /proc or /sys, or one growing while read): \
             not read"
        )));
    }
    Ok(bytes)
}

/// The first `most` bytes of `file` (fewer if it is shorter): the part a caller uses.
pub fn read_prefix(file: File, most: u64) -> std::io::Result<Vec<u8>> {
    let mut bytes = Vec::with_capacity(most.min(1 << 26) as usize);
    file.take(most).read_to_end(&mut bytes)?;
    Ok(bytes)
}

/// The bytes of the regular file `path` ([`open`], [`read_opened`]).
pub fn read(path: &Path) -> std::io::Result<Vec<u8>> {
    let (file, len) = open(path)?;
    read_opened(file, len)
}

/// A short message for a reading error: `no such file`, `permission denied`, or the error.
pub fn describe(e: &Error) -> String {
    match e.kind() {
        ErrorKind::NotFound => "no such file".into(),
        ErrorKind::PermissionDenied => "permission denied".into(),
        ErrorKind::IsADirectory | ErrorKind::Other => e.to_string(),
        _ => format!("cannot read: {e}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn special_files_are_refused_or_read_with_a_bound() {
        // /proc files say 0 bytes and can hold gigabytes: one byte past their size is read.
        let e = read(Path::new("/proc/self/status")).unwrap_err();
        assert!(e.to_string().starts_with("holds more than the 0 bytes its size says"), "{e}");
        // /proc/self/pagemap refuses so short a read: an error too.
        assert!(read(Path::new("/proc/self/pagemap")).is_err());
        assert_eq!(
            describe(&read(Path::new("/dev/null")).unwrap_err()),
            "is not a regular file (a FIFO, socket or device?)"
        );
        assert_eq!(describe(&read(Path::new("/")).unwrap_err()), "is a directory, expected a file");
        assert_eq!(describe(&read(Path::new("/nonexistent/x")).unwrap_err()), "no such file");
        let me = std::env::current_exe().unwrap();
        assert_eq!(read(&me).unwrap().len() as u64, std::fs::metadata(&me).unwrap().len());
    }
}

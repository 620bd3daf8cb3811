//! Reading input files: only regular files are opened (a FIFO or device would block or never
//! end), never more than their size says ([`crate::regular_file`]), and reading problems become
//! [`SceneError`]s naming the file.
//!
//! Files a model names inside itself (a glTF's buffers and images, an OBJ's MTL libraries) are
//! read only where [`named_file`] allows: a model may come from anyone (an upload to a render
//! farm), and must not make ember read, or quote in a message, a file its user never named.

use super::SceneError;
use std::path::{Path, PathBuf};

/// Opens the regular file `path` (symbolic links followed); the open file and its length.
pub(super) fn open(path: &Path) -> Result<(std::fs::File, u64), SceneError> {
    crate::regular_file::open(path).map_err(|e| SceneError::new(path, None, crate::regular_file::describe(&e)))
}

/// The length of `path` if it is a regular file (symbolic links followed).
pub(super) fn regular_file_len(path: &Path) -> Result<u64, SceneError> {
    open(path).map(|(_, len)| len)
}

/// The bytes of the regular file `path`.
pub(super) fn read(path: &Path) -> Result<Vec<u8>, SceneError> {
    let (file, len) = open(path)?;
    crate::regular_file::read_opened(file, len)
        .map_err(|e| SceneError::new(path, None, crate::regular_file::describe(&e)))
}

/// The text of the regular file `path`, which must be UTF-8.
pub(super) fn read_to_string(path: &Path) -> Result<String, SceneError> {
    let bytes = read(path)?;
    String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        let line = e.as_bytes()[..at].iter().filter(|&&b| b == b'\n').count() + 1;
        SceneError::new(path, Some(line), "is not UTF-8 text")
    })
}

/// Folders whose files are never read as a model's files, whatever the options: the kernel's
/// views of processes and devices.
const SYSTEM_FOLDERS: [&str; 3] = ["/proc", "/sys", "/dev"];

/// The file a model (the file `model`) names as `name`, relative to the model's folder, if the
/// model may read it; else why not, naming only `name` and what it resolves to:
/// - an absolute name is refused (glTF's URIs are relative; an OBJ's libraries sit beside it);
/// - once `..` and symbolic links are resolved, the file must be inside the model's folder
///   (or a folder below it), unless `anywhere` (`--allow-external-files`);
/// - never a file under `/proc`, `/sys` or `/dev`, nor anything but a regular file.
///
/// The path returned is the resolved one: what was checked is what is read.
pub fn named_file(model: &Path, name: &str, anywhere: bool) -> Result<PathBuf, String> {
    if Path::new(name).is_absolute() {
        return Err(format!(
            "{name:?} is an absolute path: a model's files are read from its own folder, by relative names"
        ));
    }
    let folder = crate::atomic_write::folder_of(model);
    let joined = folder.join(name);
    let resolved = std::fs::canonicalize(&joined)
        .map_err(|e| format!("{name:?} ({}): {}", joined.display(), crate::regular_file::describe(&e)))?;
    if let Some(system) = SYSTEM_FOLDERS.iter().find(|f| resolved.starts_with(f)) {
        return Err(format!("{name:?} resolves to {}, under {system}: never read", resolved.display()));
    }
    if !anywhere {
        let inside = std::fs::canonicalize(folder).is_ok_and(|f| resolved.starts_with(f));
        if !inside {
            return Err(format!(
                "{name:?} resolves to {}, outside the model's folder: not read (--allow-external-files reads \
                 files anywhere)",
                resolved.display()
            ));
        }
    }
    Ok(resolved)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_model_reads_only_the_files_of_its_folder() {
        let d = std::env::temp_dir().join(format!("ember-named-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(d.join("model/sub")).unwrap();
        std::fs::write(d.join("model/sub/a.bin"), "a").unwrap();
        std::fs::write(d.join("secret"), "s").unwrap();
        std::os::unix::fs::symlink(d.join("secret"), d.join("model/link")).unwrap();
        std::os::unix::fs::symlink("/proc/self/environ", d.join("model/env")).unwrap();
        let model = d.join("model/m.gltf");
        let real = std::fs::canonicalize(&d).unwrap();
        assert_eq!(named_file(&model, "sub/a.bin", false), Ok(real.join("model/sub/a.bin")));
        assert_eq!(named_file(&model, "sub/../sub/a.bin", false), Ok(real.join("model/sub/a.bin")));
        for (name, says) in [
            ("../secret", "outside the model's folder"),
            ("link", "outside the model's folder"),
            ("sub/../../secret", "outside the model's folder"),
            ("/etc/passwd", "is an absolute path"),
            ("env", "under /proc: never read"),
            ("missing", "no such file"),
        ] {
            let e = named_file(&model, name, false).unwrap_err();
            assert!(e.contains(says), "{name}: {e}");
        }
        // --allow-external-files: outside the folder, but still no system files.
        assert_eq!(named_file(&model, "../secret", true), Ok(real.join("secret")));
        assert_eq!(named_file(&model, "link", true), Ok(real.join("secret")));
        assert!(named_file(&model, "env", true).unwrap_err().contains("under /proc"));
        assert!(named_file(&model, "/etc/passwd", true).unwrap_err().contains("absolute"));
        std::fs::remove_dir_all(&d).unwrap();
    }
}

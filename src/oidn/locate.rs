//! Where the library is looked for, in order:
//!
//! 1. `$EMBER_OIDN_DIR/libOpenImageDenoise.so.2` if `EMBER_OIDN_DIR` is set (and only there);
//! 2. the folder `scripts/fetch-oidn.sh` fills by default, recorded by `build.rs` at build time
//!    (`~/.cache/ember/oidn-2.5.1/lib`, or under `$XDG_CACHE_HOME`), if the library is there;
//! 3. the standard library path (`dlopen("libOpenImageDenoise.so.2")`: `LD_LIBRARY_PATH`,
//!    `ld.so.cache`, `/usr/lib`...), e.g. for a system-wide OIDN 2.x.

use super::error::{Attempt, DenoiseError};
use super::ffi::{self, Api, LoadFailure};
use std::path::{Path, PathBuf};

/// The environment variable naming the folder that holds the library.
pub const DIR_VARIABLE: &str = "EMBER_OIDN_DIR";

/// The command that installs the library (absolute: it works from any directory).
pub(super) const FETCH_SCRIPT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/scripts/fetch-oidn.sh");

/// The folder `scripts/fetch-oidn.sh` fills by default, as `build.rs` computed it; `None` if
/// neither `XDG_CACHE_HOME` nor `HOME` was set at build time.
pub fn default_dir() -> Option<PathBuf> {
    Some(env!("EMBER_OIDN_DEFAULT_DIR")).filter(|d| !d.is_empty()).map(PathBuf::from)
}

pub(super) fn default_dir_display() -> String {
    match default_dir() {
        Some(d) => d.display().to_string(),
        None => String::from("~/.cache/ember/oidn-2.5.1/lib"),
    }
}

/// Loads the library from `dir` if given (and only there), else through the search order above.
pub(super) fn load(dir: Option<&Path>) -> Result<&'static Api, DenoiseError> {
    let mut attempts = Vec::new();
    let places: Vec<(Option<PathBuf>, &'static str)> = match dir {
        Some(d) => vec![(Some(d.to_path_buf()), "given folder")],
        None => match std::env::var_os(DIR_VARIABLE).filter(|v| !v.is_empty()) {
            Some(d) => vec![(Some(PathBuf::from(d)), DIR_VARIABLE)],
            None => {
                let mut p = Vec::new();
                if let Some(d) = default_dir() {
                    p.push((Some(d), "default folder of scripts/fetch-oidn.sh"));
                }
                p.push((None, "standard library path"));
                p
            }
        },
    };
    for (folder, source) in places {
        let file = match &folder {
            Some(f) => {
                let path = f.join(ffi::LIBRARY_NAME);
                if !path.exists() {
                    attempts.push(Attempt {
                        file: path.display().to_string(),
                        source,
                        reason: String::from("does not exist"),
                    });
                    continue;
                }
                match path.to_str() {
                    Some(s) => s.to_string(),
                    None => {
                        attempts.push(Attempt {
                            file: path.display().to_string(),
                            source,
                            reason: String::from("the path is not valid UTF-8"),
                        });
                        continue;
                    }
                }
            }
            None => ffi::LIBRARY_NAME.to_string(),
        };
        match ffi::load(&file) {
            Ok(api) => return Ok(api),
            Err(LoadFailure::Open(reason)) => attempts.push(Attempt { file, source, reason }),
            Err(LoadFailure::Unusable(e)) => return Err(e),
        }
    }
    Err(DenoiseError::LibraryNotFound { attempts })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// build.rs and scripts/fetch-oidn.sh must agree on the default folder.
    #[test]
    fn the_default_folder_is_the_one_fetch_oidn_fills() {
        let dir = default_dir().expect("HOME or XDG_CACHE_HOME was set at build time");
        assert!(dir.ends_with("ember/oidn-2.5.1/lib"), "{}", dir.display());
        let script = std::fs::read_to_string(FETCH_SCRIPT).unwrap();
        for line in [
            "VERSION=2.5.1",
            "cache_root=${XDG_CACHE_HOME:-${HOME:?HOME is not set}/.cache}",
            "/ember/oidn-$VERSION}}",
            "lib=\"$dir/lib\"",
        ] {
            assert!(script.contains(line), "scripts/fetch-oidn.sh no longer has {line:?}");
        }
    }
}

//! Generates Embree 3 bindings with bindgen from Debian's headers and links `embree3`.
//!
//! With the `embree4` feature the bindings come from the `embree4-sys` crate instead (it links
//! `embree4` without a search path); this script then only locates `libembree4.so`: in
//! `EMBREE_DIR` if set (link search path plus an rpath, so binaries run without
//! `LD_LIBRARY_PATH`), else on the standard library path.
//!
//! Open Image Denoise (the denoiser, `src/oidn/`) is not linked: it is loaded at run time. This
//! script only records the folder `scripts/fetch-oidn.sh` fills by default, as
//! `EMBER_OIDN_DEFAULT_DIR`, where the binaries look for it when `EMBER_OIDN_DIR` is not set.

use std::env;
use std::path::{Path, PathBuf};

const APT_HINT: &str = "install it with: sudo apt-get install libembree-dev libclang-dev";

fn main() {
    println!("cargo:rerun-if-changed=build.rs");
    println!("cargo:rerun-if-env-changed=EMBREE3_INCLUDE_DIR");
    record_oidn_default_dir();
    if env::var_os("CARGO_FEATURE_EMBREE4").is_some() {
        locate_embree4();
        return;
    }

    let include_dir =
        env::var_os("EMBREE3_INCLUDE_DIR").map(PathBuf::from).unwrap_or_else(|| PathBuf::from("/usr/include"));
    let header = include_dir.join("embree3/rtcore.h");
    if !header.is_file() {
        fail(&format!(
            "the Embree 3 header {} was not found; {APT_HINT} \
             (or set EMBREE3_INCLUDE_DIR to the folder that holds embree3/rtcore.h)",
            header.display()
        ));
    }
    println!("cargo:rerun-if-changed={}", header.display());

    let bindings = std::panic::catch_unwind(|| generate(&include_dir, &header));
    let bindings = match bindings {
        Ok(Ok(b)) => b,
        Ok(Err(e)) => fail(&format!("bindgen could not process {}: {e}; {APT_HINT}", header.display())),
        // bindgen panics when it cannot load libclang.
        Err(_) => fail(&format!("bindgen could not load libclang; {APT_HINT}")),
    };
    let out = PathBuf::from(env::var("OUT_DIR").expect("cargo sets OUT_DIR")).join("embree3_bindings.rs");
    bindings.write_to_file(&out).unwrap_or_else(|e| fail(&format!("cannot write {}: {e}", out.display())));

    if let Some(dir) = env::var_os("EMBREE3_LIB_DIR") {
        println!("cargo:rustc-link-search=native={}", Path::new(&dir).display());
    }
    println!("cargo:rerun-if-env-changed=EMBREE3_LIB_DIR");
    println!("cargo:rustc-link-lib=dylib=embree3");
}

const EMBREE4_HINT: &str = "set EMBREE_DIR to the folder holding libembree4.so \
     (`export EMBREE_DIR=\"$(scripts/fetch-embree4.sh)\"` fetches Embree 4.4 for Debian 12), \
     or install Embree 4 from your distribution (Debian 13, Ubuntu 24.04: sudo apt-get install libembree-dev)";

/// Finds `libembree4.so` for the `embree4` feature: `EMBREE_DIR`, then the standard path.
fn locate_embree4() {
    println!("cargo:rerun-if-env-changed=EMBREE_DIR");
    println!("cargo:rerun-if-env-changed=LIBRARY_PATH");
    if let Some(dir) = env::var_os("EMBREE_DIR").filter(|d| !d.is_empty()) {
        let dir = PathBuf::from(dir);
        let lib = dir.join("libembree4.so");
        if !lib.exists() {
            fail(&format!("EMBREE_DIR is {}, but {} does not exist; {EMBREE4_HINT}", dir.display(), lib.display()));
        }
        let dir = dir.canonicalize().unwrap_or(dir);
        println!("cargo:rerun-if-changed={}", lib.display());
        println!("cargo:rustc-link-search=native={}", dir.display());
        // Binaries, tests and benches find the library (and its TBB, through the library's own
        // rpath) at run time without LD_LIBRARY_PATH.
        println!("cargo:rustc-link-arg=-Wl,-rpath,{}", dir.display());
        return;
    }
    let mut dirs: Vec<PathBuf> =
        env::var_os("LIBRARY_PATH").map(|p| env::split_paths(&p).collect()).unwrap_or_default();
    let multiarch = format!("/usr/lib/{}-linux-gnu", env::var("CARGO_CFG_TARGET_ARCH").unwrap_or_default());
    for d in ["/usr/local/lib", multiarch.as_str(), "/usr/lib", "/usr/lib64", "/lib"] {
        dirs.push(PathBuf::from(d));
    }
    if !dirs.iter().any(|d| d.join("libembree4.so").exists()) {
        fail(&format!("libembree4.so was not found on the standard library path; {EMBREE4_HINT}"));
    }
}

/// The default folder of `scripts/fetch-oidn.sh` (same rule as the script: `$XDG_CACHE_HOME`,
/// else `$HOME/.cache`, then `ember/oidn-2.5.1/lib`), recorded whether or not it exists yet: the
/// library may be fetched after the build. Empty if neither variable is set.
fn record_oidn_default_dir() {
    println!("cargo:rerun-if-env-changed=XDG_CACHE_HOME");
    println!("cargo:rerun-if-env-changed=HOME");
    let cache = env::var_os("XDG_CACHE_HOME")
        .filter(|d| !d.is_empty())
        .map(PathBuf::from)
        .or_else(|| env::var_os("HOME").filter(|d| !d.is_empty()).map(|h| PathBuf::from(h).join(".cache")));
    let dir = cache.map(|c| c.join("ember/oidn-2.5.1/lib").display().to_string()).unwrap_or_default();
    println!("cargo:rustc-env=EMBER_OIDN_DEFAULT_DIR={dir}");
}

fn generate(include_dir: &Path, header: &Path) -> Result<bindgen::Bindings, bindgen::BindgenError> {
    if !clang_available() {
        fail(&format!("libclang was not found; {APT_HINT}"));
    }
    bindgen::Builder::default()
        .header(header.to_string_lossy())
        .clang_arg(format!("-I{}", include_dir.display()))
        .allowlist_function("rtc.*")
        .allowlist_type("RTC.*")
        .allowlist_var("RTC.*")
        .default_enum_style(bindgen::EnumVariation::Consts)
        .prepend_enum_name(false)
        .derive_default(true)
        .layout_tests(true)
        .generate()
}

fn clang_available() -> bool {
    // bindgen's clang-sys looks in LIBCLANG_PATH and the usual llvm folders.
    if env::var_os("LIBCLANG_PATH").is_some() {
        return true;
    }
    let globs = ["/usr/lib/llvm-", "/usr/lib/x86_64-linux-gnu/libclang", "/usr/lib/libclang"];
    let mut found = false;
    for dir in ["/usr/lib", "/usr/lib/x86_64-linux-gnu", "/usr/lib64", "/usr/local/lib"] {
        if let Ok(entries) = std::fs::read_dir(dir) {
            for e in entries.flatten() {
                let p = e.path();
                let s = p.to_string_lossy();
                if globs.iter().any(|g| s.starts_with(g))
                    && (s.contains("libclang")
                        || p.join("lib").read_dir().is_ok_and(|mut d| {
                            d.any(|f| f.is_ok_and(|f| f.file_name().to_string_lossy().starts_with("libclang")))
                        }))
                {
                    found = true;
                }
            }
        }
    }
    found
}

fn fail(msg: &str) -> ! {
    eprintln!("error: {msg}");
    println!("cargo:warning={msg}");
    std::process::exit(1);
}

//! The TOML scene parser and scene building. Files the scene names are looked up in
//! `fuzz/assets/`, which holds small stand-ins with the names of the files in `scenes/`
//! (a few triangles, an 8x4 JPEG), so every execution stays fast.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    // The path-based loader refuses non-UTF-8 files before parsing.
    let Ok(text) = std::str::from_utf8(data) else { return };
    let path = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/assets/scene.toml"));
    let _ = ember::scene::Scene::from_toml_str(text, path);
});

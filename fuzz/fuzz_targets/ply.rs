//! The PLY loader (ASCII and both binary byte orders): the input is the file, read within a
//! memory limit of 256 MB. Loading must return `Ok` or `Err`, never panic, and never allocate
//! past the limit (the fuzzer's own limit, `-rss_limit_mb`, catches that).
#![no_main]

use ember::memory::{LoadBudget, MemoryLimit};
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let budget = LoadBudget::new(MemoryLimit::bytes(256_000_000));
    if let Ok(file) = ember::scene::mesh_file::ply::parse(data, data.len() as u64, Path::new("fuzz.ply"), &budget) {
        for m in &file.meshes {
            let n = m.mesh.positions.len() as u32;
            assert!(m.mesh.indices.iter().flatten().all(|&i| i < n));
        }
    }
});

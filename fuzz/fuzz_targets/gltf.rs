//! The glTF / GLB loader, through ember's door (`mesh_file::gltf::parse`: the checks made
//! before the `gltf` crate sees the JSON, the crate's parsing and validation, ember's reading
//! of buffers, accessors, images, materials, cameras and lights). The input is the file; the
//! files it names are looked for in `fuzz/assets/` (small stand-ins: a buffer, a PNG, a JPEG),
//! within a memory limit of 256 MB. Loading must return `Ok` or `Err`, never panic (the
//! fuzzer's panic hook aborts even where ember's door would catch a panic of the crate, so
//! every one is found).
#![no_main]

use ember::memory::{LoadBudget, MemoryLimit};
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let path = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/assets/model.gltf"));
    let budget = LoadBudget::new(MemoryLimit::bytes(256_000_000));
    if let Ok(file) = ember::scene::mesh_file::gltf::parse(data.to_vec(), path, &budget) {
        for m in &file.meshes {
            // Triangles with a corner that is not finite are dropped (its vertex may stay).
            let corners = m.mesh.indices.iter().flatten();
            assert!(corners.clone().all(|&i| m.mesh.positions.get(i as usize).is_some_and(|p| p.is_finite())));
            assert!(m.material.is_none_or(|i| i < file.materials.len()));
        }
        assert!(file.point_lights.iter().all(|l| l.position.is_finite() && l.intensity.is_finite()));
        assert!(file.camera.is_none_or(|c| c.position.is_finite()));
    }
});

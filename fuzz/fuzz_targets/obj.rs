//! The OBJ/MTL loading path: the input up to the first NUL byte is the OBJ file, the rest is
//! the MTL file every `mtllib` statement gets. Loading must return `Ok` or `Err`, never panic.
#![no_main]

use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let (obj, mtl) = match data.iter().position(|&b| b == 0) {
        Some(i) => (&data[..i], &data[i + 1..]),
        None => (data, &[][..]),
    };
    let _ = ember::scene::mesh_file::obj::parse_obj(
        obj,
        Path::new("fuzz/input.obj"),
        &|_| Ok(mtl.to_vec()),
        &ember::memory::LoadBudget::unlimited(),
    );
});

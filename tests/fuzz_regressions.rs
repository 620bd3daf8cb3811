//! Inputs the fuzzers (`fuzz/`) found crashing the loaders, reduced by hand; each must now give
//! an error or a warning that names the file and line, never a panic.

use ember::material::{DiffuseMaterial, MaterialKind};
use ember::scene::mesh_file::obj::parse_obj;
use ember::texture::Texture;
use std::path::Path;

const TRIANGLE: &str = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n";

/// Parses `obj` with every MTL library reading as `mtl`.
fn obj_with_mtl(obj: &str, mtl: &str) -> ember::scene::MeshFile {
    let mtl = mtl.as_bytes().to_vec();
    parse_obj(obj.as_bytes(), Path::new("dir/t.obj"), &|_| Ok(mtl.clone())).expect("the OBJ itself is valid")
}

/// tobj 4.0.5 unwraps a 3-element conversion in `parse_float3`: `Kd 1 0` panicked.
#[test]
fn mtl_colour_with_two_numbers_is_a_located_warning() {
    for (mtl, line, needle) in [
        ("newmtl a\nKd 1 0\n", 2, "Kd needs 3 numbers, found 2"),
        ("newmtl a\nKs 0 0 0\nKa\n", 3, "Ka needs 3 numbers, found 0"),
        ("newmtl a\n\nKe 1\n", 3, "Ke needs 3 numbers, found 1"),
    ] {
        let obj = obj_with_mtl(TRIANGLE, mtl);
        assert!(obj.materials.is_empty(), "{mtl:?}");
        assert_eq!(obj.triangle_count(), 1);
        let expected = format!("{}:{line}: {needle}", Path::new("dir/m.mtl").display());
        assert!(obj.warnings.iter().any(|w| w == &expected), "{mtl:?}: {:?}", obj.warnings);
    }
    // The well-formed library still loads.
    let obj = obj_with_mtl(TRIANGLE, "newmtl a\nKd 1 0 0\n");
    assert_eq!(obj.materials.len(), 1);
    assert_eq!(
        obj.materials[0].kind,
        MaterialKind::Diffuse(DiffuseMaterial { color: Texture::Constant(glam::Vec3::new(1.0, 0.0, 0.0)) })
    );
    assert_eq!(obj.meshes[0].material, Some(0));
}

/// Profiling the OBJ fuzzer showed most of its time going to inputs that repeat `mtllib`:
/// every repetition read and parsed the library again, and tobj appended its materials again.
/// A library is now read once.
#[test]
fn repeated_mtllib_reads_the_library_once() {
    let reads = std::cell::Cell::new(0);
    let obj = format!("{}{TRIANGLE}", "mtllib m.mtl\n".repeat(1000));
    let parsed = parse_obj(obj.as_bytes(), Path::new("dir/t.obj"), &|_| {
        reads.set(reads.get() + 1);
        Ok(b"newmtl a\nKd 1 0 0\nnewmtl b\nKd 0 1 0\n".to_vec())
    })
    .unwrap();
    assert_eq!(reads.get(), 1);
    assert_eq!(parsed.materials.len(), 2);
    assert_eq!(parsed.meshes[0].material, Some(0));
}

//! Inputs the fuzzers (`fuzz/`) found crashing the loaders, reduced by hand; each must give
//! an error that names the file and line, never a panic.

use ember::material::{DiffuseMaterial, MaterialKind};
use ember::memory::LoadBudget;
use ember::scene::mesh_file::obj::parse_obj;
use ember::texture::Texture;
use std::path::Path;

const TRIANGLE: &str = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\n";

/// Parses `obj` with every MTL library reading as `mtl`.
fn obj_with_mtl(obj: &str, mtl: &str) -> Result<ember::scene::MeshFile, ember::scene::SceneError> {
    let mtl = mtl.as_bytes().to_vec();
    parse_obj(obj.as_bytes(), Path::new("dir/t.obj"), &|_| Ok(mtl.clone()), &LoadBudget::unlimited())
}

/// tobj 4.0.5 unwraps a 3-element conversion in `parse_float3`: `Kd 1 0` panicked. Such a
/// line, and a value that is not finite or is negative, is an error naming the MTL file and
/// line.
#[test]
fn a_bad_mtl_line_is_a_located_error() {
    for (mtl, line, needle) in [
        ("newmtl a\nKd 1 0\n", 2, "Kd needs 3 numbers, found 2"),
        ("newmtl a\nKs 0 0 0\nKa\n", 3, "Ka needs 3 numbers, found 0"),
        ("newmtl a\n\nKe 1\n", 3, "Ke needs 3 numbers, found 1"),
        ("newmtl a\nKd nan inf -1\n", 2, "Kd: \"nan\" is not a finite number"),
        ("newmtl a\nKd 0.5 inf 1\n", 2, "Kd: \"inf\" is not a finite number"),
        ("newmtl a\nKd 0.5 0.5 -1\n", 2, "Kd: \"-1\" is negative"),
        ("newmtl a\nNs -3\n", 2, "Ns: \"-3\" is negative"),
    ] {
        let e = obj_with_mtl(TRIANGLE, mtl).expect_err(mtl);
        assert_eq!((e.path.as_path(), e.line), (Path::new("dir/m.mtl"), Some(line)), "{mtl:?}");
        assert_eq!(e.message, needle, "{mtl:?}");
    }
    // The well-formed library still loads.
    let obj = obj_with_mtl(TRIANGLE, "newmtl a\nKd 1 0 0\n").unwrap();
    assert_eq!(obj.materials.len(), 1);
    assert_eq!(
        obj.materials[0].kind,
        MaterialKind::Diffuse(DiffuseMaterial { color: Texture::Constant(glam::Vec3::new(1.0, 0.0, 0.0)) })
    );
    assert_eq!(obj.meshes[0].material, Some(0));
}

/// Profiling the OBJ fuzzer showed most of its time going to inputs that repeat `mtllib`:
/// every repetition read and parsed the library again, and tobj appended its materials again.
/// A library must be read once.
#[test]
fn repeated_mtllib_reads_the_library_once() {
    let reads = std::cell::Cell::new(0);
    let obj = format!("{}{TRIANGLE}", "mtllib m.mtl\n".repeat(1000));
    let read = |_: &Path| {
        reads.set(reads.get() + 1);
        Ok(b"newmtl a\nKd 1 0 0\nnewmtl b\nKd 0 1 0\n".to_vec())
    };
    let parsed = parse_obj(obj.as_bytes(), Path::new("dir/t.obj"), &read, &LoadBudget::unlimited()).unwrap();
    assert_eq!(reads.get(), 1);
    assert_eq!(parsed.materials.len(), 2);
    assert_eq!(parsed.meshes[0].material, Some(0));
}

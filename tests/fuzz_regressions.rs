//! Inputs the fuzzers (`fuzz/`) found crashing the loaders, reduced by hand; each must give
//! an error that names the file and line, never a panic.

use ember::material::{DiffuseMaterial, MaterialKind};
use ember::memory::LoadBudget;
use ember::scene::mesh_file::obj::parse_obj;
use ember::texture::{Encoding, Image, MipImage, Texture};
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

/// A one-triangle glTF (embedded buffer) with a textured material whose image is `image`, and
/// `cameras` (JSON, with a node for the first).
fn gltf_with(image: &str, cameras: &str) -> String {
    let mut buf: Vec<u8> =
        [0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0].iter().flat_map(|c| c.to_le_bytes()).collect();
    buf.extend([0f32, 0.0, 1.0, 0.0, 0.0, 1.0].iter().flat_map(|c| c.to_le_bytes()));
    let data = base64_encode(&buf);
    let camera_node = if cameras.is_empty() { "" } else { r#", {"camera": 0, "translation": [0, 0, 3]}"# };
    format!(
        r#"{{"asset": {{"version": "2.0"}}, "scenes": [{{"nodes": [0{}]}}], "nodes": [{{"mesh": 0}}{camera_node}],
        "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0, "TEXCOORD_0": 1}}, "material": 0}}]}}],
        "materials": [{{"pbrMetallicRoughness": {{"baseColorTexture": {{"index": 0}}}}}}],
        "textures": [{{"source": 0}}], "images": [{image}]{cameras},
        "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}},
                      {{"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC2"}}],
        "bufferViews": [{{"buffer": 0, "byteLength": 36}}, {{"buffer": 0, "byteOffset": 36, "byteLength": 24}}],
        "buffers": [{{"byteLength": 60, "uri": "data:application/octet-stream;base64,{data}"}}]}}"#,
        if cameras.is_empty() { "" } else { ", 1" }
    )
}

fn base64_encode(bytes: &[u8]) -> String {
    const ABC: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for c in bytes.chunks(3) {
        let n = (c[0] as u32) << 16 | (*c.get(1).unwrap_or(&0) as u32) << 8 | *c.get(2).unwrap_or(&0) as u32;
        for k in 0..4 {
            out.push(if k <= c.len() { ABC[(n >> (18 - 6 * k)) as usize & 63] as char } else { '=' });
        }
    }
    out
}

/// The `gltf` crate (1.4.1) unwrapped where its validation leaves gaps — an image with neither
/// a uri nor a bufferView, a bufferView image without a mimeType, a camera whose type names a
/// projection object it lacks — and panicked (exit 101). Each is now an error naming the file
/// and the JSON path.
#[test]
fn gltf_crate_panics_are_located_errors() {
    let d = std::env::temp_dir().join(format!("ember-fuzz-regressions-gltf-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    let perspective_without_object =
        r#", "cameras": [{"type": "perspective", "orthographic": {"xmag": 1, "ymag": 1, "zfar": 9, "znear": 1}}]"#;
    let orthographic_without_object =
        r#", "cameras": [{"type": "orthographic", "perspective": {"yfov": 1, "znear": 1}}]"#;
    for (name, text, needle) in [
        ("no-source", gltf_with("{}", ""), "images[0]: has neither a uri nor a bufferView"),
        ("no-mime", gltf_with(r#"{"bufferView": 0}"#, ""), "images[0]: a bufferView image needs a mimeType"),
        (
            "perspective",
            gltf_with(r#"{"uri": "x.png"}"#, perspective_without_object),
            "cameras[0]: its type is perspective but it has no perspective object",
        ),
        (
            "orthographic",
            gltf_with(r#"{"uri": "x.png"}"#, orthographic_without_object),
            "cameras[0]: its type is orthographic but it has no orthographic object",
        ),
    ] {
        let p = d.join(format!("{name}.gltf"));
        std::fs::write(&p, text).unwrap();
        let e = ember::scene::mesh_file::load(&p, &LoadBudget::unlimited()).expect_err(name);
        assert_eq!((e.path.as_path(), e.line), (p.as_path(), None), "{name}");
        assert_eq!(e.message, needle, "{name}");
    }
    std::fs::remove_dir_all(&d).unwrap();
}

/// A Radiance HDR file of 0 × 0 pixels decoded to an empty image, whose lookups divided by its
/// width (remainder by zero); a JPEG cut short with an end-of-image marker appended, or with a
/// stretch zeroed, decoded without an error into a partly grey texture. All are errors now.
#[test]
fn empty_and_damaged_images_are_errors() {
    let d = std::env::temp_dir().join(format!("ember-fuzz-regressions-images-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    let budget = LoadBudget::unlimited();
    for dims in ["-Y 0 +X 0", "-Y 0 +X 4", "-Y 4 +X 0"] {
        let p = d.join("empty.hdr");
        std::fs::write(&p, format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n{dims}\n")).unwrap();
        let e = Image::load_environment(&p, &budget).expect_err(dims).to_string();
        assert!(e.starts_with("the image is ") && e.ends_with("pixels: empty"), "{dims}: {e}");
    }
    let good = std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/earthmap.jpg")).unwrap();
    let n = good.len();
    let mut cut = good[..n / 2].to_vec();
    cut.extend([0xFF, 0xD9]);
    let mut zeroed = good.clone();
    zeroed[n / 3..2 * n / 3].fill(0);
    for (what, bytes) in [("cut", cut), ("zeroed", zeroed)] {
        let p = d.join(format!("{what}.jpg"));
        std::fs::write(&p, bytes).unwrap();
        let e = MipImage::load(&p, &budget, Encoding::Srgb).expect_err(what).to_string();
        assert!(e.starts_with("truncated or damaged JPEG: "), "{what}: {e}");
    }
    assert!(
        MipImage::load(Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/earthmap.jpg")), &budget, Encoding::Srgb)
            .is_ok()
    );
    std::fs::remove_dir_all(&d).unwrap();
}

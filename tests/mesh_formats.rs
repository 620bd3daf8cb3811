//! PLY and glTF/GLB meshes written by other programs (Blender 4.5, trimesh, plyfile: see
//! tests/data/meshes/README.md): counts and bounds, the same triangles as the equivalent OBJ,
//! the same image as the OBJ, glTF materials, camera and lights as documented in
//! docs/scene-format.md, and the command line's errors for broken files.

mod common;

use ember::film::Film;
use ember::geometry::{Aabb, Geometry, TriMesh};
use ember::integrator::RenderSettings;
use ember::material::{GlassMaterial, MaterialKind, PbrMaterial};
use ember::memory::LoadBudget;
use ember::scene::Scene;
use ember::scene::mesh_file::{self, MeshFile};
use ember::texture::{Encoding, MipImage, Texture};
use glam::Vec3;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn data(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/meshes").join(name)
}

fn load(name: &str) -> MeshFile {
    mesh_file::load(&data(name), &LoadBudget::unlimited()).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn bounds(f: &MeshFile) -> Aabb {
    f.meshes.iter().fold(Aabb::EMPTY, |b, m| b.union(&m.mesh.bounds()))
}

/// The corners of every triangle, in order.
fn corners(meshes: &[&TriMesh]) -> Vec<[Vec3; 3]> {
    meshes.iter().flat_map(|m| (0..m.triangle_count()).map(|i| m.triangle(i))).collect()
}

fn obj_meshes(name: &str) -> Vec<TriMesh> {
    mesh_file::load(&data(name), &LoadBudget::unlimited()).unwrap().meshes.into_iter().map(|m| m.mesh).collect()
}

#[test]
fn ply_files_hold_the_obj_triangles() {
    // icosphere-*.ply (trimesh ASCII and binary little-endian, plyfile big-endian with double
    // positions) and icosphere.obj hold the same 162 vertices and 320 triangles: every corner
    // must be the same f32, in the same order.
    let obj = obj_meshes("icosphere.obj");
    let want = corners(&obj.iter().collect::<Vec<_>>());
    assert_eq!(want.len(), 320);
    for name in ["icosphere-ascii.ply", "icosphere-le.ply", "icosphere-be.ply"] {
        let f = load(name);
        assert_eq!(f.meshes.len(), 1, "{name}");
        let m = &f.meshes[0];
        assert_eq!((m.mesh.positions.len(), m.mesh.triangle_count()), (162, 320), "{name}");
        assert_eq!(m.mesh.normals.len(), 162, "{name}: normals");
        assert_eq!(m.colors.len(), 162, "{name}: colours");
        assert_eq!(corners(&[&m.mesh]), want, "{name}");
        assert_eq!(bounds(&f), obj[0].bounds(), "{name}");
        assert!(f.warnings.is_empty(), "{name}: {:?}", f.warnings);
    }
    // Only plyfile's file has texture coordinates (`u v`).
    assert_eq!(load("icosphere-be.ply").meshes[0].mesh.uvs.len(), 162);
    // uchar colours, sRGB-decoded: the same in all three files.
    let c = load("icosphere-ascii.ply").meshes[0].colors.clone();
    assert_eq!(load("icosphere-be.ply").meshes[0].colors, c);
    assert_eq!(load("icosphere-le.ply").meshes[0].colors, c);
}

#[test]
fn blender_ply_quads_are_fanned() {
    // Blender's cube: 14 vertices (split at UV seams), 6 quads → 12 triangles, normals,
    // `s t` texture coordinates and uchar colours; ASCII and binary give the same mesh.
    let a = load("quadcube-ascii.ply");
    let b = load("quadcube-le.ply");
    for (name, f) in [("ascii", &a), ("le", &b)] {
        let m = &f.meshes[0];
        assert_eq!((m.mesh.positions.len(), m.mesh.triangle_count()), (14, 12), "{name}");
        assert_eq!((m.mesh.normals.len(), m.mesh.uvs.len(), m.colors.len()), (14, 14, 14), "{name}");
        let bb = bounds(f);
        assert_eq!((bb.min, bb.max), (Vec3::splat(-1.0), Vec3::ONE), "{name}");
    }
    assert_eq!(a.meshes[0].mesh.positions, b.meshes[0].mesh.positions);
    assert_eq!(a.meshes[0].mesh.indices, b.meshes[0].mesh.indices);
    assert_eq!(a.meshes[0].mesh.uvs, b.meshes[0].mesh.uvs);
    assert_eq!(a.meshes[0].colors, b.meshes[0].colors);
    // The first quad, 0 1 2 3, fanned from its first corner.
    assert_eq!(&a.meshes[0].mesh.indices[..2], &[[0, 1, 2], [0, 2, 3]]);
    // Vertex 1 is Blender's colour (0, 0, 254)/255 in sRGB: blue, decoded to linear.
    let blue = a.meshes[0].colors[1];
    assert_eq!((blue.x, blue.y), (0.0, 0.0));
    assert!((blue.z - 0.991).abs() < 0.001, "{blue}");
}

#[test]
fn gltf_and_glb_hold_the_reference_triangles() {
    // scene.gltf (+ .bin + .png) and scene.glb are the same Blender scene; scene-reference.obj
    // is the GLB as trimesh reads it, node transforms applied in float64. Corners agree with
    // it to 1e-5 (the transforms are composed in f32 here: a few ulps of coordinates ≤ 12).
    let gltf = load("scene.gltf");
    let glb = load("scene.glb");
    let reference = obj_meshes("scene-reference.obj");
    let counts: Vec<usize> = gltf.meshes.iter().map(|m| m.mesh.triangle_count()).collect();
    assert_eq!(counts, reference.iter().map(TriMesh::triangle_count).collect::<Vec<_>>());
    assert_eq!(counts, [410, 12, 80]);
    let ours = corners(&gltf.meshes.iter().map(|m| &m.mesh).collect::<Vec<_>>());
    assert_eq!(ours, corners(&glb.meshes.iter().map(|m| &m.mesh).collect::<Vec<_>>()), "glTF and GLB differ");
    let theirs = corners(&reference.iter().collect::<Vec<_>>());
    let worst = ours
        .iter()
        .zip(&theirs)
        .flat_map(|(a, b)| a.iter().zip(b).map(|(p, q)| (*p - *q).abs().max_element()))
        .fold(0.0f32, f32::max);
    assert!(worst < 1e-5, "corners differ from trimesh's by up to {worst}");
    let b = bounds(&gltf);
    let r = reference.iter().fold(Aabb::EMPTY, |b, m| b.union(&m.bounds()));
    assert!((b.min - r.min).abs().max_element() < 1e-5 && (b.max - r.max).abs().max_element() < 1e-5);
    // Normals: unit length after the node transforms.
    for m in &gltf.meshes {
        assert_eq!(m.mesh.normals.len(), m.mesh.positions.len());
        assert!(m.mesh.normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-5));
        assert!(m.colors.is_empty());
    }
}

#[test]
fn gltf_materials_camera_and_lights_are_mapped() {
    for name in ["scene.gltf", "scene.glb"] {
        let f = load(name);
        let names: Vec<&str> = f.materials.iter().map(|m| m.name.as_str()).collect();
        assert_eq!(
            names,
            [format!("{name}:teapot-plastic"), format!("{name}:cube-metal"), format!("{name}:ico-glass")]
        );
        let material_of: Vec<Option<usize>> = f.meshes.iter().map(|m| m.material).collect();
        assert_eq!(material_of, [Some(0), Some(1), Some(2)]);
        // glTF's material: metallic 0, roughness 0.3.
        match &f.materials[0].kind {
            MaterialKind::Pbr(PbrMaterial {
                base: Texture::Constant(c),
                metal_rough: Texture::Constant(mr),
                normal: None,
                ..
            }) => {
                assert!((*c - Vec3::new(0.62, 0.08, 0.05)).abs().max_element() < 1e-6);
                assert!((*mr - Vec3::new(1.0, 0.3, 0.0)).abs().max_element() < 1e-6, "{mr}");
            }
            k => panic!("{name}: teapot material {k:?}"),
        }
        // metallic 1 (the default), roughness 0.2, base colour texture: the image decodes as the
        // PNG Blender saved beside the .gltf does.
        match &f.materials[1].kind {
            MaterialKind::Pbr(PbrMaterial {
                base: Texture::Map { map, .. },
                metal_rough: Texture::Constant(mr),
                ..
            }) => {
                assert!((*mr - Vec3::new(1.0, 0.2, 1.0)).abs().max_element() < 1e-6, "{mr}");
                let png = MipImage::load(&data("checker.png"), &LoadBudget::unlimited(), Encoding::Srgb).unwrap();
                assert_eq!(*map.image, png, "{name}: texture");
            }
            k => panic!("{name}: cube material {k:?}"),
        }
        // transmission 1 with ior 1.45 → glass; emissive (1, 0.5, 0.25) × strength 2.
        match &f.materials[2].kind {
            MaterialKind::Glass(GlassMaterial { ior, tint, .. }) => {
                assert!((ior - 1.45).abs() < 1e-6);
                assert_eq!(*tint, Vec3::ONE);
            }
            k => panic!("{name}: icosphere material {k:?}"),
        }
        assert_eq!(f.materials[2].emission, Texture::Constant(Vec3::new(2.0, 1.0, 0.5)));
        // Blender's camera at (9, -11, 7) Z-up = (9, 7, 11) Y-up, aimed at (0, 1, 0), 35°.
        let cam = f.camera.expect("camera");
        assert!((cam.position - Vec3::new(9.0, 7.0, 11.0)).length() < 1e-4, "{cam:?}");
        let to_target = (Vec3::new(0.0, 1.0, 0.0) - cam.position).normalize();
        assert!((cam.look_at - cam.position).normalize().dot(to_target) > 1.0 - 1e-6, "{cam:?}");
        assert!((cam.fov - 35.0).abs() < 1e-3, "{cam:?}");
        assert!(cam.up.y > 0.9, "{cam:?}");
        // A 1000 W Blender lamp: 1000 / 4π · 683 cd, read as 1000 / 4π W/sr, times its colour.
        assert_eq!(f.point_lights.len(), 1);
        let l = f.point_lights[0];
        assert!((l.position - Vec3::new(2.0, 6.0, 3.0)).length() < 1e-5);
        let watts_per_sr = 1000.0 / (4.0 * std::f32::consts::PI);
        assert!((l.intensity - Vec3::new(1.0, 0.9, 0.8) * watts_per_sr).abs().max_element() < 1e-3, "{l:?}");
        // The sun is not a point light: one warning names it.
        assert_eq!(f.warnings.iter().filter(|w| w.contains("directional lights")).count(), 1, "{:?}", f.warnings);
    }
}

fn render(scene: &Scene, max_depth: u32) -> Film {
    let settings = RenderSettings { width: 48, height: 36, spp: 16, max_depth, seed: 7, ..Default::default() };
    let (film, stats) = common::render_embree(scene, &settings);
    assert_eq!(stats.nonfinite, 0);
    film
}

/// A TOML scene in a fresh folder: the mesh file (an absolute path) under a grey diffuse
/// material on a ground quad, lit by `lights` (TOML), a point light and a sky, seen by a fixed
/// camera.
fn scene_with(test: &str, mesh: &Path, camera: &str, lights: &str) -> Scene {
    let d = common::fresh_dir("mesh-formats", test);
    let p = d.join("scene.toml");
    let text = format!(
        r#"
        {camera}
        [background]
        type = "gradient"
        zenith = [0.4, 0.45, 0.5]
        horizon = [0.3, 0.3, 0.3]
        [materials.grey]
        type = "diffuse"
        color = [0.7, 0.7, 0.7]
        [[meshes]]
        file = "{}"
        material = "grey"
        override = "all"
        [[quads]]
        corner = [-20.0, -1.0, -20.0]
        edge1 = [0.0, 0.0, 40.0]
        edge2 = [40.0, 0.0, 0.0]
        material = "grey"
        {lights}
        [[lights]]
        type = "point"
        position = [3.0, 8.0, 5.0]
        intensity = [40.0, 40.0, 40.0]
        "#,
        mesh.display()
    );
    std::fs::write(&p, text).unwrap();
    Scene::load(&p).unwrap()
}

/// Largest per-pixel difference (any channel) and the number of pixels that differ at all.
fn difference(a: &Film, b: &Film) -> (f32, usize) {
    let d: Vec<f32> = a.pixels.iter().zip(&b.pixels).map(|(p, q)| (*p - *q).abs().max_element()).collect();
    (d.iter().copied().fold(0.0, f32::max), d.iter().filter(|&&x| x > 0.0).count())
}

#[test]
fn ply_renders_like_the_obj() {
    // The PLY files hold the same f32 corners and normals in the same order as each other and
    // as the OBJ (checked above), so the same seed must give the same image. The three PLY
    // files, whose vertex arrays are identical, must render bit-identically. The OBJ's vertex
    // array is in another order (tobj numbers vertices by first use in the faces), and that
    // alone changes some pixels in the last bit (measured: 103 of 1728 pixels, by at most
    // 6e-8 in values up to ~1): tolerance 1e-6 per pixel channel against the OBJ.
    let cam = "[camera]\nposition = [2.5, 1.5, 3.0]\nlook_at = [0.0, 0.0, 0.0]\nfov = 40";
    let reference = render(&scene_with("ply-obj", &data("icosphere.obj"), cam, ""), 3);
    assert!(reference.pixels.iter().any(|p| p.max_element() > 0.05), "the image is black");
    let ascii = render(&scene_with("ply-ascii", &data("icosphere-ascii.ply"), cam, ""), 3);
    let (worst, differing) = difference(&ascii, &reference);
    eprintln!("PLY vs OBJ: {differing} of {} pixels differ, by at most {worst}", ascii.pixels.len());
    assert!(worst <= 1e-6, "PLY and OBJ renders differ by {worst}");
    for name in ["icosphere-le.ply", "icosphere-be.ply"] {
        let img = render(&scene_with(&format!("ply-{name}"), &data(name), cam, ""), 3);
        assert_eq!(difference(&img, &ascii), (0.0, 0), "{name}");
    }
}

#[test]
fn gltf_renders_like_the_reference_obj() {
    // glTF and GLB hold the same data: bit-identical images. The trimesh reference differs
    // from ember's world-space corners by a few ulps (transforms composed in float64 there,
    // f32 here; normals by up to 1.2e-7), which moves hit points by ~1e-6 of the scene size:
    // pixels differ in the last bits (measured: 217 of 1728 pixels, by at most 1.3e-6), and a
    // path that grazes an edge could change. Tolerance: at most 1% of the pixels differ by
    // more than 1e-4, and the image means agree to 0.1%.
    let cam = "[camera]\nposition = [9.0, 7.0, 11.0]\nlook_at = [0.0, 1.0, 0.0]\nfov = 35";
    let glb = render(&scene_with("gltf-glb", &data("scene.glb"), cam, ""), 3);
    let gltf = render(&scene_with("gltf-gltf", &data("scene.gltf"), cam, ""), 3);
    assert_eq!(difference(&gltf, &glb), (0.0, 0));
    // The glTF file brings its lamp into the scene (first, as the file is read before the
    // scene's own lights): the OBJ's scene gets the same light in the same place.
    let lamp = load("scene.glb").point_lights[0];
    let (p, i) = (lamp.position, lamp.intensity);
    let lamp = format!(
        "[[lights]]\ntype = \"point\"\nposition = [{:?}, {:?}, {:?}]\nintensity = [{:?}, {:?}, {:?}]\n",
        p.x, p.y, p.z, i.x, i.y, i.z
    );
    let obj = render(&scene_with("gltf-obj", &data("scene-reference.obj"), cam, &lamp), 3);
    let (worst, differing) = difference(&glb, &obj);
    let mean = |f: &Film| f.pixels.iter().map(|p| p.element_sum() as f64).sum::<f64>() / f.pixels.len() as f64;
    eprintln!("glb vs reference obj: {differing} of {} pixels differ, worst {worst}", glb.pixels.len());
    let far = glb.pixels.iter().zip(&obj.pixels).filter(|(p, q)| (**p - **q).abs().max_element() > 1e-4).count();
    assert!(far * 100 <= glb.pixels.len(), "{far} pixels differ by more than 1e-4 (worst {worst})");
    assert!((mean(&glb) / mean(&obj) - 1.0).abs() < 0.001, "means {} and {}", mean(&glb), mean(&obj));
}

#[test]
fn gltf_file_renders_on_its_own() {
    // `ember render scene.glb`: its materials, camera and point light; no sky (the glass
    // emits and the lamp lights it). The image must show something and hold no NaN.
    let scene = Scene::load(&data("scene.glb")).unwrap();
    assert_eq!(scene.camera, mesh_file::load(&data("scene.glb"), &LoadBudget::unlimited()).unwrap().camera);
    assert_eq!(scene.lights.len(), 1);
    assert!(matches!(scene.lights[0], ember::light::Light::Point(_)));
    assert!(matches!(scene.background(), ember::light::Background::Black));
    let film = render(&scene, 4);
    let lit = film.pixels.iter().filter(|p| p.max_element() > 0.01).count();
    assert!(lit * 10 > film.pixels.len(), "only {lit} pixels lit");
    // A PLY file on its own gets a sky (nothing in it emits) and the framing camera.
    let scene = Scene::load(&data("quadcube-le.ply")).unwrap();
    assert!(scene.camera.is_none());
    assert!(matches!(scene.background(), ember::light::Background::Gradient { .. }));
    assert!(scene.warnings.iter().any(|w| w.ends_with(mesh_file::VERTEX_COLOURS_WARNING)), "{:?}", scene.warnings);
    assert!(matches!(&scene.geometry[0], Geometry::Mesh(m) if m.triangle_count() == 12));
}

// ---- The command line's errors ------------------------------------------------------------

fn ember_env(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_ember"));
    c.args(args).env_remove("EMBER_MEMORY_LIMIT");
    for (k, v) in env {
        c.env(k, v);
    }
    c.output().expect("ember runs")
}

/// Runs `ember render FILE -o out.png` (8x8, 1 spp) in `dir` and expects exit code 2, an
/// `error: ` line starting with `prefix` and containing `needle`, and no file written.
fn expect_error(dir: &Path, file: &Path, env: &[(&str, &str)], prefix: &str, needle: &str) {
    let before: Vec<_> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name()).collect();
    let out = dir.join("out.png");
    let args =
        ["render", file.to_str().unwrap(), "-o", out.to_str().unwrap(), "--width", "8", "--height", "8", "--spp", "1"];
    let o = ember_env(&args, env);
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {e}");
    let line = e.lines().find(|l| l.starts_with("error: ")).unwrap_or("");
    assert!(line.starts_with(prefix), "{args:?}: expected prefix {prefix:?} in {e:?}");
    assert!(line.contains(needle), "{args:?}: expected {needle:?} in {e:?}");
    assert!(!out.exists(), "an output file was written");
    let after: Vec<_> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(after.len(), before.len(), "files appeared: {after:?}");
    // `ember info` fails the same way.
    let o = ember_env(&["info", file.to_str().unwrap()], env);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains(needle));
}

fn at(path: &Path, line: Option<usize>) -> String {
    match line {
        Some(l) => format!("error: {}:{l}: ", path.display()),
        None => format!("error: {}: ", path.display()),
    }
}

#[test]
fn broken_ply_files_are_located_errors() {
    let d = common::fresh_dir("mesh-formats", "bad-ply");
    // Truncated binary: 320 faces of 13 bytes end the file; cutting 20 bytes leaves face 318
    // incomplete.
    let le = std::fs::read(data("icosphere-le.ply")).unwrap();
    let p = d.join("cut.ply");
    std::fs::write(&p, &le[..le.len() - 20]).unwrap();
    expect_error(&d, &p, &[], &at(&p, None), "face 318: the file ends early, in face 318 of 320 (truncated?)");
    // Cut in the vertices: the header's counts cannot fit in what is left.
    std::fs::write(&p, &le[..le.len() / 3]).unwrap();
    expect_error(&d, &p, &[], &at(&p, None), "PLY header declares 162 vertex and 320 face");
    std::fs::remove_file(&p).unwrap();
    // An index out of range, in the ASCII file: 19 header lines + 14 vertices + the 6th face
    // = line 39.
    let text = std::fs::read_to_string(data("quadcube-ascii.ply")).unwrap();
    let bad = text.replace("4 4 12 13 6\n", "4 4 12 14 6\n");
    assert_ne!(bad, text);
    let p = d.join("index.ply");
    std::fs::write(&p, bad).unwrap();
    expect_error(
        &d,
        &p,
        &[],
        &at(&p, Some(39)),
        "face vertex index 14 is out of range (the file has 14 vertices, 0 to 13)",
    );
    // A non-finite normal (vertex 1, line 21).
    let bad = text.replacen("-0.5773503 0.5773503 0.5773503", "-0.5773503 nan 0.5773503", 1);
    std::fs::write(&p, bad).unwrap();
    expect_error(&d, &p, &[], &at(&p, Some(21)), "vertex normal: NaN is not a finite number");
    // Memory is refused from the header's counts, before the payload is read.
    std::fs::copy(data("icosphere-be.ply"), &p).unwrap();
    expect_error(
        &d,
        &p,
        &[("EMBER_MEMORY_LIMIT", "10K")],
        &at(&p, None),
        "PLY mesh of 162 vertices and 320 triangles needs ~",
    );
    std::fs::remove_file(&p).unwrap();
    // Through a scene file: the scene's line names the mesh file.
    let s = d.join("scene.toml");
    std::fs::write(&s, "[[meshes]]\nfile = \"missing.ply\"\n").unwrap();
    expect_error(&d, &s, &[], &at(&s, Some(2)), "missing.ply: no such file");
}

#[test]
fn broken_gltf_files_are_located_errors() {
    let d = common::fresh_dir("mesh-formats", "bad-gltf");
    let json = std::fs::read_to_string(data("scene.gltf")).unwrap();
    // The .gltf without its .bin.
    let p = d.join("scene.gltf");
    std::fs::write(&p, &json).unwrap();
    let missing = format!("buffers[0]: \"scene.bin\" ({}): no such file", d.join("scene.bin").display());
    expect_error(&d, &p, &[], &at(&p, None), &missing);
    // With it, and the PNG: it loads.
    std::fs::copy(data("scene.bin"), d.join("scene.bin")).unwrap();
    std::fs::copy(data("checker.png"), d.join("checker.png")).unwrap();
    assert!(Scene::load(&p).is_ok());
    // Bad JSON: the line of the problem.
    let cut: String = json.lines().take(5).collect::<Vec<_>>().join("\n");
    std::fs::write(&p, cut).unwrap();
    expect_error(&d, &p, &[], &at(&p, Some(5)), "invalid glTF JSON");
    // An accessor whose data does not fit in its buffer view, named by JSON path.
    let mut v: serde_json::Value = serde_json::from_str(&json).unwrap();
    v["accessors"][0]["count"] = serde_json::json!(100000);
    std::fs::write(&p, v.to_string()).unwrap();
    expect_error(&d, &p, &[], &at(&p, None), "meshes[0].primitives[0].attributes.POSITION: accessor 0 out of range");
    // Fewer normals than positions.
    let mut v: serde_json::Value = serde_json::from_str(&json).unwrap();
    let n = v["accessors"][0]["count"].as_u64().unwrap();
    v["accessors"][0]["count"] = serde_json::json!(n - 1);
    std::fs::write(&p, v.to_string()).unwrap();
    expect_error(
        &d,
        &p,
        &[],
        &at(&p, None),
        &format!("meshes[0].primitives[0].attributes.NORMAL: accessor 1 has {n} entries for {} positions", n - 1),
    );
    // An index past the primitive's vertices: the teapot's last vertex dropped from both
    // its attributes (its triangles use every vertex).
    v["accessors"][1]["count"] = serde_json::json!(n - 1);
    std::fs::write(&p, v.to_string()).unwrap();
    expect_error(&d, &p, &[], &at(&p, None), &format!("meshes[0].primitives[0].indices: index {} (entry", n - 1));
    // A reference to an accessor that does not exist: the validator's JSON path.
    let mut v: serde_json::Value = serde_json::from_str(&json).unwrap();
    v["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = serde_json::json!(99);
    std::fs::write(&p, v.to_string()).unwrap();
    expect_error(&d, &p, &[], &at(&p, None), "meshes[0].primitives[0].attributes");
    // A GLB cut short.
    let glb = std::fs::read(data("scene.glb")).unwrap();
    let p = d.join("cut.glb");
    std::fs::write(&p, &glb[..glb.len() / 2]).unwrap();
    expect_error(&d, &p, &[], &at(&p, None), "invalid GLB");
}

/// A glTF with one triangle whose buffer is the URI `uri`, and with `nodes` (JSON) after the
/// mesh's node.
fn gltf_naming(uri: &str, nodes: &str, extra: &str) -> String {
    format!(
        r#"{{"asset": {{"version": "2.0"}}, "scenes": [{{"nodes": [0, 1]}}], "nodes": [{{"mesh": 0}}, {nodes}],
        "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}}}]}}],
        "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}}],
        "bufferViews": [{{"buffer": 0, "byteLength": 36}}],
        "buffers": [{{"byteLength": 36, "uri": "{uri}"}}]{extra}}}"#
    )
}

/// The 36 bytes of a triangle's positions.
fn triangle_bytes() -> Vec<u8> {
    [0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0].iter().flat_map(|c| c.to_le_bytes()).collect()
}

/// The files a glTF names are read only from its folder (or below), after resolving `..`,
/// percent escapes and links; absolute names and files of /proc are refused by name, and no
/// message quotes a byte of a file the user did not name. `--allow-external-files` lifts the
/// folder rule, not the others.
#[test]
fn gltf_files_read_only_the_files_of_their_folder() {
    let d = common::fresh_dir("mesh-formats", "gltf-uris");
    let model = d.join("model");
    std::fs::create_dir_all(model.join("sub")).unwrap();
    std::fs::write(model.join("sub/tri.bin"), triangle_bytes()).unwrap();
    // Outside the model's folder: a triangle too, so that only the rule can refuse it.
    std::fs::write(d.join("outside.bin"), triangle_bytes()).unwrap();
    std::os::unix::fs::symlink(d.join("outside.bin"), model.join("link.bin")).unwrap();
    let light = r#"{"translation": [0, 0, 2], "extensions": {"KHR_lights_punctual": {"light": 0}}}"#;
    let lights = r#", "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 100}]}}"#;
    let write = |name: &str, uri: &str| {
        let p = model.join(name);
        std::fs::write(&p, gltf_naming(uri, light, lights)).unwrap();
        p
    };
    let ok = write("ok.gltf", "sub/tri.bin");
    assert!(Scene::load(&ok).is_ok());
    for (name, uri, needle) in [
        ("up.gltf", "../outside.bin", "\"../outside.bin\" resolves to "),
        ("escaped.gltf", "%2e%2e/outside.bin", "\"../outside.bin\" resolves to "),
        ("link.gltf", "link.bin", "\"link.bin\" resolves to "),
        ("absolute.gltf", "/etc/passwd", "\"/etc/passwd\" is an absolute path"),
        ("proc.gltf", "../../../../../../../../proc/self/environ", "under /proc: never read"),
    ] {
        let p = write(name, uri);
        expect_error(&model, &p, &[], &at(&p, None), needle);
        // Nothing of the file is quoted (the old message named an accessor index read from it).
        let o = ember_env(&["info", p.to_str().unwrap()], &[]);
        let e = String::from_utf8_lossy(&o.stderr);
        assert!(!e.contains("root:") && !e.contains("PATH="), "{e}");
        if needle.ends_with("resolves to ") {
            assert!(e.contains("outside the model's folder: not read (--allow-external-files"), "{e}");
        }
    }
    // Allowed outside the folder: the two that resolve there load; system files never.
    let out = d.join("out.png");
    for name in ["up.gltf", "escaped.gltf", "link.gltf"] {
        let p = model.join(name);
        let args =
            ["render", p.to_str().unwrap(), "-o", out.to_str().unwrap(), "--spp", "1", "--width", "8", "--height", "8"];
        let o = ember_env(&[&args[..], &["--allow-external-files"]].concat(), &[]);
        assert!(o.status.success(), "{name}: {}", String::from_utf8_lossy(&o.stderr));
    }
    let p = model.join("proc.gltf");
    let o = ember_env(&["info", p.to_str().unwrap(), "--allow-external-files"], &[]);
    assert_eq!(o.status.code(), Some(2));
    std::fs::remove_dir_all(&d).unwrap();
}

/// A glTF light or camera the node transforms put at NaN, or beyond ±1e15 (a scene file's
/// limit), is an error naming the node, not a black image or an unusable camera.
#[test]
fn gltf_lights_and_cameras_must_be_at_finite_places() {
    let d = common::fresh_dir("mesh-formats", "gltf-places");
    std::fs::write(d.join("tri.bin"), triangle_bytes()).unwrap();
    let lights = r#", "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 100}]}}"#;
    let camera = r#", "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1}}]"#;
    let light = |t: &str| format!(r#"{{{t}, "extensions": {{"KHR_lights_punctual": {{"light": 0}}}}}}"#);
    // An infinite scale on the parent: the child's place is inf × 0, NaN.
    let nan = format!(r#"{{"scale": [1e39, 1, 1], "children": [2]}}, {}"#, light(r#""translation": [0, 0, 0]"#));
    for (name, node, extra, needle) in [
        ("nan-light.gltf", nan, lights, "nodes[2].extensions.KHR_lights_punctual: the light is at [NaN"),
        (
            "far-light.gltf",
            light(r#""translation": [1e39, 0, 0]"#),
            lights,
            // (inf or NaN, depending on how the node's matrix is multiplied out)
            "nodes[1].extensions.KHR_lights_punctual: the light is at [",
        ),
        (
            "far-camera.gltf",
            r#"{"camera": 0, "translation": [0, 0, 1e30]}"#.to_string(),
            camera,
            "nodes[1]: the camera is at [0.0, 0.0, 1e30]",
        ),
    ] {
        let p = d.join(name);
        std::fs::write(&p, gltf_naming("tri.bin", &node, extra)).unwrap();
        expect_error(&d, &p, &[], &at(&p, None), needle);
        let e = String::from_utf8_lossy(&ember_env(&["info", p.to_str().unwrap()], &[]).stderr).into_owned();
        assert!(e.contains("must be finite and within ±1e15"), "{e}");
    }
    std::fs::remove_dir_all(&d).unwrap();
}

/// An OBJ (and its MTL) that starts with a UTF-8 byte-order mark, as some editors write, reads
/// as the same file without it.
#[test]
fn a_byte_order_mark_does_not_change_an_obj() {
    let d = common::fresh_dir("mesh-formats", "bom");
    let obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\n";
    std::fs::write(d.join("m.mtl"), "\u{feff}newmtl red\nKd 1 0 0\n").unwrap();
    std::fs::write(d.join("plain.obj"), obj).unwrap();
    std::fs::write(d.join("bom.obj"), format!("\u{feff}{obj}")).unwrap();
    let plain = mesh_file::load(&d.join("plain.obj"), &LoadBudget::unlimited()).unwrap();
    let bom = mesh_file::load(&d.join("bom.obj"), &LoadBudget::unlimited()).unwrap();
    assert_eq!(bom.meshes[0].mesh.indices, plain.meshes[0].mesh.indices);
    assert_eq!(bom.meshes[0].mesh.positions, plain.meshes[0].mesh.positions);
    assert_eq!(bom.materials.len(), 1);
    assert_eq!(bom.materials[0].kind, plain.materials[0].kind);
    assert!(bom.warnings.is_empty(), "{:?}", bom.warnings);
    std::fs::remove_dir_all(&d).unwrap();
}

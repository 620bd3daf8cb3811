//! glTF's metallic-roughness material as ember renders it: normal maps (given tangents and
//! MikkTSpace ones) against geometry, texture samplers through glTF files. The files are
//! written here, small enough to state what they hold; the assets made by Blender's and
//! trimesh's exporters are checked in `gltf_assets.rs`.

mod common;

use base64::Engine;
use common::{fresh_dir, render_embree};
use ember::integrator::RenderSettings;
use ember::scene::Scene;
use glam::{Quat, Vec3};
use std::path::{Path, PathBuf};

/// A PNG of `w` × `h` RGBA texels, as a data URI.
fn png_uri(w: u32, h: u32, texel: impl Fn(u32, u32) -> [u8; 4]) -> String {
    let img = image::RgbaImage::from_fn(w, h, |x, y| image::Rgba(texel(x, y)));
    let mut bytes = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut bytes), image::ImageFormat::Png).unwrap();
    format!("data:image/png;base64,{}", base64::engine::general_purpose::STANDARD.encode(bytes))
}

/// A glTF quad: four corners (counter-clockwise seen from the front), one normal, glTF texture
/// coordinates per corner, an optional tangent for every corner, and the material's JSON with
/// the images it names.
struct Quad {
    corners: [Vec3; 4],
    normal: Vec3,
    uvs: [[f32; 2]; 4],
    tangent: Option<[f32; 4]>,
    material: String,
    images: Vec<String>,
    samplers: String,
}

impl Quad {
    /// The unit square in the XZ plane facing +Y, u along +X, glTF's v along +Z (so the
    /// image's top edge is at −Z), transformed by `rotation`.
    fn floor(rotation: Quat) -> Quad {
        let corners =
            [[-1.0, 0.0, 1.0], [1.0, 0.0, 1.0], [1.0, 0.0, -1.0], [-1.0, 0.0, -1.0]].map(|c| rotation * Vec3::from(c));
        Quad {
            corners,
            normal: rotation * Vec3::Y,
            uvs: [[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]],
            tangent: None,
            material: r#"{"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0, "roughnessFactor": 1}}"#.into(),
            images: Vec::new(),
            samplers: "[{}]".into(),
        }
    }

    fn write(&self, path: &Path) {
        let mut buf: Vec<u8> = Vec::new();
        let f32s = |buf: &mut Vec<u8>, v: &[f32]| buf.extend(v.iter().flat_map(|x| x.to_le_bytes()));
        f32s(&mut buf, &self.corners.iter().flat_map(|c| c.to_array()).collect::<Vec<_>>());
        f32s(&mut buf, &(0..4).flat_map(|_| self.normal.to_array()).collect::<Vec<_>>());
        f32s(&mut buf, &self.uvs.concat());
        let mut views = vec![(0, 48), (48, 48), (96, 32)];
        if let Some(t) = self.tangent {
            f32s(&mut buf, &(0..4).flat_map(|_| t).collect::<Vec<_>>());
            views.push((128, 64));
        }
        let index_at = buf.len();
        buf.extend([0u16, 1, 2, 0, 2, 3].iter().flat_map(|i| i.to_le_bytes()));
        views.push((index_at, 12));
        let lo = self.corners.iter().copied().fold(Vec3::INFINITY, Vec3::min);
        let hi = self.corners.iter().copied().fold(Vec3::NEG_INFINITY, Vec3::max);
        let mut accessors = vec![
            format!(
                r#"{{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": {:?}, "max": {:?}}}"#,
                lo.to_array(),
                hi.to_array()
            ),
            r#"{"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"}"#.to_string(),
            r#"{"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"}"#.to_string(),
        ];
        let mut attributes = r#""POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2"#.to_string();
        if self.tangent.is_some() {
            accessors.push(r#"{"bufferView": 3, "componentType": 5126, "count": 4, "type": "VEC4"}"#.into());
            attributes += r#", "TANGENT": 3"#;
        }
        accessors.push(format!(
            r#"{{"bufferView": {}, "componentType": 5123, "count": 6, "type": "SCALAR"}}"#,
            views.len() - 1
        ));
        let views: Vec<String> =
            views.iter().map(|(o, l)| format!(r#"{{"buffer": 0, "byteOffset": {o}, "byteLength": {l}}}"#)).collect();
        let images: Vec<String> = self.images.iter().map(|u| format!(r#"{{"uri": "{u}"}}"#)).collect();
        let textures: Vec<String> =
            (0..self.images.len()).map(|i| format!(r#"{{"source": {i}, "sampler": 0}}"#)).collect();
        let json = format!(
            r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0]}}], "nodes": [{{"mesh": 0}}],
            "meshes": [{{"primitives": [{{"attributes": {{{attributes}}}, "indices": {}, "material": 0}}]}}],
            "materials": [{}], "images": [{}], "textures": [{}], "samplers": {},
            "accessors": [{}], "bufferViews": [{}],
            "buffers": [{{"byteLength": {}, "uri": "data:application/octet-stream;base64,{}"}}]}}"#,
            accessors.len() - 1,
            self.material,
            images.join(", "),
            textures.join(", "),
            self.samplers,
            accessors.join(", "),
            views.join(", "),
            buf.len(),
            base64::engine::general_purpose::STANDARD.encode(&buf)
        );
        std::fs::write(path, json).unwrap();
    }
}

/// A scene of `gltf` lit by a sky whose radiance is its direction's height (black below the
/// horizon), seen from straight above with a narrow field of view.
fn sky_scene(dir: &Path, gltf: &str) -> PathBuf {
    let p = dir.join(format!("{gltf}.toml"));
    let text = format!(
        "[camera]\nposition = [0.0, 6.0, 0.0]\nlook_at = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, -1.0]\nfov = 8\n\n\
         [background]\ntype = \"gradient\"\nzenith = [1.0, 1.0, 1.0]\nhorizon = [0.0, 0.0, 0.0]\nground = [0.0, 0.0, 0.0]\n\n\
         [[meshes]]\nfile = \"{gltf}\"\n"
    );
    std::fs::write(&p, text).unwrap();
    p
}

/// The mean radiance of a render of `scene` (all its pixels see the quad).
fn mean_radiance(scene: &Path) -> f64 {
    let scene = Scene::load(scene).unwrap();
    let settings = RenderSettings { width: 16, height: 16, spp: 256, max_depth: 1, ..Default::default() };
    let (film, _) = render_embree(&scene, &settings);
    film.pixels.iter().map(|p| (p.x + p.y + p.z) as f64 / 3.0).sum::<f64>() / film.pixels.len() as f64
}

#[test]
fn a_normal_map_shades_as_the_geometry_it_describes() {
    let dir = fresh_dir("gltf-materials", "normal-map");
    let tilt = 20f32.to_radians();
    // The tangent-space normal (sin 20°, 0, cos 20°), tilted towards the tangent (+u: +X),
    // 8-bit encoded as (n + 1) / 2.
    let encode = |x: f32| ((x + 1.0) * 0.5 * 255.0).round() as u8;
    let texel = [encode(tilt.sin()), encode(0.0), encode(tilt.cos()), 255];
    let normal_mapped = |tangent: Option<[f32; 4]>| {
        Quad {
        tangent,
        material: r#"{"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0, "roughnessFactor": 1}, "normalTexture": {"index": 0}}"#.into(),
        images: vec![png_uri(2, 2, |_, _| texel)],
        ..Quad::floor(Quat::IDENTITY)
    }
    };
    normal_mapped(Some([1.0, 0.0, 0.0, 1.0])).write(&dir.join("given.gltf"));
    normal_mapped(None).write(&dir.join("mikktspace.gltf"));
    // The same floor turned 20° about −Z: its normal (sin 20°, cos 20°, 0).
    Quad::floor(Quat::from_rotation_z(-tilt)).write(&dir.join("tilted.gltf"));
    Quad::floor(Quat::IDENTITY).write(&dir.join("flat.gltf"));
    let [given, mikk, tilted, flat] =
        ["given.gltf", "mikktspace.gltf", "tilted.gltf", "flat.gltf"].map(|g| mean_radiance(&sky_scene(&dir, g)));
    println!("given tangents {given:.5}, MikkTSpace {mikk:.5}, tilted geometry {tilted:.5}, flat {flat:.5}");
    // The sky is black below the horizon, so the tilted geometry and the normal-mapped floor
    // receive the same light; their means agree to the noise of 16×16×256 samples and the
    // 8-bit encoding of the normal (0.5 %).
    assert!((given - tilted).abs() < 0.005 * tilted, "given tangents {given} vs tilted {tilted}");
    assert!((mikk - tilted).abs() < 0.005 * tilted, "MikkTSpace {mikk} vs tilted {tilted}");
    // And the tilt matters: the flat floor faces the bright zenith squarely.
    assert!(flat > 1.03 * tilted, "flat {flat} vs tilted {tilted}");
}

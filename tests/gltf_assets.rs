//! The glTF assets Blender's exporter and trimesh wrote (`tests/data/gltf/`, made by
//! `scripts/assets/make_gltf_assets.py`; the facts quoted here are in its `SOURCES.md`), read
//! and rendered by ember.

mod common;

use common::{fresh_dir, render_embree};
use ember::integrator::RenderSettings;
use ember::material::{MaterialKind, PbrMaterial};
use ember::memory::LoadBudget;
use ember::scene::Scene;
use ember::scene::mesh_file::{self, MeshFile};
use ember::settings::Estimator;
use ember::texture::{TexCoords, Texture};
use glam::{Vec2, Vec3};
use std::path::{Path, PathBuf};

fn asset(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/gltf").join(name)
}

fn load(name: &str) -> MeshFile {
    mesh_file::load(&asset(name), &LoadBudget::unlimited()).unwrap()
}

/// The base colour texture of material `i` of a file.
fn base_texture(f: &MeshFile, i: usize) -> &Texture {
    match &f.materials[i].kind {
        MaterialKind::Pbr(PbrMaterial { base, .. }) => base,
        k => panic!("material {i}: {k:?}"),
    }
}

/// A texture's value at glTF texture coordinates (u, v) (v down from the image's top; ember's
/// meshes keep v up) of set 0 and, for set 1, `uv1`.
fn at(t: &Texture, u: f32, v: f32, uv1: Option<(f32, f32)>) -> Vec3 {
    let up = |(u, v): (f32, f32)| Vec2::new(u, 1.0 - v);
    let uv0 = up((u, v));
    t.eval(&TexCoords { uv: [uv0, uv1.map_or(uv0, up)], width: 0.0 })
}

/// The 8-bit sRGB values of the blocks texture's levels, linear.
fn level(k: usize) -> f32 {
    ember::film::srgb_to_linear([32.0f32, 96.0, 159.0, 223.0][k] / 255.0)
}

#[test]
fn samplers_repeat_mirror_and_clamp_as_the_file_says() {
    // samplers.glb: four quads, REPEAT², MIRRORED_REPEAT², CLAMP_TO_EDGE², MIRRORED × CLAMP,
    // the 4×4-block texture whose block (i, j) is (level i, level j, 51).
    let f = load("samplers.glb");
    assert_eq!(f.materials.len(), 4);
    let mut by_wrap = std::collections::HashMap::new();
    for i in 0..4 {
        let t = base_texture(&f, i);
        let Texture::Map { map, .. } = t else { panic!("{t:?}") };
        by_wrap.insert(format!("{:?}", map.sampler.wrap), t);
    }
    let block = |t: &Texture, u: f32, v: f32| {
        let c = at(t, u, v, None);
        let k = |x: f32| (0..4).min_by(|&a, &b| (level(a) - x).abs().total_cmp(&(level(b) - x).abs())).unwrap();
        assert!((c.x - level(k(c.x))).abs() < 1e-5 && (c.y - level(k(c.y))).abs() < 1e-5, "{c}");
        (k(c.x), k(c.y))
    };
    let repeat = by_wrap["[Repeat, Repeat]"];
    let mirror = by_wrap["[MirroredRepeat, MirroredRepeat]"];
    let clamp = by_wrap["[ClampToEdge, ClampToEdge]"];
    let mixed = by_wrap["[MirroredRepeat, ClampToEdge]"];
    // Inside the image every sampler reads the same block.
    for t in [repeat, mirror, clamp, mixed] {
        assert_eq!(block(t, 0.3, 0.6), (1, 2));
    }
    // u = 1.1 (v = 0.1): REPEAT reads u = 0.1 (block 0), MIRRORED_REPEAT 0.9 (block 3),
    // CLAMP_TO_EDGE the last column (block 3); v likewise at 1.1 and −0.4.
    assert_eq!(block(repeat, 1.1, 0.1), (0, 0));
    assert_eq!(block(mirror, 1.1, 0.1), (3, 0));
    assert_eq!(block(clamp, 1.1, 0.1), (3, 0));
    assert_eq!(block(repeat, 0.1, -0.4), (0, 2));
    assert_eq!(block(mirror, 0.1, -0.4), (0, 1));
    assert_eq!(block(clamp, 0.1, -0.4), (0, 0));
    // Mirrored u = 2.6 is 0.6 forward again (block 2); clamped v = 2.6 the last row.
    assert_eq!(block(mixed, 2.6, 2.6), (2, 3));
}

#[test]
fn texcoord1_and_texture_transforms_are_applied() {
    // texcoord1.glb: the base colour texture reads TEXCOORD_1 = (v0, u0).
    let f = load("texcoord1.glb");
    let t = base_texture(&f, 0);
    let (u, v) = (0.3, 0.6);
    assert_eq!(at(t, u, v, Some((v, u))), at(t, v, u, None));
    assert_ne!(at(t, u, v, Some((v, u))), at(t, u, v, None));
    // texture_transform.glb renders as texture_transform_baked.glb, whose UVs hold the
    // transform applied: the same image to within rounding of the coordinates.
    let dir = fresh_dir("gltf-assets", "transform");
    let render = |name: &str| {
        let scene = scene_with(
            &dir,
            name,
            "[camera]\nposition = [0.0, 0.0, 5.0]\nlook_at = [0.0, 0.0, 0.0]\nfov = 22.62\n\n[background]\ntype = \"constant\"\ncolor = [1.0, 1.0, 1.0]\n",
        );
        let settings = RenderSettings { width: 32, height: 32, spp: 16, max_depth: 1, ..Default::default() };
        render_embree(&scene, &settings).0.pixels
    };
    let (a, b) = (render("texture_transform.glb"), render("texture_transform_baked.glb"));
    let differ = a.iter().zip(&b).filter(|(x, y)| (**x - **y).abs().max_element() > 1e-3 * x.max_element()).count();
    assert!(differ <= a.len() / 100, "{differ} of {} pixels differ", a.len());
}

/// A scene file beside a copy of the asset `gltf`, with `head` (camera, background) before it.
fn scene_with(dir: &Path, gltf: &str, head: &str) -> Scene {
    std::fs::copy(asset(gltf), dir.join(gltf)).unwrap();
    let p = dir.join(format!("{gltf}.toml"));
    std::fs::write(&p, format!("{head}\n[[meshes]]\nfile = \"{gltf}\"\n")).unwrap();
    Scene::load(&p).unwrap()
}

#[test]
fn an_emission_texture_is_seen_and_lights_as_its_texels_say() {
    let dir = fresh_dir("gltf-assets", "emission");
    // Seen straight on, filling the image: its mean radiance is the texture's over the quad,
    // (2.0, 1.4432, 1.05) (SOURCES.md), each 16×16-pixel block one block of the texture.
    let head = "[camera]\nposition = [0.0, 0.0, 5.0]\nlook_at = [0.0, 0.0, 0.0]\nfov = 22.619865\n";
    let scene = scene_with(&dir, "emissive_texture.glb", head);
    let settings = RenderSettings { width: 64, height: 64, spp: 4, max_depth: 0, ..Default::default() };
    let (film, _) = render_embree(&scene, &settings);
    let mean = film.pixels.iter().map(|p| p.as_dvec3()).sum::<glam::DVec3>() / film.pixels.len() as f64;
    println!("seen: mean radiance {mean}");
    assert!((mean - glam::DVec3::new(2.0, 1.4432, 1.05)).abs().max_element() < 0.01, "{mean}");
    // The top-left block is orange, its neighbour black.
    let px = |x: usize, y: usize| film.pixels[y * 64 + x];
    assert!((px(8, 8) - Vec3::new(4.0, 0.6908, 0.0)).abs().max_element() < 0.01, "{}", px(8, 8));
    assert_eq!(px(24, 8), Vec3::ZERO);

    // Lighting a floor: next-event estimation (which picks triangles by their power and reads
    // the texture at the point it samples) and BSDF sampling (which finds the texture where
    // its rays land) estimate the same light.
    let floor = "[camera]\nposition = [0.0, 3.0, 4.0]\nlook_at = [0.0, 0.0, 1.5]\n\n\
        [materials.floor]\ntype = \"diffuse\"\ncolor = [0.8, 0.8, 0.8]\n\n\
        [[quads]]\ncorner = [-3.0, -1.0, 4.0]\nedge1 = [6.0, 0.0, 0.0]\nedge2 = [0.0, 0.0, -4.0]\nmaterial = \"floor\"\n";
    let scene = scene_with(&dir, "emissive_texture.glb", floor);
    let mean_with = |estimator| {
        let s = RenderSettings { width: 32, height: 32, spp: 256, max_depth: 1, estimator, ..Default::default() };
        let (film, _) = render_embree(&scene, &s);
        film.pixels.iter().map(|p| p.element_sum() as f64).sum::<f64>() / film.pixels.len() as f64
    };
    let (nee, bsdf) = (mean_with(Estimator::NeeOnly), mean_with(Estimator::BsdfOnly));
    println!("floor: next-event estimation {nee:.5}, BSDF sampling {bsdf:.5}");
    assert!((nee - bsdf).abs() < 0.02 * bsdf, "NEE {nee} vs BSDF {bsdf}");
}

/// Blender's exporter writes a clear coat's weight and roughness and a sheen's colour and
/// roughness as textures (`ext_clearcoat_textured.glb`, `ext_sheen_textured.glb`: 8 sectors in
/// u, 4 bands in v, SOURCES.md): each is read from its channel (coat weight R, coat roughness
/// G, sheen colour RGB in sRGB, sheen roughness A) times its factor. Looked up at each
/// block's centre (bilinear filtering reaches one texel, the blocks are 8 × 16), within the
/// 8-bit steps.
#[test]
fn clearcoat_and_sheen_textures_are_read_channel_by_channel() {
    let centre = |s: usize, j: usize| ((s as f32 + 0.5) / 8.0, (j as f32 + 0.5) / 4.0);
    let f = load("ext_clearcoat_textured.glb");
    let MaterialKind::Pbr(PbrMaterial { clearcoat: Some(coat), .. }) = &f.materials[0].kind else {
        panic!("{:?}", f.materials[0].kind)
    };
    let f = load("ext_sheen_textured.glb");
    let MaterialKind::Pbr(PbrMaterial { sheen: Some(sheen), .. }) = &f.materials[0].kind else {
        panic!("{:?}", f.materials[0].kind)
    };
    let Texture::Map { map: rough_map, factor: rough_factor } = &sheen.roughness else {
        panic!("{:?}", sheen.roughness)
    };
    let orange = Vec3::new(1.0, 0.35, 0.05);
    for s in 0..8 {
        for j in 0..4 {
            let (u, v) = centre(s, j);
            let weight = at(&coat.factor, u, v, None).x;
            let roughness = at(&coat.roughness, u, v, None).y;
            let want = (if s % 2 == 0 { 1.0 } else { 0.0 }, [0.05, 0.25, 0.5, 0.8][j]);
            assert!(
                (weight - want.0).abs() < 1e-3 && (roughness - want.1).abs() < 2.5e-3,
                "coat ({s}, {j}): {weight} {roughness}, want {want:?}"
            );
            let colour = at(&sheen.color, u, v, None);
            let want_colour = if s % 2 == 0 { Vec3::ONE } else { orange };
            assert!((colour - want_colour).abs().max_element() < 0.01, "sheen colour ({s}, {j}): {colour}");
            let tc = TexCoords { uv: [Vec2::new(u, 1.0 - v); 2], width: 0.0 };
            let r = rough_factor.x * rough_map.sample(&tc).w;
            let want_r = [0.2, 0.4, 0.6, 0.9][j];
            assert!((r - want_r).abs() < 2.5e-3, "sheen roughness ({s}, {j}): {r}, want {want_r}");
        }
    }
}

/// Blender's exporter writes the Principled BSDF's Coat Normal, fed by a Normal Map node, as
/// `clearcoatNormalTexture` (`ext_clearcoat_normal.glb`: 16 longitude sectors alternately
/// tilting the coat's normal 20° up and down the bitangent, the base's normal left alone,
/// no `TANGENT`; SOURCES.md): the coat gets its own normal map, read linear with scale 1,
/// the mesh gets MikkTSpace tangents for it although the base has no normal map, and the
/// scene counts it as textured. Rendered under a gradient sky, the coat's reflections break
/// into the sectors: the image differs from the same scene with the map taken away far beyond
/// the noise (two seeds of the same scene).
#[test]
fn a_coat_normal_map_gives_the_coat_its_own_normal() {
    let f = load("ext_clearcoat_normal.glb");
    assert!(f.warnings.is_empty(), "{:?}", f.warnings);
    let MaterialKind::Pbr(PbrMaterial { normal: None, clearcoat: Some(coat), .. }) = &f.materials[0].kind else {
        panic!("{:?}", f.materials[0].kind)
    };
    let map = coat.normal.as_ref().expect("the coat's normal map");
    assert_eq!(map.scale, 1.0);
    let (s, c) = 20f32.to_radians().sin_cos();
    for sector in 0..16 {
        let n = at(&map.texture, (sector as f32 + 0.5) / 16.0, 0.4, None) * 2.0 - Vec3::ONE;
        let want = Vec3::new(0.0, if sector % 2 == 0 { s } else { -s }, c);
        assert!((n - want).abs().max_element() < 0.01, "sector {sector}: {n}, want {want}");
    }
    assert!(f.meshes.iter().all(|m| !m.mesh.tangents.is_empty()), "tangents for the coat's normal map");

    let dir = fresh_dir("gltf-assets", "coat-normal");
    let scene = scene_with(
        &dir,
        "ext_clearcoat_normal.glb",
        "[camera]\nposition = [0.0, 1.2, 3.6]\nlook_at = [0.0, 0.0, 0.0]\nfov = 40.0\n\n\
         [background]\ntype = \"gradient\"\nzenith = [0.2, 0.3, 0.8]\nhorizon = [2.0, 2.0, 2.0]\nground = [0.1, 0.1, 0.1]\n",
    );
    assert!(scene.effects().textures, "{}", scene.effects());
    let mut ignored = scene.clone();
    for m in &mut ignored.materials {
        if let MaterialKind::Pbr(PbrMaterial { clearcoat: Some(coat), .. }) = &mut m.kind {
            coat.normal = None;
        }
    }
    let render = |scene: &Scene, seed| {
        let settings =
            RenderSettings { width: 48, height: 48, spp: 512, adaptive: false, seed, ..RenderSettings::default() };
        render_embree(scene, &settings).0.pixels
    };
    let differ = |a: &[Vec3], b: &[Vec3]| {
        a.iter().zip(b).map(|(x, y)| (*x - *y).abs().element_sum() as f64).sum::<f64>()
            / a.iter().map(|x| x.element_sum() as f64).sum::<f64>()
    };
    let mapped = render(&scene, 0);
    let (noise, effect) = (differ(&mapped, &render(&scene, 1)), differ(&mapped, &render(&ignored, 0)));
    println!("relative difference: map against map (seed 1) {noise:.4}, map against none {effect:.4}");
    // Measured: 0.0153 against 0.0030.
    assert!(effect > 3.0 * noise, "the coat normal map changes the image by {effect}, noise {noise}");
}

/// The worst distance (position, normal, texture coordinates) from a corner of `a`'s triangles
/// to the nearest corner of the nearest triangle of `b`: two files of the same mesh, their
/// vertices and faces in any order. Texture coordinates are compared where the base colour
/// texture of material 0 looks them up (after its transform: a packer may quantize them and
/// undo it with `KHR_texture_transform`).
fn worst_corner_distance(a: &MeshFile, b: &MeshFile) -> (f32, f32, f32) {
    let corners = |f: &MeshFile| -> Vec<[(Vec3, Vec3, Vec2); 3]> {
        let Texture::Map { map, .. } = base_texture(f, 0) else { panic!("material 0 has no base colour texture") };
        let lookup = map.transform.map_or(glam::Affine2::IDENTITY, |t| t.0);
        f.meshes
            .iter()
            .flat_map(|m| {
                let t = &m.mesh;
                t.indices.iter().map(move |tri| {
                    tri.map(|i| {
                        let i = i as usize;
                        (t.positions[i], t.normals[i], lookup.transform_point2(t.uvs[i]))
                    })
                })
            })
            .collect()
    };
    let (a, b) = (corners(a), corners(b));
    assert_eq!(a.len(), b.len(), "triangle counts");
    let centre = |t: &[(Vec3, Vec3, Vec2); 3]| (t[0].0 + t[1].0 + t[2].0) / 3.0;
    let (mut worst_p, mut worst_n, mut worst_uv) = (0.0f32, 0.0f32, 0.0f32);
    for t in &a {
        let u = b
            .iter()
            .min_by(|x, y| (centre(x) - centre(t)).length().total_cmp(&(centre(y) - centre(t)).length()))
            .unwrap();
        for c in t {
            let m = u.iter().min_by(|x, y| (x.0 - c.0).length().total_cmp(&(y.0 - c.0).length())).unwrap();
            worst_p = worst_p.max((m.0 - c.0).length());
            worst_n = worst_n.max((m.1 - c.1).length());
            worst_uv = worst_uv.max((m.2 - c.2).length());
        }
    }
    (worst_p, worst_n, worst_uv)
}

/// The mean of a 48 × 48 render (64 spp, uniform) of a model under the default sky.
fn model_image_mean(name: &str) -> f64 {
    let scene = Scene::load(&asset(name)).unwrap();
    let settings = RenderSettings { width: 48, height: 48, spp: 64, adaptive: false, ..RenderSettings::default() };
    common::image_mean(&render_embree(&scene, &settings).0.pixels)
}

/// A Draco-compressed file (Blender's exporter with Draco, compression level 6, positions
/// quantized to 14 bits, normals to 10, coordinates to 12) decodes to the same torus as the
/// uncompressed file Blender wrote beside it: every triangle's corners within the quantization
/// steps (positions 1e-3 of a 2.2-wide torus, normals 0.01, coordinates 1e-3), and their
/// images alike.
#[test]
fn a_draco_compressed_mesh_decodes_to_the_uncompressed_one() {
    let (draco, plain) = (load("draco_torus.glb"), load("draco_torus_uncompressed.glb"));
    assert_eq!(draco.meshes.iter().map(|m| m.mesh.indices.len()).sum::<usize>(), 48 * 16 * 2);
    let (worst_p, worst_n, worst_uv) = worst_corner_distance(&draco, &plain);
    println!("worst corner: position {worst_p:.2e}, normal {worst_n:.2e}, uv {worst_uv:.2e}");
    assert!(worst_p < 1e-3 && worst_n < 0.01 && worst_uv < 1e-3, "{worst_p} {worst_n} {worst_uv}");
    // Rendered the same way, the two images agree within the noise of different triangles.
    let (md, mp) = (model_image_mean("draco_torus.glb"), model_image_mean("draco_torus_uncompressed.glb"));
    assert!((md / mp - 1.0).abs() < 0.005, "image means {md} and {mp}");
}

/// The same torus through gltfpack 1.3 (`-cc`: meshopt compression with the octahedral
/// filter on normals, KHR_mesh_quantization with positions in 14 bits, normals in 8, texture
/// coordinates in 12), once with EXT_meshopt_compression and once with KHR_meshopt_compression,
/// decodes to the uncompressed torus within those steps (positions 1e-3 of the 2.2-wide torus,
/// normals 0.02, coordinates 1e-3), and renders alike.
#[test]
fn meshopt_compressed_meshes_decode_to_the_uncompressed_one() {
    let plain = load("draco_torus_uncompressed.glb");
    let mp = model_image_mean("draco_torus_uncompressed.glb");
    for name in ["meshopt_torus.glb", "meshopt_torus_khr.glb"] {
        let (worst_p, worst_n, worst_uv) = worst_corner_distance(&load(name), &plain);
        println!("{name}: worst corner: position {worst_p:.2e}, normal {worst_n:.2e}, uv {worst_uv:.2e}");
        assert!(worst_p < 1e-3 && worst_n < 0.02 && worst_uv < 1e-3, "{name}: {worst_p} {worst_n} {worst_uv}");
        let m = model_image_mean(name);
        assert!((m / mp - 1.0).abs() < 0.005, "{name}: image means {m} and {mp}");
    }
}

/// A meshopt stream that does not decode (its bytes cut short or garbled) is an error naming
/// the view and the extension, and nothing is rendered from it.
#[test]
fn a_corrupt_meshopt_stream_is_an_error_naming_its_view() {
    let d = fresh_dir("gltf", "meshopt-corrupt");
    let bytes = std::fs::read(asset("meshopt_torus.glb")).unwrap();
    // The JSON chunk's length, then the binary chunk: the index stream (view 4) is its last
    // part; garble its bytes.
    let json_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let json: serde_json::Value = serde_json::from_slice(&bytes[20..20 + json_len]).unwrap();
    let ext = &json["bufferViews"][4]["extensions"]["EXT_meshopt_compression"];
    assert_eq!(ext["mode"], "TRIANGLES");
    let start = 20 + json_len + 8 + ext["byteOffset"].as_u64().unwrap() as usize;
    let mut bad = bytes.clone();
    for b in &mut bad[start..start + 64] {
        *b = 0xff;
    }
    let f = d.join("bad.glb");
    std::fs::write(&f, &bad).unwrap();
    let m = mesh_file::load(&f, &LoadBudget::unlimited()).unwrap_err().to_string();
    assert!(m.contains("bad.glb") && m.contains("bufferViews[4].extensions.EXT_meshopt_compression"), "{m}");
    assert!(m.contains("cannot be decoded"), "{m}");
    std::fs::remove_dir_all(&d).unwrap();
}

/// Rays along −Z through an n × n grid over the 2 × 2 quad at z = 0 (from z = 2): how many
/// meet a surface before z = `stop`, through `accel`'s intersect and occluded queries, and
/// the hits themselves (geometry, primitive) lane by lane.
fn grid_hits(accel: &dyn ember::accel::Accel, n: usize, stop: f32) -> (usize, usize, Vec<Option<(u32, u32)>>) {
    use ember::geometry::{Ray, RayPacket};
    let mut hits = Vec::new();
    let mut occluded = 0;
    let mut packet_hits = 0;
    let rays: Vec<Ray> = (0..n * n)
        .map(|k| {
            let (i, j) = (k % n, k / n);
            let p = |i: usize| -1.0 + 2.0 * (i as f32 + 0.5) / n as f32;
            Ray::new(Vec3::new(p(i), p(j), 2.0), Vec3::NEG_Z)
        })
        .collect();
    for r in &rays {
        hits.push(accel.intersect(r, 0.0, 2.0 - stop).unwrap().map(|h| (h.geom, h.prim)));
        occluded += accel.occluded(r, 0.0, 2.0 - stop).unwrap() as usize;
    }
    // The packet queries (camera rays) filter too.
    for chunk in rays.chunks(ember::geometry::LANES) {
        if chunk.len() < ember::geometry::LANES {
            break;
        }
        let packet = RayPacket::from_rays(chunk.try_into().unwrap());
        let found = accel.intersect_packet_deferred(&packet, [true; ember::geometry::LANES], 0.0, 2.0 - stop);
        packet_hits += found.iter().filter(|h| h.is_some()).count();
    }
    assert_eq!(packet_hits, hits.iter().filter(|h| h.is_some()).count(), "{}: packets", accel.name());
    (hits.iter().filter(|h| h.is_some()).count(), occluded, hits)
}

/// `alphaMode` MASK, `alphaCutoff` 0.3 (Blender's alpha clip): rays pass through the leaf
/// where its texture's alpha is below 0.3, camera, bounce and shadow rays alike, through
/// Embree's filter callback and the naive loop the same; the covered fraction is the
/// texture's: 0.4122 (tests/data/gltf/SOURCES.md), not 1.
#[test]
fn an_alpha_mask_cuts_holes_for_every_ray() {
    let scene = Scene::load(&asset("alpha_mask_leaf.glb")).unwrap();
    assert!(scene.effects().cutouts);
    let leaf: Vec<_> = scene
        .geometry
        .iter()
        .filter(|g| matches!(g, ember::geometry::Geometry::Mesh(m) if m.cutout.is_some()))
        .collect();
    assert_eq!(leaf.len(), 1);
    let device = ember::embree::Device::new().unwrap();
    let embree =
        ember::accel::EmbreeAccel::new(&device, &scene.geometry, ember::embree::BuildOptions::default()).unwrap();
    let naive = ember::accel::NaiveAccel::new(&scene.geometry);
    let n = 200;
    let (e_hits, e_occluded, e) = grid_hits(&embree, n, -0.01);
    let (n_hits, n_occluded, nv) = grid_hits(&naive, n, -0.01);
    // The studio ground lies below the leaf (y = -1): these rays, along −Z, miss it.
    let coverage = e_hits as f64 / (n * n) as f64;
    println!("coverage: embree {coverage:.4}, naive {:.4}", n_hits as f64 / (n * n) as f64);
    assert!((coverage - 0.4122).abs() < 0.01, "coverage {coverage}");
    assert_eq!((e_hits, n_hits), (e_occluded, n_occluded), "shadow rays pass where camera rays do");
    // Barycentrics differ in the last bits between the two: a ray on the ellipse's edge may
    // differ. At most 0.1% of the rays.
    // (Which of the quad's two triangles a ray on its diagonal meets may differ too.)
    let differ = e.iter().zip(&nv).filter(|(a, b)| a.is_some() != b.is_some()).count();
    assert!(differ * 1000 <= n * n, "{differ} rays differ between Embree and the naive loop");
}

/// `alphaMode` BLEND: stochastic transparency. The pane's alpha is 0.35: of the rays through
/// it, that fraction meets it, the rest go on to the quad behind.
#[test]
fn alpha_blend_is_met_with_probability_alpha() {
    let scene = Scene::load(&asset("alpha_blend_pane.glb")).unwrap();
    assert!(scene.effects().cutouts);
    let device = ember::embree::Device::new().unwrap();
    let embree =
        ember::accel::EmbreeAccel::new(&device, &scene.geometry, ember::embree::BuildOptions::default()).unwrap();
    let naive = ember::accel::NaiveAccel::new(&scene.geometry);
    // Rays stopping between the pane (z = 0.5) and the quad (z = 0): only the pane, which
    // covers (−0.3..0.9)² of the 2 × 2 grid: 0.36 of it.
    for accel in [&embree as &dyn ember::accel::Accel, &naive] {
        let n = 200;
        let (hits, occluded, _) = grid_hits(accel, n, 0.25);
        let fraction = hits as f64 / (n * n) as f64 / 0.36;
        println!("{}: {fraction:.4} of the rays through the pane meet it", accel.name());
        // 14,400 rays through the pane: a binomial fraction's 4 standard deviations, 0.016.
        assert!((fraction - 0.35).abs() < 0.02, "{}: {fraction}", accel.name());
        assert!((occluded as f64 / hits as f64 - 1.0).abs() < 0.05, "{}: occluded {occluded}", accel.name());
    }
}

#[test]
fn instanced_nodes_share_one_mesh_and_render_as_their_copies() {
    // instanced_blender.glb: one icosphere mesh used by 50 nodes; instanced_copies_trimesh.glb:
    // the same 50 spheres as 50 meshes (SOURCES.md).
    use ember::accel::{EmbreeAccel, build_options_for};
    use ember::geometry::Geometry;
    let budget = LoadBudget::unlimited();
    let instanced = mesh_file::scene_of(&asset("instanced_blender.glb"), &budget).unwrap();
    let copies = mesh_file::scene_of(&asset("instanced_copies_trimesh.glb"), &budget).unwrap();
    let placed: Vec<_> = instanced
        .geometry
        .iter()
        .filter_map(|g| match g {
            Geometry::Instance(i) => Some(i),
            _ => None,
        })
        .collect();
    assert_eq!(placed.len(), 50);
    assert!(placed.iter().all(|i| std::sync::Arc::ptr_eq(&i.mesh, &placed[0].mesh)), "one mesh, shared");
    assert_eq!(copies.geometry.iter().filter(|g| matches!(g, Geometry::Mesh(_))).count(), 50 + 1, "and the ground");
    assert_eq!(instanced.primitive_counts(), copies.primitive_counts());

    // Memory: ember's arrays and Embree's (its BVHs and buffers) hold the mesh once.
    let embree_bytes = |scene: &Scene| {
        let device = ember::embree::Device::new().unwrap();
        let before = device.memory_in_use();
        let accel = EmbreeAccel::new(&device, &scene.geometry, build_options_for(&scene.geometry)).unwrap();
        let bytes = device.memory_in_use() - before;
        drop(accel);
        bytes
    };
    let (ours, theirs) = (instanced.data_bytes(), copies.data_bytes());
    let (embree_ours, embree_theirs) = (embree_bytes(&instanced), embree_bytes(&copies));
    let mesh = placed[0].mesh.heap_bytes();
    println!(
        "one mesh {mesh} B; ember's data: instances {ours} B, copies {theirs} B; Embree: instances {embree_ours} B, \
         copies {embree_theirs} B"
    );
    assert!(ours < 2 * mesh + 50 * 256, "instances hold {ours} B for a mesh of {mesh} B");
    assert!(theirs > 40 * mesh, "the copies hold {theirs} B");
    assert!(embree_ours * 5 < embree_theirs, "Embree: {embree_ours} B for instances, {embree_theirs} B for copies");

    // The image: the same, but for rounding where rays meet the spheres (the copies' vertices
    // were moved by trimesh, the instances' rays are moved by Embree).
    let settings = RenderSettings { width: 64, height: 48, spp: 16, max_depth: 4, ..Default::default() };
    let a = render_embree(&instanced, &settings).0.pixels;
    let b = render_embree(&copies, &settings).0.pixels;
    let (ma, mb) = (common::image_mean(&a), common::image_mean(&b));
    println!("means: instances {ma:.5}, copies {mb:.5}");
    assert!((ma / mb - 1.0).abs() < 0.005, "means {ma} vs {mb}");
    let differ =
        a.iter().zip(&b).filter(|(x, y)| (**x - **y).abs().max_element() > 0.02 * x.max_element().max(0.05)).count();
    assert!(differ <= a.len() / 50, "{differ} of {} pixels differ", a.len());
}

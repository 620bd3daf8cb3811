//! A mesh file rendered on its own: the studio it gets (a sky, a ground with the model's
//! shadow, a clay material), when it gets none (it lights itself), `--env` in its place, and a
//! scene file's `[[meshes]]` material override.

mod common;

use ember::geometry::Geometry;
use ember::integrator::RenderSettings;
use ember::light::Background;
use ember::memory::{LoadBudget, MemoryLimit};
use ember::scene::mesh_file::{CLAY, STUDIO_GROUND};
use ember::scene::{CameraOverride, Orbit, Scene};
use ember::texture::Texture;
use glam::Vec3;
use std::path::{Path, PathBuf};

fn diffuse_colour(scene: &Scene, material: u32) -> Option<Vec3> {
    match &scene.materials[material as usize].kind {
        ember::material::MaterialKind::Diffuse(d) => match d.color {
            Texture::Constant(c) => Some(c),
            _ => None,
        },
        _ => None,
    }
}

#[test]
fn a_bare_mesh_stands_in_a_studio_and_the_camera_frames_the_mesh_alone() {
    let scene = Scene::load(&common::scene_path("bunny.obj")).unwrap();
    assert!(matches!(scene.background(), Background::Gradient { .. }));
    let g = scene.ground.expect("a studio ground");
    assert_eq!(g, scene.geometry.len() - 1);
    let Geometry::Mesh(ground) = &scene.geometry[g] else { panic!("the ground is a mesh") };
    let bunny = scene.subject_bounds();
    let size = bunny.diagonal().length();
    // Under the lowest point, by a hair; flat, and 100 times the model across.
    assert!(ground.positions.iter().all(|p| p.y < bunny.min.y && p.y > bunny.min.y - 1e-3 * size));
    let gb = ground.bounds();
    assert!(gb.max.x - gb.min.x >= 99.0 * size && gb.max.z - gb.min.z >= 99.0 * size, "{gb:?}");
    assert_eq!(diffuse_colour(&scene, scene.bindings[g].material(0)), Some(STUDIO_GROUND));
    // The bunny has no material of its own: the clay.
    assert_eq!(diffuse_colour(&scene, scene.bindings[0].material(0)), Some(CLAY));
    // The automatic camera and an orbit frame the bunny as if the ground were not there.
    let mut alone = scene.clone();
    alone.geometry.truncate(g);
    alone.bindings.truncate(g);
    alone.ground = None;
    assert_eq!(scene.camera_spec(1.5), alone.camera_spec(1.5));
    let orbit =
        CameraOverride { orbit: Some(Orbit { azimuth: 120.0, elevation: 10.0, distance: None }), ..Default::default() };
    let (mut a, mut b) = (scene.clone(), alone);
    a.override_camera(&orbit, 1.5).unwrap();
    b.override_camera(&orbit, 1.5).unwrap();
    assert_eq!(a.camera, b.camera);
}

/// A unit cube on the studio ground seen from straight above (orthographic): the ground
/// beside the cube, in its shadow, is darker than the ground farther out; the cube's top,
/// clay under the open sky, is brighter than both.
#[test]
fn the_studio_ground_shows_the_models_shadow() {
    let d = common::fresh_dir("bare-mesh", "shadow");
    let obj = d.join("cube.obj");
    let mut text = String::new();
    for i in 0..8 {
        text += &format!("v {} {} {}\n", i & 1, (i >> 1) & 1, (i >> 2) & 1);
    }
    // Faces wound outward (1-based: bit 0 = x, bit 1 = y, bit 2 = z).
    text += "f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n";
    std::fs::write(&obj, text).unwrap();
    let mut scene = Scene::load(&obj).unwrap();
    assert!(scene.ground.is_some());
    let top = CameraOverride {
        orbit: Some(Orbit { azimuth: 0.0, elevation: 90.0, distance: Some(5.0) }),
        ortho: Some(4.0),
        ..Default::default()
    };
    scene.override_camera(&top, 1.0).unwrap();
    let settings = RenderSettings { width: 40, height: 40, spp: 64, adaptive: false, ..RenderSettings::default() };
    let (film, _) = common::render_embree(&scene, &settings);
    // 10 pixels a unit: the cube covers 15..25 in x and y; the ground beside it, in its
    // shadow, is the two columns each side.
    let mean = |xs: std::ops::Range<u32>, ys: std::ops::Range<u32>| {
        let (mut sum, mut n) = (0.0, 0.0);
        for y in ys {
            for x in xs.clone() {
                sum += film.get(x, y).element_sum() / 3.0;
                n += 1.0;
            }
        }
        sum / n
    };
    let cube_top = mean(17..23, 17..23);
    let beside = (mean(13..15, 17..23) + mean(25..27, 17..23)) / 2.0;
    let far = (mean(0..4, 0..4) + mean(36..40, 36..40)) / 2.0;
    println!("cube top {cube_top:.3}, ground beside it {beside:.3}, ground far out {far:.3}");
    assert!(beside < 0.87 * far, "no shadow: beside {beside}, far {far}");
    assert!(cube_top > far, "the clay top {cube_top} is darker than the ground {far}");
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn a_mesh_that_lights_itself_gets_no_studio_and_a_textured_glow_does() {
    let d = common::fresh_dir("bare-mesh", "lit");
    std::fs::write(d.join("lamp.mtl"), "newmtl lamp\nKd 0 0 0\nKe 5 5 5\n").unwrap();
    std::fs::write(
        d.join("lamp.obj"),
        "mtllib lamp.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 5\nv 1 0 5\nv 0 1 5\nf 4 5 6\nusemtl lamp\nf 1 2 3\n",
    )
    .unwrap();
    let lamp = Scene::load(&d.join("lamp.obj")).unwrap();
    assert_eq!(lamp.ground, None);
    assert!(matches!(lamp.background(), Background::Black));
    // A texture's glow (a helmet's lit visor, a screen) is not how a model is lit.
    let glow = Scene::load(&gltf("emissive_texture.glb")).unwrap();
    assert!(glow.materials.iter().any(|m| m.is_emissive()));
    assert!(glow.ground.is_some() && matches!(glow.background(), Background::Gradient { .. }));
    std::fs::remove_dir_all(&d).unwrap();
}

fn gltf(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/gltf").join(name)
}

#[test]
fn an_environment_replaces_the_studio() {
    let mut scene = Scene::load(&common::scene_path("bunny.obj")).unwrap();
    let triangles = scene.primitive_counts().0;
    let sky = common::scene_path("sky.exr");
    let budget = LoadBudget::new(MemoryLimit::current());
    scene.set_environment(&sky, 2.0, 90.0, &budget).unwrap();
    assert!(matches!(scene.background(), Background::Image(_)));
    assert_eq!(scene.ground, None);
    assert_eq!(scene.primitive_counts().0, triangles - 2, "the ground's two triangles are gone");
    assert!(scene.inputs.contains(&sky));
    // The strength scales the radiance; the turn is about +Y.
    let mut plain = Scene::load(&common::scene_path("bunny.obj")).unwrap();
    plain.set_environment(&sky, 1.0, 0.0, &budget).unwrap();
    let (a, b) = (scene.background(), plain.background());
    for d in [Vec3::Y, Vec3::new(0.3, 0.2, 0.9).normalize(), Vec3::new(-0.8, 0.1, 0.2).normalize()] {
        let turned = glam::Quat::from_rotation_y(-90f32.to_radians()) * d;
        let (x, y) = (a.radiance(d), 2.0 * b.radiance(turned));
        let y2 = 2.0 * b.radiance(glam::Quat::from_rotation_y(90f32.to_radians()) * d);
        assert!(
            (x - y).abs().max_element() <= 1e-3 * x.max_element().max(1.0)
                || (x - y2).abs().max_element() <= 1e-3 * x.max_element().max(1.0),
            "{d}: {x} vs {y} or {y2}"
        );
    }
}

#[test]
fn env_on_the_command_line() {
    let d = common::fresh_dir("bare-mesh", "env-cli");
    let out = d.join("out.png");
    let (bunny, sky) = (common::scene_path("bunny.obj"), common::scene_path("sky.exr"));
    let small = ["--width", "8", "--height", "6", "--spp", "2"];
    let run = |extra: &[&str]| {
        let args = [&["render", bunny.to_str().unwrap(), "-o", out.to_str().unwrap()][..], &small, extra].concat();
        common::ember(&args)
    };
    let o = run(&["--env", sky.to_str().unwrap(), "--env-rotate", "-30", "--env-strength", "0.5"]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{e}");
    assert!(e.contains("environment") && out.is_file(), "{e}");
    std::fs::remove_file(&out).unwrap();
    // A missing image: named, exit 2, nothing written.
    let missing = d.join("nowhere.hdr");
    let o = run(&["--env", missing.to_str().unwrap()]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains(&format!("--env: environment image {}: ", missing.display())), "{e}");
    // A turn or strength without an image, and a strength that is not positive.
    for bad in [&["--env-rotate", "10"][..], &["--env", sky.to_str().unwrap(), "--env-strength", "0"]] {
        let o = run(bad);
        assert_eq!(o.status.code(), Some(2), "{bad:?}");
    }
    assert!(std::fs::read_dir(&d).unwrap().next().is_none(), "files written");
    std::fs::remove_dir_all(&d).unwrap();
}

/// `[[meshes]] material` replaces the material of a file's untextured meshes and keeps the
/// textured ones; `override = "all"` replaces every one.
#[test]
fn a_mesh_material_override_keeps_textures_unless_asked() {
    let scene_text = |scope: &str| {
        format!(
            "[materials.gold]\ntype = \"metal\"\ncolor = [1.0, 0.8, 0.3]\nroughness = 0.2\n\
             [[meshes]]\nfile = \"{}\"\nmaterial = \"gold\"\n{scope}\
             [[meshes]]\nfile = \"{}\"\nmaterial = \"gold\"\n{scope}",
            gltf("metal_rough_sphere.glb").display(),
            Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/meshes/icosphere.obj").display(),
        )
    };
    let gold = |s: &Scene, g: usize| s.materials[s.bindings[g].material(0) as usize].name == "gold";
    let kept = Scene::from_toml_str(&scene_text(""), Path::new("override.toml")).unwrap();
    let n = kept.geometry.len();
    assert!(n >= 2);
    assert!(!gold(&kept, 0), "the textured sphere lost its material");
    assert!(kept.materials[kept.bindings[0].material(0) as usize].has_texture_map());
    assert!(gold(&kept, n - 1), "the untextured icosphere kept its own");
    let all = Scene::from_toml_str(&scene_text("override = \"all\"\n"), Path::new("override.toml")).unwrap();
    assert!((0..n).all(|g| gold(&all, g)));
    let e = Scene::from_toml_str(&scene_text("override = \"some\"\n"), Path::new("override.toml")).unwrap_err();
    assert!(e.to_string().contains("untextured") && e.line.is_some(), "{e}");
}

//! Scene analysis and specialised kernels: what the analysis finds in each sample scene and in
//! small scenes built for one point each, and that the specialised kernel renders the same
//! image as the general one (`--no-specialize`), bit for bit.

mod common;

use ember::integrator::{KernelChoice, RenderSettings};
use ember::scene::{DepthLimit, Effects, Scene};

fn scene_from(name: &str, text: &str) -> Scene {
    Scene::load(&common::write_scene("effects", name, text)).unwrap_or_else(|e| panic!("{e}"))
}

fn on(e: &Effects) -> Vec<&'static str> {
    e.list().iter().filter(|(_, p)| *p).map(|(n, _)| *n).collect()
}

fn small(spp: u32) -> RenderSettings {
    RenderSettings { width: 40, height: 30, spp, max_depth: 8, seed: 7, ..Default::default() }
}

#[test]
fn sample_scenes_have_the_effects_they_use() {
    let cases: [(&str, &[&str]); 9] = [
        (
            "teapot.toml",
            &["triangles", "diffuse", "glossy", "emissive", "texture", "area lights", "sky", "indirect light"],
        ),
        ("cornell.toml", &["triangles", "diffuse", "point lights", "indirect light"]),
        ("cornell-area.toml", &["triangles", "diffuse", "emissive", "area lights", "indirect light"]),
        (
            "spheres.toml",
            &[
                "triangles",
                "spheres",
                "cylinders",
                "diffuse",
                "glossy",
                "mirror",
                "glass",
                "emissive",
                "texture",
                "area lights",
                "sky",
                "indirect light",
            ],
        ),
        (
            "dof.toml",
            &["triangles", "spheres", "diffuse", "glossy", "texture", "sky", "depth of field", "indirect light"],
        ),
        ("gltf-sky.toml", &["triangles", "diffuse", "glossy", "texture", "environment", "indirect light"]),
        ("teapot.obj", &["triangles", "diffuse", "sky", "indirect light"]),
        // Embree's file defines an emissive material whose light face is commented out: unused
        // materials do not count, so the mesh gets a sky.
        ("cornell_box.obj", &["triangles", "diffuse", "sky", "indirect light"]),
        ("bunny.obj", &["triangles", "diffuse", "sky", "indirect light"]),
    ];
    for (name, expected) in cases {
        let e = Scene::load(&common::scene_path(name)).unwrap().effects();
        assert_eq!(on(&e), expected.to_vec(), "{name}");
        assert!(e.lit, "{name}");
        assert_eq!(e.depth_limit(), DepthLimit::Unbounded, "{name}");
    }
}

#[test]
fn the_report_line_names_what_is_on_and_off() {
    let e = Scene::load(&common::scene_path("cornell.toml")).unwrap().effects();
    assert_eq!(
        e.to_string(),
        "effects: triangles, diffuse, point lights, indirect light — off: spheres, cylinders, glossy, mirror, glass, \
         emissive, texture, cut-outs, area lights, sky, environment, depth of field"
    );
    assert_eq!(
        KernelChoice::for_effects(&e),
        KernelChoice { lens: false, textures: false, glossy: false, glass: false, hit_lights: false }
    );
}

const ONE_SPHERE: &str = r#"
[camera]
position = [0, 0, 4]
look_at = [0, 0, 0]
fov = 40
[background]
type = "constant"
color = [1, 1, 1]
[materials.white]
type = "diffuse"
color = [0.7, 0.7, 0.7]
[[spheres]]
center = [0, 0, 0]
radius = 1
material = "white"
"#;

#[test]
fn one_convex_object_needs_direct_light_only() {
    let scene = scene_from("one-sphere.toml", ONE_SPHERE);
    let e = scene.effects();
    assert!(!e.indirect);
    assert_eq!(e.depth_limit(), DepthLimit::DirectOnly);
    let (spec, stats) = common::render_embree(&scene, &small(8));
    assert_eq!(stats.plan.path_depth, 1);
    // The general kernel at depth 8 traces the same paths: a ray leaving a convex object never
    // meets it again, so depth 1 loses nothing.
    let (general, gstats) = common::render_embree(&scene, &RenderSettings { specialize: false, ..small(8) });
    assert_eq!(gstats.plan.path_depth, 8);
    assert_eq!(spec, general);
    assert_eq!(stats.rays, gstats.rays);
    // And it is not trivially black: the sphere under a white sky is lit.
    assert!(spec.mean().x > 0.3);
}

#[test]
fn a_camera_inside_the_one_sphere_needs_deep_paths() {
    // From inside, a sphere's surface sees itself (hard case inside-sphere).
    let inside = ONE_SPHERE.replace("position = [0, 0, 4]", "position = [0, 0, 0.5]");
    let e = scene_from("inside-sphere.toml", &inside).effects();
    assert!(e.indirect);
    assert_eq!(e.depth_limit(), DepthLimit::Unbounded);
}

#[test]
fn a_glass_sphere_alone_needs_deep_paths() {
    let glass = ONE_SPHERE.replace("type = \"diffuse\"\ncolor = [0.7, 0.7, 0.7]", "type = \"glass\"\nior = 1.5");
    let e = scene_from("glass-sphere.toml", &glass).effects();
    assert!(e.glass && e.indirect);
    assert_eq!(e.depth_limit(), DepthLimit::Unbounded);
}

#[test]
fn only_emitters_need_no_bounce_and_no_light_needs_no_ray() {
    let emitter = ONE_SPHERE
        .replace("type = \"diffuse\"\ncolor = [0.7, 0.7, 0.7]", "type = \"emissive\"\nemission = [2, 2, 2]")
        .replace("color = [1, 1, 1]", "color = [0, 0, 0]");
    let scene = scene_from("emitter.toml", &emitter);
    assert_eq!(scene.effects().depth_limit(), DepthLimit::EmittersOnly);
    let (film, stats) = common::render_embree(&scene, &small(4));
    assert_eq!(stats.plan.path_depth, 0);
    let centre = film.get(20, 15);
    assert_eq!(centre, glam::Vec3::splat(2.0), "an emitter seen directly has exactly its radiance");

    let dark = ONE_SPHERE.replace("color = [1, 1, 1]", "color = [0, 0, 0]");
    let scene = scene_from("dark.toml", &dark);
    let e = scene.effects();
    assert!(!e.lit);
    assert!(e.to_string().ends_with("(no light: the image is black)"));
    let (film, stats) = common::render_embree(&scene, &small(4));
    assert_eq!(stats.rays, 0, "nothing emits: no ray needs tracing");
    assert!(film.pixels.iter().all(|p| *p == glam::Vec3::ZERO));
    let (general, gstats) = common::render_embree(&scene, &RenderSettings { specialize: false, ..small(4) });
    assert!(gstats.rays > 0);
    assert_eq!(film, general);
}

#[test]
fn unused_materials_and_textures_do_not_switch_effects_on() {
    let extra = format!(
        "{ONE_SPHERE}\n[materials.unused_glass]\ntype = \"glass\"\nior = 1.5\n\
         [materials.unused_earth]\ntype = \"diffuse\"\ntexture = \"earthmap.jpg\"\n"
    );
    let e = scene_from("unused.toml", &extra).effects();
    assert!(!e.glass && !e.textures, "{e}");
}

#[test]
fn specialised_and_general_kernels_give_bit_identical_images() {
    // Every scene in scenes/, plus the one-sphere scene (whose specialised kernel also uses a
    // shorter path depth). Bit-identical: each switch only removes work whose result is known.
    let mut scenes: Vec<(String, Scene)> =
        ["teapot.toml", "cornell.toml", "cornell-area.toml", "spheres.toml", "dof.toml", "gltf-sky.toml"]
            .iter()
            .chain(["teapot.obj", "cornell_box.obj", "bunny.obj"].iter())
            .map(|n| (n.to_string(), Scene::load(&common::scene_path(n)).unwrap()))
            .collect();
    scenes.push(("one-sphere".into(), scene_from("one-sphere-2.toml", ONE_SPHERE)));
    for (name, scene) in &scenes {
        let (a, sa) = common::render_embree(scene, &small(2));
        let (b, sb) = common::render_embree(scene, &RenderSettings { specialize: false, ..small(2) });
        assert_eq!(sb.plan.kernel, KernelChoice::GENERAL);
        let same = a
            .pixels
            .iter()
            .zip(&b.pixels)
            .all(|(p, q)| p.to_array().map(f32::to_bits) == q.to_array().map(f32::to_bits));
        assert!(same, "{name}: kernel {} differs from the general kernel", sa.plan.kernel);
        assert!(a.mean().max_element() > 0.005, "{name} is black");
    }
}

//! Light choice weighed by visibility (`--light-visibility`, `light::visibility` and the pass
//! of `integrator::visibility`): in a room lit through a window by the sky and a sun, where
//! most light samples hit the walls, next-event estimation learns which lights its samples
//! reach. The image must stay the same in expectation, be bit-identical for any thread
//! count, lower the noise it is for, and leave an open scene as it was.

mod common;

use ember::film::Film;
use ember::integrator::RenderSettings;
use ember::scene::Scene;
use ember::settings::LightVisibility;

/// A closed room (4 × 3 × 4, walls 0.7) lit through a window in its -x wall by a white sky
/// and a small bright "sun" quad outside, whose light falls through the window onto the floor.
fn room() -> Scene {
    let quad = |c: [f32; 3], e1: [f32; 3], e2: [f32; 3], m: &str| {
        format!("[[quads]]\ncorner = {c:?}\nedge1 = {e1:?}\nedge2 = {e2:?}\nmaterial = \"{m}\"\n")
    };
    let mut text = String::from(
        "[camera]\nposition = [1.7, 1.6, 1.7]\nlook_at = [-0.8, 0.9, -0.8]\nfov = 70\n\
         [background]\ntype = \"constant\"\ncolor = [1.0, 1.0, 1.0]\n\
         [materials.wall]\ntype = \"diffuse\"\ncolor = [0.7, 0.7, 0.7]\n\
         [materials.sun]\ntype = \"emissive\"\nemission = [500.0, 500.0, 500.0]\n",
    );
    let (w, h) = (2.0, 3.0);
    for q in [
        quad([-w, 0.0, -w], [0.0, 0.0, 2.0 * w], [2.0 * w, 0.0, 0.0], "wall"),
        quad([-w, h, -w], [2.0 * w, 0.0, 0.0], [0.0, 0.0, 2.0 * w], "wall"),
        quad([-w, 0.0, -w], [2.0 * w, 0.0, 0.0], [0.0, h, 0.0], "wall"),
        quad([-w, 0.0, w], [0.0, h, 0.0], [2.0 * w, 0.0, 0.0], "wall"),
        quad([w, 0.0, -w], [0.0, 0.0, 2.0 * w], [0.0, h, 0.0], "wall"),
        // The -x wall around a window 1.6 wide and 1.2 high.
        quad([-w, 0.0, -w], [0.0, 0.9, 0.0], [0.0, 0.0, 2.0 * w], "wall"),
        quad([-w, 2.1, -w], [0.0, 0.9, 0.0], [0.0, 0.0, 2.0 * w], "wall"),
        quad([-w, 0.9, -w], [0.0, 1.2, 0.0], [0.0, 0.0, 1.2], "wall"),
        quad([-w, 0.9, 0.8], [0.0, 1.2, 0.0], [0.0, 0.0, 1.2], "wall"),
        quad([-5.0, 4.0, -0.5], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], "sun"),
    ] {
        text += &q;
    }
    Scene::load(&common::write_scene("light_visibility", "room.toml", &text)).unwrap_or_else(|e| panic!("{e}"))
}

fn settings(spp: u32, seed: u64, light_visibility: LightVisibility) -> RenderSettings {
    RenderSettings {
        width: 48,
        height: 48,
        spp,
        seed,
        max_depth: 6,
        adaptive: false,
        light_visibility,
        ..RenderSettings::default()
    }
}

/// The image, checked to have weighed the light choice (or not).
fn render(scene: &Scene, settings: &RenderSettings, weighed: bool) -> Film {
    let (film, stats) = common::render_embree(scene, settings);
    assert_eq!(stats.light_visibility_cells.is_some(), weighed, "{}", stats.plan);
    assert_eq!(stats.nonfinite, 0);
    film
}

#[test]
fn weighing_by_visibility_keeps_the_image_and_lowers_its_noise() {
    // 4 seeds at 64 spp against a 4096-spp render without weights. Measured: relMSE 0.62 of
    // the unweighted one's.
    let scene = room();
    let reference = render(&scene, &settings(4096, 99, LightVisibility::Off), false);
    let reference_mean = common::image_mean(&reference.pixels);
    let (mut weighed, mut plain) = (0.0, 0.0);
    for seed in 1..=4 {
        let film = render(&scene, &settings(64, seed, LightVisibility::Auto), true);
        let m = common::image_mean(&film.pixels);
        assert!((m / reference_mean - 1.0).abs() < 0.02, "seed {seed}: mean {m} against {reference_mean}");
        weighed += common::rel_mse(&film, &reference);
        plain += common::rel_mse(&render(&scene, &settings(64, seed, LightVisibility::Off), false), &reference);
    }
    println!("relMSE weighed {weighed:.5}, by importance alone {plain:.5}: {:.2}×", weighed / plain);
    assert!(weighed < 0.8 * plain, "relMSE weighed {weighed}, by importance alone {plain}");
}

#[test]
fn the_weights_give_one_image_for_any_thread_count() {
    let scene = room();
    let bits = |f: &Film| f.pixels.iter().flat_map(|p| p.to_array().map(f32::to_bits)).collect::<Vec<_>>();
    let one = render(&scene, &RenderSettings { threads: Some(1), ..settings(8, 0, LightVisibility::Auto) }, true);
    for threads in [2, 3] {
        let other =
            render(&scene, &RenderSettings { threads: Some(threads), ..settings(8, 0, LightVisibility::Auto) }, true);
        assert_eq!(bits(&one), bits(&other), "{threads} threads");
    }
}

#[test]
fn an_open_scene_keeps_the_choice_by_importance() {
    // teapot.toml (an area light and a sky over a floor): most light samples get through, so
    // the weights are not kept and the image is the one without them, bit for bit.
    let scene = Scene::load(&common::scene_path("teapot.toml")).unwrap();
    let s = |v| RenderSettings { width: 40, height: 30, spp: 4, light_visibility: v, ..RenderSettings::default() };
    let (on, stats) = common::render_embree(&scene, &s(LightVisibility::Auto));
    assert_eq!(stats.light_visibility_cells, None);
    let (off, _) = common::render_embree(&scene, &s(LightVisibility::Off));
    assert_eq!(on.pixels, off.pixels);
}

//! Light choice weighed by visibility (`--light-visibility`, `light::visibility` and the pass
//! of `integrator::visibility`): in a room lit through a window by the sky and a sun, where
//! most light samples hit the walls, next-event estimation learns which lights its samples
//! reach. The image must stay the same in expectation, be bit-identical for any thread
//! count, lower the noise it is for, and leave an open scene as it was.

mod common;

use ember::film::Film;
use ember::integrator::RenderSettings;
use ember::scene::Scene;
use ember::settings::{LightVertices, LightVisibility};

fn room() -> Scene {
    common::window_room("light_visibility")
}

fn settings(spp: u32, seed: u64, light_visibility: LightVisibility) -> RenderSettings {
    RenderSettings {
        light_visibility,
        // The room's sun would also give light vertices: this file is about the choice alone.
        light_vertices: LightVertices::Off,
        ..common::window_room_settings(spp, seed)
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

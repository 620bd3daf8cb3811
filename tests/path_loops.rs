//! The two path loops (`--path-loop scalar|wavefront`) compute the same image, bit for bit:
//! the wavefront loop shades each path with the scalar loop's code, in the same order on the
//! same numbers, and only regroups the work. Checked on every sample scene, through both
//! accelerators, uniform and adaptive, with the auxiliary images and with several threads.

mod common;

use ember::accel::{Accel, NaiveAccel};
use ember::embree::{BuildOptions, Device};
use ember::integrator::{RenderControl, RenderPlan, RenderSettings, RenderStats, render_controlled};
use ember::scene::Scene;
use ember::settings::PathLoop;

fn render(scene: &Scene, accel: &dyn Accel, settings: &RenderSettings) -> (ember::film::Accumulator, RenderStats) {
    let plan = RenderPlan::new(scene, settings);
    let r = render_controlled(scene, accel, &plan, RenderControl::default()).unwrap();
    (r.accum, r.stats)
}

/// Renders `scene` with both loops and checks the sums of every pixel (radiance, squares,
/// counts, auxiliary sums) and the rays traced are equal.
fn assert_loops_agree(name: &str, scene: &Scene, accel: &dyn Accel, settings: &RenderSettings) {
    let scalar = RenderSettings { path_loop: PathLoop::Scalar, ..settings.clone() };
    let wavefront = RenderSettings { path_loop: PathLoop::Wavefront, ..settings.clone() };
    let (a, sa) = render(scene, accel, &scalar);
    let (b, sb) = render(scene, accel, &wavefront);
    assert!(a.samples() > 0);
    assert_eq!(a.pixels.len(), b.pixels.len());
    for (i, (p, q)) in a.pixels.iter().zip(&b.pixels).enumerate() {
        assert_eq!(p.count, q.count, "{name}: pixel {i} took another number of samples");
        assert_eq!(p.sum.to_array().map(f64::to_bits), q.sum.to_array().map(f64::to_bits), "{name}: pixel {i}");
        assert_eq!(p.sum_lum_sq.to_bits(), q.sum_lum_sq.to_bits(), "{name}: pixel {i}");
    }
    assert_eq!(a.aux, b.aux, "{name}: auxiliary sums differ");
    assert_eq!(a.adaptive, b.adaptive, "{name}: the adaptive plans differ");
    assert_eq!((sa.rays, sa.samples, sa.nonfinite), (sb.rays, sb.samples, sb.nonfinite), "{name}");
    assert!(a.film().mean().max_element() > 0.005, "{name} is black");
}

fn scenes() -> Vec<(&'static str, Scene)> {
    [
        "teapot.toml",
        "cornell.toml",
        "cornell-area.toml",
        "spheres.toml",
        "dof.toml",
        "gltf-sky.toml",
        "lamps.toml",
        "helmet.toml",
        "bunny.obj",
    ]
    .iter()
    .map(|&n| (n, Scene::load(&common::scene_path(n)).unwrap()))
    .collect()
}

fn small(spp: u32) -> RenderSettings {
    // 20 pixels wide: two tiles across, the second cut short; 13 spp: groups of 8 and 5.
    RenderSettings { width: 20, height: 12, spp, max_depth: 8, seed: 11, adaptive: false, ..Default::default() }
}

#[test]
fn both_loops_give_the_same_image_through_embree() {
    let device = Device::new().unwrap();
    for (name, scene) in scenes() {
        let accel = ember::accel::EmbreeAccel::new(&device, &scene.geometry, BuildOptions::default()).unwrap();
        assert_loops_agree(name, &scene, &accel, &small(13));
        // With the auxiliary images (albedo, normal), on two threads.
        let aux = RenderSettings { aux: true, threads: Some(2), ..small(5) };
        assert_loops_agree(name, &scene, &accel, &aux);
    }
}

#[test]
fn both_loops_give_the_same_adaptive_image() {
    // An adaptive render's plan depends on each pixel's first-round samples and rays: the
    // wavefront loop counts rays per group as the scalar loop counts them per pixel.
    let device = Device::new().unwrap();
    for (name, scene) in scenes().into_iter().filter(|(n, _)| ["teapot.toml", "cornell.toml"].contains(n)) {
        let accel = ember::accel::EmbreeAccel::new(&device, &scene.geometry, BuildOptions::default()).unwrap();
        let adaptive = RenderSettings { adaptive: true, ..small(64) };
        assert_loops_agree(name, &scene, &accel, &adaptive);
    }
}

#[test]
fn both_loops_give_the_same_image_through_the_naive_loop() {
    for (name, scene) in scenes().into_iter().filter(|(n, _)| ["spheres.toml", "cornell.toml", "dof.toml"].contains(n))
    {
        let accel = NaiveAccel::new(&scene.geometry);
        assert_loops_agree(name, &scene, &accel, &small(9));
    }
}

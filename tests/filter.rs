//! The pixel filter: box images are pinned bit for bit (a box film position is exactly x + u);
//! the Gaussian spreads an edge over the pixels near it as its distribution says, and its
//! images are as deterministic as the box's.

mod common;

use ember::film::{Film, PixelFilter};
use ember::hash::Fnv1a;
use ember::integrator::{RenderSettings, RrDepth};
use ember::sampler::SamplerKind;
use ember::scene::Scene;
use ember::settings::LightVertices;
use glam::Vec2;
use std::path::Path;

fn pixel_hash(film: &Film) -> u64 {
    let mut h = Fnv1a::default();
    for p in &film.pixels {
        for c in p.to_array() {
            h.write(&c.to_bits().to_le_bytes());
        }
    }
    h.finish()
}

/// Images of the sample scenes (40 × 30, 8 spp, each scene's own `[render]` otherwise) with
/// the default settings, whose filter is the box, and independent samples, through the naive
/// loop (whose bits do not depend on the CPU, unlike Embree's). A box render draws its film
/// positions as `x + u` exactly. (The Sobol sampler's first two numbers of a sample are the
/// same whether drawn as one pair or one by one.) Light vertices, which the Cornell box's lamp
/// turns on, are off here: they change the image's noise, not the filter. Roulette starts
/// where the automatic start put it when the images were pinned (3 for the teapot).
#[test]
fn box_renders_are_bit_identical_to_before_filters() {
    let recorded = [
        ("cornell.toml", RrDepth::Off, 0xffa5_cb84_b812_949eu64),
        ("dof.toml", RrDepth::Off, 0xeeb6_0d07_87e9_40dd),
        ("spheres.toml", RrDepth::Off, 0x347a_fc49_b180_3620),
        ("teapot.toml", RrDepth::After(3), 0x42f5_adf2_4c85_cd9f),
        ("teapot.obj", RrDepth::After(3), 0x3d6f_f1da_03d8_da6d),
    ];
    for (name, rr_depth, hash) in recorded {
        let scene = Scene::load(&common::scene_path(name)).unwrap();
        let settings = RenderSettings {
            width: 40,
            height: 30,
            spp: 8,
            sampler: SamplerKind::Independent,
            light_vertices: LightVertices::Off,
            rr_depth,
            // Pinned before the caustics' light paths.
            caustics: ember::settings::Caustics::Off,
            ..RenderSettings::from_scene(&scene.render)
        };
        assert_eq!(settings.filter, PixelFilter::Box);
        let (film, _) = common::render_naive(&scene, &settings);
        assert_eq!(pixel_hash(&film), hash, "{name}: the box render changed");
    }
}

/// A white sky with a black wall over the right half of the view, its edge on the boundary
/// between columns 3 and 4 of an 8 × 2 image (a pinhole maps film x linearly onto a plane
/// facing it).
fn edge_scene() -> Scene {
    let toml = r#"
[camera]
position = [0.0, 0.0, 0.0]
look_at = [0.0, 0.0, -1.0]
fov = 90.0
[background]
type = "constant"
color = [1.0, 1.0, 1.0]
[materials.black]
type = "diffuse"
color = [0.0, 0.0, 0.0]
[[quads]]
corner = [0.0, -100.0, -1.0]
edge1 = [100.0, 0.0, 0.0]
edge2 = [0.0, 200.0, 0.0]
material = "black"
"#;
    Scene::from_toml_str(toml, Path::new("edge.toml")).unwrap()
}

#[test]
fn the_gaussian_spreads_an_edge_as_its_distribution_says() {
    let scene = edge_scene();
    let (w, h, spp) = (8, 2, 4096);
    let render = |filter| {
        let settings = RenderSettings { width: w, height: h, spp, filter, ..RenderSettings::default() };
        common::render_embree(&scene, &settings).0
    };
    // A pixel whose centre is d pixels left of the edge sees the sky with the probability that
    // its offset is below d: for the box, 1 for d ≥ 0.5 and 0 for d ≤ -0.5; for the Gaussian
    // (σ 0.5, truncated at 1.5), ½ + ½ erf(d / (σ√2)) / erf(3/√2): at d = 0.5, ½ + ½ · 0.682689
    // / 0.997300 = 0.842269; 1 and 0 from |d| = 1.5 on.
    let gaussian = [1.0, 1.0, 1.0, 0.842_269, 1.0 - 0.842_269, 0.0, 0.0, 0.0];
    let boxed = [1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0];
    for (filter, expected) in [(PixelFilter::Box, boxed), (PixelFilter::Gaussian, gaussian)] {
        let film = render(filter);
        for y in 0..h {
            for (x, &want) in expected.iter().enumerate() {
                let v = film.get(x as u32, y).x as f64;
                // A fraction of 4096 samples: standard error at most 0.0078; 4 of them.
                assert!((v - want).abs() < 0.032, "{filter}: pixel ({x}, {y}) is {v}, expected {want}");
                // Far from the edge nothing can reach it (the Gaussian's radius is 1.5 pixels).
                let far = filter == PixelFilter::Box || !(2..6).contains(&x);
                if far {
                    assert_eq!(v, want, "{filter}: pixel ({x}, {y}) beyond the filter's reach");
                }
            }
        }
    }
}

#[test]
fn gaussian_images_do_not_depend_on_the_thread_count() {
    let scene = Scene::load(&common::scene_path("cornell.toml")).unwrap();
    let settings = |threads| RenderSettings {
        width: 24,
        height: 24,
        spp: 8,
        threads: Some(threads),
        filter: PixelFilter::Gaussian,
        ..RenderSettings::from_scene(&scene.render)
    };
    let (one, _) = common::render_embree(&scene, &settings(1));
    let (two, _) = common::render_embree(&scene, &settings(2));
    assert_eq!(one, two);
    let (boxed, _) = common::render_embree(&scene, &RenderSettings { filter: PixelFilter::Box, ..settings(2) });
    assert_ne!(one, boxed);
    // The same light, differently placed: the image means agree within their noise.
    let (a, b) = (one.mean(), boxed.mean());
    assert!((a - b).abs().max_element() < 0.05 * b.max_element(), "{a} vs {b}");
}

/// A box render's film position is the first pair of numbers of a sample, drawn with
/// `next_2d`; before filters it was drawn as two `next_f32`. Both samplers give the same two
/// numbers either way, so box images are those of the code before filters with either one.
#[test]
fn a_first_pair_is_the_first_two_numbers_with_either_sampler() {
    use ember::sampler::PixelSampler;
    for kind in [SamplerKind::Independent, SamplerKind::Sobol] {
        for (seed, pixel, sample) in [(0, 0, 0), (7, 1234, 5), (u64::MAX, 99, 1 << 20)] {
            let pixel_sampler = PixelSampler::new(kind, seed, pixel);
            let stream = pixel_sampler.sample(sample);
            let (mut a, mut b) = (stream.clone(), stream);
            let pair = a.next_2d();
            let (x, y) = (b.next_f32(), b.next_f32());
            assert_eq!((pair.x.to_bits(), pair.y.to_bits()), (x.to_bits(), y.to_bits()), "{kind:?}");
            // And the streams go on alike.
            assert_eq!(a.next_2d(), Vec2::new(b.next_f32(), b.next_f32()), "{kind:?}");
        }
    }
}

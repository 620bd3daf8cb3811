//! The light tree (`--light-tree`, `src/light/tree.rs`): with many lights, next-event
//! estimation chooses one by its importance at the shading point. It must leave the image
//! unbiased (against a closed form) and lower its noise where lights are many and spread out,
//! and the set must say how it chooses.

mod common;

use ember::integrator::RenderSettings;
use ember::scene::Scene;
use ember::settings::LightTreeMode;
use glam::Vec3;

const LAMPS: usize = 24;
const RADIUS: f32 = 0.08;
const ALBEDO: f32 = 0.5;
/// The floor seen: x and z in [-HALF, HALF].
const HALF: f32 = 4.0;
const SIDE: u32 = 40;

/// 24 small emitting spheres of different colours and strengths, 1.5 units over a grey floor
/// on a jittered 6 × 4 grid (by a fixed sequence): at one height and at least 1.1 apart, no
/// lamp hides another from any point of the floor seen.
fn lamps() -> Vec<(Vec3, Vec3)> {
    let mut s = 12345u64;
    let mut next = || {
        s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (s >> 40) as f32 / (1u64 << 24) as f32
    };
    (0..LAMPS)
        .map(|i| {
            let (gx, gz) = ((i % 6) as f32, (i / 6) as f32);
            let c = Vec3::new(-3.75 + 1.5 * gx + 0.4 * next() - 0.2, 1.5, -2.25 + 1.5 * gz + 0.4 * next() - 0.2);
            let e = Vec3::new(0.5 + 4.0 * next(), 0.5 + 4.0 * next(), 0.5 + 4.0 * next()) * (1.0 + 9.0 * next());
            (c, e)
        })
        .collect()
}

/// The floor lit directly by the lamps, seen from above by an orthographic camera between
/// them and the floor (so the lamps are not in view).
fn scene(name: &str) -> Scene {
    let mut text = format!(
        "[camera]\ntype = \"orthographic\"\nposition = [0, 0.5, 0]\nlook_at = [0, 0, 0]\nup = [0, 0, -1]\nwidth = {}\n\n\
         [materials.floor]\ntype = \"diffuse\"\ncolor = [{ALBEDO}, {ALBEDO}, {ALBEDO}]\n\n\
         [[quads]]\ncorner = [-{HALF}, 0, -{HALF}]\nedge1 = [0, 0, {}]\nedge2 = [{}, 0, 0]\nmaterial = \"floor\"\n",
        2.0 * HALF,
        2.0 * HALF,
        2.0 * HALF
    );
    for (i, (c, e)) in lamps().iter().enumerate() {
        text += &format!(
            "\n[materials.lamp{i}]\ntype = \"emissive\"\nemission = [{}, {}, {}]\n\n[[spheres]]\ncenter = [{}, {}, {}]\nradius = {RADIUS}\nmaterial = \"lamp{i}\"\n",
            e.x, e.y, e.z, c.x, c.y, c.z
        );
    }
    Scene::load(&common::write_scene("light-tree", &format!("{name}.toml"), &text)).unwrap_or_else(|e| panic!("{e}"))
}

/// The floor's radiance at (x, 0, z): each lamp, a sphere of radiance L wholly above the
/// floor's horizon, gives irradiance π L sin²α cos θ (α the half-angle it subtends, θ its
/// angle from the normal), and a Lambertian floor of albedo ρ reflects ρ/π of it.
fn closed_form(x: f32, z: f32) -> Vec3 {
    let p = Vec3::new(x, 0.0, z);
    lamps()
        .iter()
        .map(|(c, e)| {
            let d2 = (*c - p).length_squared();
            let cos = c.y / d2.sqrt();
            *e * (ALBEDO * RADIUS * RADIUS / d2 * cos)
        })
        .sum()
}

/// Each pixel's radiance against the closed form over it: (the image mean's ratio to
/// the closed form's, the root mean square of the pixels' relative errors).
fn errors(mode: LightTreeMode, spp: u32, seed: u64) -> (f64, f64) {
    let scene = scene(&format!("lamps-{mode}"));
    let settings = RenderSettings {
        width: SIDE,
        height: SIDE,
        spp,
        seed,
        max_depth: 1,
        adaptive: false,
        light_tree: mode,
        ..RenderSettings::default()
    };
    let (film, stats) = common::render_embree(&scene, &settings);
    assert_eq!(stats.nonfinite, 0);
    let px = 2.0 * HALF / SIDE as f32;
    let (mut sum, mut sum_ref, mut sq) = (0.0f64, 0.0f64, 0.0f64);
    for y in 0..SIDE {
        for x in 0..SIDE {
            // The pixel's mean radiance (a box filter), by the midpoint rule on 4 × 4 points.
            let want = (0..16)
                .map(|k| {
                    let (u, v) = ((k % 4) as f32 + 0.5, (k / 4) as f32 + 0.5);
                    closed_form(-HALF + (x as f32 + u / 4.0) * px, -HALF + (y as f32 + v / 4.0) * px)
                })
                .sum::<Vec3>()
                / 16.0;
            let got = film.get(x, y);
            sum += got.element_sum() as f64;
            sum_ref += want.element_sum() as f64;
            sq += ((got.element_sum() / want.element_sum() - 1.0) as f64).powi(2);
        }
    }
    (sum / sum_ref, (sq / (SIDE * SIDE) as f64).sqrt())
}

#[test]
fn many_lights_through_the_tree_match_the_closed_form_with_less_noise() {
    // Tolerances at 256 spp, 1,600 pixels: the image mean within 0.2% of the closed form for
    // both choices (measured 0.013% through the tree, 0.034% by power). The pixels' RMS
    // relative error through the tree below 0.6× that by power (measured 0.0067 against
    // 0.0151: 0.44×).
    let (mean_tree, rms_tree) = errors(LightTreeMode::Auto, 256, 1);
    let (mean_power, rms_power) = errors(LightTreeMode::Off, 256, 1);
    println!("tree: mean {mean_tree:.5}, rms {rms_tree:.4}; by power: mean {mean_power:.5}, rms {rms_power:.4}");
    assert!((mean_tree - 1.0).abs() < 0.002, "tree: image mean {mean_tree} of the closed form's");
    assert!((mean_power - 1.0).abs() < 0.002, "by power: image mean {mean_power} of the closed form's");
    assert!(rms_tree < 0.6 * rms_power, "tree rms {rms_tree} vs by power {rms_power}");
}

#[test]
fn the_set_says_how_it_chooses() {
    let scene = scene("set");
    let tree = scene.light_set(LightTreeMode::Auto).describe();
    let power = scene.light_set(LightTreeMode::Off).describe();
    assert!(tree.starts_with("24 lights in 24 groups: chosen by importance") && tree.contains("light tree"), "{tree}");
    assert_eq!(power, "24 lights in 24 groups: chosen by power (more than 8 groups)");
    // A few groups keep the choice among groups: the teapot's quad light and sky.
    let teapot = Scene::load(&common::scene_path("teapot.toml")).unwrap();
    let few = teapot.light_set(LightTreeMode::Auto).describe();
    assert!(few.contains("a group chosen by importance") && !few.contains("tree"), "{few}");
}

//! Light vertices (`--light-vertices`, `integrator::light_vertex`): paths connect to surface
//! points sampled from point lights, weighed by MIS against next-event estimation. They must
//! leave every image the same in expectation: against a closed form inside a sphere, and
//! against renders without them where there is no closed form (the Cornell box; a room of
//! glossy, mirror and glass spheres). And the scene analysis turns them on only for lamps
//! inside the scene. Light vertices from area lights (`LightVertexPool::from_surfaces`) must
//! keep a room lit through a window the same in expectation and lower its noise, and run only
//! where the pass before the render finds the scene enclosed.

mod common;

use common::image_mean;
use ember::film::Film;
use ember::integrator::RenderSettings;
use ember::scene::Scene;
use ember::settings::{LightVertices, SamplerKind};
use glam::Vec3;

fn scene_from(name: &str, text: &str) -> Scene {
    Scene::load(&common::write_scene("light-vertices", name, text)).unwrap_or_else(|e| panic!("{e}"))
}

/// The renders of `settings` with seeds 0..seeds (each checked to have no non-finite sample),
/// and whether their plan connects paths to light vertices.
fn renders(scene: &Scene, settings: &RenderSettings, seeds: u64) -> (Vec<Film>, bool) {
    let mut light_vertices = false;
    let films = (0..seeds)
        .map(|seed| {
            let (film, stats) = common::render_embree(scene, &RenderSettings { seed, ..settings.clone() });
            assert_eq!(stats.nonfinite, 0, "non-finite samples");
            light_vertices = stats.plan.light_vertices;
            film
        })
        .collect();
    (films, light_vertices)
}

/// Per-pixel mean and variance over `seeds` renders of `settings` with seeds 0..seeds.
fn seed_stats(scene: &Scene, settings: &RenderSettings, seeds: u64) -> (Vec<Vec3>, Vec<Vec3>, bool) {
    let (films, light_vertices) = renders(scene, settings, seeds);
    let n = films[0].pixels.len();
    let mean: Vec<Vec3> = (0..n).map(|i| films.iter().map(|f| f.pixels[i]).sum::<Vec3>() / seeds as f32).collect();
    let var: Vec<Vec3> = (0..n)
        .map(|i| films.iter().map(|f| (f.pixels[i] - mean[i]).powf(2.0)).sum::<Vec3>() / (seeds - 1) as f32)
        .collect();
    (mean, var, light_vertices)
}

/// The image mean over `seeds` renders and its standard error, from per-seed image means.
fn mean_and_error(scene: &Scene, settings: &RenderSettings, seeds: u64) -> (f64, f64, bool) {
    let (films, light_vertices) = renders(scene, settings, seeds);
    let means: Vec<f64> = films.iter().map(|f| image_mean(&f.pixels)).collect();
    let m = means.iter().sum::<f64>() / seeds as f64;
    let var = means.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (seeds - 1) as f64;
    (m, (var / seeds as f64).sqrt(), light_vertices)
}

#[test]
fn a_lamp_inside_a_white_sphere_matches_the_closed_form() {
    // Inside a sphere of radius R every surface element sees every other with the same form
    // factor dA / 4πR², so whatever leaves the walls after one bounce lights them uniformly:
    // the first bounce gives E₁(x) = I cos θ / |x − p|² from the lamp at p, every later one
    // ρ^(k−1) I / R² (the lamp's whole power 4πI, reflected k−1 times, over the area). At path
    // depth D the wall's radiance is L(x) = ρ/π (E₁(x) + I/R² Σ_{j=1}^{D−1} ρ^j). The lamp is
    // off-centre, so E₁ varies several-fold over the view and light vertices carry much of it.
    // Tolerances at 1024 spp: the image mean within 0.2% (measured 0.02% with light vertices,
    // 0.01% without), each pixel within 4% (measured worst 1.6% and 2.0%: the noise).
    lamp_in_a_sphere("off-centre", Vec3::new(0.6, 0.5, -0.7), &[LightVertices::Auto, LightVertices::Off], 0.002);
}

#[test]
fn a_lamp_against_the_wall_of_a_sphere_matches_the_closed_form() {
    // The same sphere with the lamp 1e-4 below its top: the wall beside it gets ~10⁸ times the
    // irradiance of the rest, and light bounced from that spot is most of every pixel. BSDF
    // sampling alone almost never lands there: its image mean converges from below, by rare
    // huge samples (0.62× the closed form at 64 spp, 0.71× at 1024). Light vertices land there
    // as the lamp's light does: the image mean within 0.5% (measured 0.05%) and each pixel
    // within 4% (measured worst 2.4%) at 1024 spp.
    lamp_in_a_sphere("against-the-wall", Vec3::new(0.0, 1.9999, -0.0001), &[LightVertices::Auto], 0.005);
}

/// Renders a white sphere (radius 2, albedo 0.6, depth 6) with a lamp at `lamp`, seen from its
/// centre, with each of `modes` (the scene file is named after `name`), against the closed form: the image mean within `mean_tol`
/// (relative), each pixel within 4%.
fn lamp_in_a_sphere(name: &str, lamp: Vec3, modes: &[LightVertices], mean_tol: f64) {
    let (rho, intensity, radius, depth) = (0.6f32, 3.0f32, 2.0f32, 6u32);
    let scene = scene_from(
        &format!("sphere-room-{name}.toml"),
        &format!(
            r#"
            [camera]
            position = [0.0, 0.0, 0.0]
            look_at = [0.0, 0.0, -1.0]
            up = [0.0, 1.0, 0.0]
            fov = 70
            [materials.wall]
            type = "diffuse"
            color = [{rho}, {rho}, {rho}]
            [[spheres]]
            center = [0.0, 0.0, 0.0]
            radius = {radius}
            material = "wall"
            [[lights]]
            type = "point"
            position = [{}, {}, {}]
            intensity = [{intensity}, {intensity}, {intensity}]
            "#,
            lamp.x, lamp.y, lamp.z
        ),
    );
    let (w, h) = (16u32, 16u32);
    let cam = scene.camera(1.0);
    let indirect: f32 = (1..depth).map(|j| rho.powi(j as i32)).sum::<f32>() * intensity / (radius * radius);
    let expected: Vec<f32> = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| {
            let mut sum = 0.0f64;
            for j in 0..8 {
                for i in 0..8 {
                    let film = glam::Vec2::new(
                        (x as f32 + (i as f32 + 0.5) / 8.0) / w as f32,
                        (y as f32 + (j as f32 + 0.5) / 8.0) / h as f32,
                    );
                    let d = cam.ray(film, glam::Vec2::ZERO).d.normalize();
                    let q = d * radius;
                    let to_lamp = lamp - q;
                    let cos = (-q / radius).dot(to_lamp.normalize());
                    let e1 = intensity * cos / to_lamp.length_squared();
                    sum += (rho / std::f32::consts::PI * (e1 + indirect)) as f64;
                }
            }
            (sum / 64.0) as f32
        })
        .collect();
    for &lv in modes {
        let s = RenderSettings {
            width: w,
            height: h,
            spp: 1024,
            max_depth: depth,
            light_vertices: lv,
            ..Default::default()
        };
        let (film, stats) = common::render_embree(&scene, &s);
        assert_eq!(stats.plan.light_vertices, lv == LightVertices::Auto, "{lv}: the lamp is inside the scene");
        let worst = film.pixels.iter().zip(&expected).map(|(p, e)| ((p.x - e) / e).abs()).fold(0.0f32, f32::max);
        let (got, want) =
            (image_mean(&film.pixels), expected.iter().map(|&e| e as f64).sum::<f64>() / expected.len() as f64);
        println!("lamp at {lamp}, light vertices {lv}: image mean {got:.5} against {want:.5}, worst pixel {worst:.4}");
        assert!(((got - want) / want).abs() < mean_tol, "{lv}: image mean {got} against the closed form {want}");
        assert!(worst < 0.04, "{lv}: worst pixel off by {worst}");
    }
}

#[test]
fn the_cornell_box_keeps_its_mean_and_loses_noise() {
    // Embree's Cornell box: its lamp hangs beside the tall block. 8 seeds each way, 24×24 at
    // 16 spp: the image means agree within 3 combined standard errors, and the per-pixel
    // variance over seeds falls (measured: 0.61× at 128×128; here the sum over pixels of
    // variance / (mean² + 0.01), the relMSE's measure, is asserted below 0.8×).
    let scene = Scene::load(&common::scene_path("cornell.toml")).unwrap();
    let s = RenderSettings { width: 24, height: 24, spp: 16, max_depth: 8, ..Default::default() };
    let (m_on, v_on, lv_on) = seed_stats(&scene, &s, 8);
    let (m_off, v_off, lv_off) =
        seed_stats(&scene, &RenderSettings { light_vertices: LightVertices::Off, ..s.clone() }, 8);
    assert!(lv_on && !lv_off, "auto turns light vertices on for the Cornell box");
    let rel = |m: &[Vec3], v: &[Vec3]| {
        m.iter().zip(v).map(|(m, v)| (*v / (*m * *m + Vec3::splat(0.01))).element_sum() as f64 / 3.0).sum::<f64>()
    };
    let (r_on, r_off) = (rel(&m_on, &v_on), rel(&m_off, &v_off));
    let se = |v: &[Vec3]| (v.iter().map(|v| v.element_sum() as f64 / 3.0).sum::<f64>() / 8.0).sqrt() / v.len() as f64;
    let (a, b) = (image_mean(&m_on), image_mean(&m_off));
    let tol = 3.0 * (se(&v_on).powi(2) + se(&v_off).powi(2)).sqrt();
    println!("mean {a:.5} (on) against {b:.5} (off), tolerance {tol:.5}; variance ratio {:.3}", r_on / r_off);
    assert!((a - b).abs() < tol, "light vertices move the mean: {a} against {b} (3 SE {tol})");
    assert!(r_on < 0.8 * r_off, "light vertices should lower the noise: {r_on} against {r_off}");
}

#[test]
fn glossy_mirror_and_glass_surfaces_keep_their_mean() {
    // A room (a white sphere) with a lamp and four balls: plastic, rough metal, a mirror and
    // glass. Mirror and glass vertices do not connect, rough ones connect through their BSDF;
    // the image means with and without light vertices agree within 3 combined standard errors
    // (8 seeds, independent samples so that the spread is honest).
    let scene = scene_from(
        "glossy-room.toml",
        r#"
        [camera]
        position = [0.0, 0.0, 3.5]
        look_at = [0.0, 0.0, 0.0]
        up = [0.0, 1.0, 0.0]
        fov = 60
        [materials.wall]
        type = "diffuse"
        color = [0.7, 0.7, 0.6]
        [materials.plastic]
        type = "plastic"
        color = [0.8, 0.2, 0.1]
        roughness = 0.2
        [materials.metal]
        type = "metal"
        color = [0.9, 0.8, 0.5]
        roughness = 0.3
        [materials.mirror]
        type = "metal"
        color = [0.95, 0.95, 0.95]
        roughness = 0.0
        [materials.glass]
        type = "glass"
        ior = 1.5
        [[spheres]]
        center = [0.0, 0.0, 0.0]
        radius = 5.0
        material = "wall"
        [[spheres]]
        center = [-1.2, -0.8, 0.0]
        radius = 0.7
        material = "plastic"
        [[spheres]]
        center = [1.2, -0.8, 0.0]
        radius = 0.7
        material = "metal"
        [[spheres]]
        center = [-1.0, 1.0, -0.5]
        radius = 0.6
        material = "mirror"
        [[spheres]]
        center = [1.0, 1.0, -0.5]
        radius = 0.6
        material = "glass"
        [[lights]]
        type = "point"
        position = [0.0, 2.5, 1.0]
        intensity = [20.0, 20.0, 20.0]
        "#,
    );
    let s = RenderSettings {
        width: 24,
        height: 24,
        spp: 16,
        max_depth: 6,
        sampler: SamplerKind::Independent,
        ..Default::default()
    };
    let (a, se_a, lv_a) = mean_and_error(&scene, &s, 8);
    let (b, se_b, lv_b) = mean_and_error(&scene, &RenderSettings { light_vertices: LightVertices::Off, ..s }, 8);
    assert!(lv_a && !lv_b);
    let tol = 3.0 * (se_a * se_a + se_b * se_b).sqrt();
    println!("mean {a:.5} ± {se_a:.5} (on) against {b:.5} ± {se_b:.5} (off)");
    assert!((a - b).abs() < tol, "light vertices move the mean: {a} against {b} (3 SE {tol})");
}

#[test]
fn only_lamps_inside_the_scene_turn_light_vertices_on() {
    let lamp_at = |y: f32| {
        format!(
            r#"
            [camera]
            position = [0.0, 1.0, 6.0]
            look_at = [0.0, 0.0, 0.0]
            [materials.m]
            type = "diffuse"
            color = [0.8, 0.8, 0.8]
            [[quads]]
            corner = [-3.0, 0.0, -3.0]
            edge1 = [0.0, 0.0, 6.0]
            edge2 = [6.0, 0.0, 0.0]
            material = "m"
            [[spheres]]
            center = [0.0, 1.0, 0.0]
            radius = 1.0
            material = "m"
            [[lights]]
            type = "point"
            position = [0.5, {y}, 0.5]
            intensity = [10.0, 10.0, 10.0]
            "#
        )
    };
    let plan = |text: &str, lv: LightVertices| {
        let scene = scene_from("lamp.toml", text);
        ember::integrator::RenderPlan::new(&scene, &RenderSettings { light_vertices: lv, ..Default::default() })
    };
    // Above everything: a lamp over a table, whose light mostly leaves the scene.
    let above = plan(&lamp_at(5.0), LightVertices::Auto);
    assert!(!above.light_vertices);
    assert!(
        above.to_string().ends_with("light vertices: off (a point light is outside the scene's surfaces)"),
        "{above}"
    );
    // Within the bounds of the surfaces: on.
    let inside = plan(&lamp_at(1.5), LightVertices::Auto);
    assert!(inside.light_vertices);
    assert!(inside.to_string().ends_with("light vertices: on (every light is a point light inside the scene)"));
    // Asked for: on wherever every light is a point light; off when asked.
    assert!(plan(&lamp_at(5.0), LightVertices::On).light_vertices);
    assert!(!plan(&lamp_at(1.5), LightVertices::Off).light_vertices);
    // Not with an area light, a sky, or an estimator other than NEE+MIS.
    let sky = lamp_at(1.5) + "\n[background]\ntype = \"constant\"\ncolor = [0.2, 0.2, 0.2]\n";
    let with_sky = plan(&sky, LightVertices::On);
    assert!(!with_sky.light_vertices);
    assert!(
        with_sky.to_string().ends_with("light vertices: off (not every light is a point light or an area light)"),
        "{with_sky}"
    );
    let scene = scene_from("lamp-bsdf.toml", &lamp_at(1.5));
    let bsdf_only = RenderSettings { estimator: ember::settings::Estimator::BsdfOnly, ..Default::default() };
    assert!(!ember::integrator::RenderPlan::new(&scene, &bsdf_only).light_vertices);
    // A scene file may set it under [render]; a value other than auto, on or off is refused,
    // naming the file.
    let off = scene_from("lamp-off.toml", &("[render]\nlight_vertices = \"off\"\n".to_string() + &lamp_at(1.5)));
    let settings = RenderSettings::from_scene(&off.render);
    assert_eq!(settings.light_vertices, LightVertices::Off);
    assert!(!ember::integrator::RenderPlan::new(&off, &settings).light_vertices);
    let path = common::write_scene(
        "light-vertices",
        "lamp-bad.toml",
        &("[render]\nlight_vertices = \"sometimes\"\n".to_string() + &lamp_at(1.5)),
    );
    let e = Scene::load(&path).unwrap_err().to_string();
    assert!(e.contains("lamp-bad.toml") && e.contains("\"auto\", \"on\" or \"off\""), "{e}");
}

#[test]
fn the_render_says_what_it_decided() {
    let out = common::fresh_dir("light-vertices", "cli").join("c.exr");
    let line = |extra: &[&str]| {
        let scene = common::scene_path("cornell.toml");
        let args = ["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--width", "8", "--height", "6"];
        let o = common::ember(&[&args[..], &["--spp", "1"], extra].concat());
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        assert!(o.status.success(), "{err}");
        err.lines().find(|l| l.starts_with("light vertices:")).unwrap_or_else(|| panic!("no line in {err}")).to_string()
    };
    assert_eq!(line(&[]), "light vertices: on (every light is a point light inside the scene)");
    assert_eq!(line(&["--light-vertices", "off"]), "light vertices: off (--light-vertices off)");
    let o = common::ember(&["render", "x.toml", "-o", "y.exr", "--light-vertices", "maybe"]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("\"auto\", \"on\" or \"off\""));
}

/// The window-lit room's settings with `light_vertices`.
fn room_settings(spp: u32, seed: u64, light_vertices: LightVertices) -> RenderSettings {
    RenderSettings { light_vertices, ..common::window_room_settings(spp, seed) }
}

/// The image of a render of the window-lit room, checked to have connected to light vertices
/// from its area light (or not).
fn room_render(scene: &Scene, settings: &RenderSettings, connected: bool) -> Film {
    let (film, stats) = common::render_embree(scene, settings);
    assert_eq!(stats.nonfinite, 0);
    let pool = stats.surface_light_vertices.and_then(|v| v.pool);
    assert_eq!(pool.is_some(), connected, "{:?}\n{}", stats.surface_light_vertices, stats.plan);
    film
}

#[test]
fn vertices_from_a_sun_through_a_window_keep_the_image_and_lower_its_noise() {
    // The sun's light lands on the floor under the window; almost all of it lands outside the
    // room, where the pool keeps none. 4 seeds at 64 spp against a 4096-spp render without
    // light vertices. Measured: relMSE 0.27 of the render's without them.
    let scene = common::window_room("light-vertices");
    let reference = room_render(&scene, &room_settings(4096, 99, LightVertices::Off), false);
    let reference_mean = image_mean(&reference.pixels);
    let (mut with, mut without) = (0.0, 0.0);
    for seed in 1..=4 {
        // Most of the pass's bounces stay in the room: on by default.
        let film = room_render(&scene, &room_settings(64, seed, LightVertices::Auto), true);
        let m = image_mean(&film.pixels);
        assert!((m / reference_mean - 1.0).abs() < 0.02, "seed {seed}: mean {m} against {reference_mean}");
        with += common::rel_mse(&film, &reference);
        without +=
            common::rel_mse(&room_render(&scene, &room_settings(64, seed, LightVertices::Off), false), &reference);
    }
    println!("relMSE with light vertices {with:.5}, without {without:.5}: {:.2}×", with / without);
    assert!(with < 0.6 * without, "relMSE with light vertices {with}, without {without}");
}

#[test]
fn vertices_from_area_lights_give_one_image_for_any_thread_count() {
    let scene = common::window_room("light-vertices");
    let bits = |f: &Film| f.pixels.iter().flat_map(|p| p.to_array().map(f32::to_bits)).collect::<Vec<_>>();
    let s = |threads| RenderSettings { threads: Some(threads), ..room_settings(8, 0, LightVertices::Auto) };
    let one = room_render(&scene, &s(1), true);
    for threads in [2, 3] {
        assert_eq!(bits(&one), bits(&room_render(&scene, &s(threads), true)), "{threads} threads");
    }
}

#[test]
fn an_open_scene_renders_without_vertices_from_its_area_light() {
    // teapot.toml (an area light and a sky over a floor): most of the pass's bounces leave the
    // scene, so the image is the one without light vertices, bit for bit; asked for, they run.
    let scene = Scene::load(&common::scene_path("teapot.toml")).unwrap();
    let s = |lv| RenderSettings { width: 40, height: 30, spp: 4, light_vertices: lv, ..RenderSettings::default() };
    let (auto, stats) = common::render_embree(&scene, &s(LightVertices::Auto));
    let v = stats.surface_light_vertices.expect("the pass decides");
    assert!(v.pool.is_none() && v.escaped > 0.5, "{v:?}");
    let (off, stats) = common::render_embree(&scene, &s(LightVertices::Off));
    assert_eq!(stats.surface_light_vertices, None);
    assert_eq!(auto.pixels, off.pixels);
    let (_, stats) = common::render_embree(&scene, &s(LightVertices::On));
    assert!(stats.surface_light_vertices.and_then(|v| v.pool).is_some());
}

#[test]
fn a_pass_run_only_to_decide_stops_after_its_first_chunk_in_an_open_scene() {
    // A floor filling the view under one small lamp and no sky: one group of lights, so the
    // pass weighs nothing and runs only to decide light vertices. Its paths hit the floor and
    // bounce (2 rays or more each), mostly out of the scene: the first chunk of 4,096 paths
    // (at most 4 rays each) decides, and the rest of the pass (3 chunks or more) is not traced.
    let text = "[camera]\nposition = [0.0, 2.0, 0.0]\nlook_at = [0.0, 0.0, 0.01]\nfov = 40\n\
        [materials.floor]\ntype = \"diffuse\"\ncolor = [0.5, 0.5, 0.5]\n\
        [materials.lamp]\ntype = \"emissive\"\nemission = [20.0, 20.0, 20.0]\n\
        [[quads]]\ncorner = [-50.0, 0.0, -50.0]\nedge1 = [0.0, 0.0, 100.0]\nedge2 = [100.0, 0.0, 0.0]\nmaterial = \"floor\"\n\
        [[quads]]\ncorner = [-0.2, 1.0, -0.2]\nedge1 = [0.4, 0.0, 0.0]\nedge2 = [0.0, 0.0, 0.4]\nmaterial = \"lamp\"\n";
    let scene = Scene::load(&common::write_scene("light-vertices", "open-floor.toml", text)).unwrap();
    let s = |lv| RenderSettings { width: 32, height: 32, spp: 4, light_vertices: lv, ..RenderSettings::default() };
    let (auto, auto_stats) = common::render_embree(&scene, &s(LightVertices::Auto));
    let (off, off_stats) = common::render_embree(&scene, &s(LightVertices::Off));
    let v = auto_stats.surface_light_vertices.expect("the pass decides");
    assert!(v.pool.is_none() && v.escaped > 0.5, "{v:?}");
    assert_eq!(auto.pixels, off.pixels);
    let pass = auto_stats.rays - off_stats.rays;
    assert!((2 * 4096..=4 * 4096).contains(&pass), "the pass traced {pass} rays");
}

//! Caustic light paths (`--caustics`, `integrator::caustic`): light that reaches a surface the
//! camera sees through mirrors and glass only is carried by paths traced from the lights and
//! splatted onto the film, and paths from the camera leave it to them; where they land, paths
//! from the camera also sample toward the light (`--guiding`, `integrator::guide`). The image
//! must stay the same in expectation (against renders without either), for area and point
//! lights, pinhole and thin-lens cameras and both pixel filters; bit-identical for any thread
//! count; guiding must lower the noise it is for; and the plan says when they run and why not.

mod common;

use ember::film::{Film, PixelFilter};
use ember::integrator::{RenderPlan, RenderSettings};
use ember::scene::Scene;
use ember::settings::{Caustics, Guiding};

/// A floor under a glass ball and a mirror ball, lit from above by `lamp` (TOML of its
/// section), seen by `camera` (the camera section's lines after its position and target).
fn balls(name: &str, lamp: &str, camera: &str) -> Scene {
    let text = format!(
        "[camera]\nposition = [0.0, 3.0, 7.0]\nlook_at = [0.0, 0.5, 0.0]\n{camera}\n\
         [materials.floor]\ntype = \"diffuse\"\ncolor = [0.6, 0.6, 0.6]\n\
         [materials.glass]\ntype = \"glass\"\nior = 1.5\n\
         [materials.mirror]\ntype = \"metal\"\ncolor = [0.95, 0.95, 0.95]\nroughness = 0.0\n\
         [materials.lamp]\ntype = \"emissive\"\nemission = [40.0, 40.0, 40.0]\n\
         [[quads]]\ncorner = [-6.0, 0.0, -6.0]\nedge1 = [0.0, 0.0, 12.0]\nedge2 = [12.0, 0.0, 0.0]\nmaterial = \"floor\"\n\
         [[spheres]]\ncenter = [-1.2, 1.0, 0.0]\nradius = 0.9\nmaterial = \"glass\"\n\
         [[spheres]]\ncenter = [1.3, 0.8, 0.3]\nradius = 0.8\nmaterial = \"mirror\"\n{lamp}"
    );
    Scene::load(&common::write_scene("caustics", name, &text)).unwrap_or_else(|e| panic!("{e}"))
}

const PINHOLE: &str = "fov = 40";

const QUAD_LAMP: &str =
    "[[quads]]\ncorner = [-0.5, 4.0, -1.5]\nedge1 = [1.0, 0.0, 0.0]\nedge2 = [0.0, 0.0, 1.0]\nmaterial = \"lamp\"";

fn settings(spp: u32, caustics: Caustics) -> RenderSettings {
    RenderSettings { width: 64, height: 48, spp, max_depth: 8, adaptive: false, caustics, ..RenderSettings::default() }
}

/// The image of `scene` with `settings`, checked to have traced light paths if `caustics`.
fn render(scene: &Scene, settings: &RenderSettings, caustics: bool) -> Film {
    let (film, stats) = common::render_embree(scene, settings);
    assert_eq!(stats.plan.caustics, caustics, "{}", stats.plan);
    assert_eq!(stats.nonfinite, 0);
    film
}

/// Mean luminance of the `rect` (x0, y0, x1, y1) of `film`.
fn mean(film: &Film, (x0, y0, x1, y1): (u32, u32, u32, u32)) -> f64 {
    let mut sum = 0.0;
    for y in y0..y1 {
        for x in x0..x1 {
            let p = film.get(x, y);
            sum += (0.2126 * p.x + 0.7152 * p.y + 0.0722 * p.z) as f64;
        }
    }
    sum / ((x1 - x0) * (y1 - y0)) as f64
}

/// The caustic the glass ball throws on the floor (measured where the 64 x 48 image shows it).
const GLASS_CAUSTIC: (u32, u32, u32, u32) = (10, 28, 26, 40);

/// Compares two images block by block (16 x 12 pixel blocks) and the caustic's region, within
/// `tolerance` relative (and 0.0005 absolute), naming the first block outside it.
fn assert_same_in_expectation(on: &Film, off: &Film, tolerance: f64, what: &str) {
    for by in 0..4 {
        for bx in 0..4 {
            let rect = (bx * 16, by * 12, bx * 16 + 16, by * 12 + 12);
            let (a, b) = (mean(on, rect), mean(off, rect));
            // Dark blocks (the sky, 0.004) within 0.0005 of luminance.
            assert!((a - b).abs() < tolerance * b + 5e-4, "{what}: block {rect:?}: {a} with light paths, {b} without");
        }
    }
    let (a, b) = (mean(on, GLASS_CAUSTIC), mean(off, GLASS_CAUSTIC));
    println!("{what}: the caustic: {:.4}", a / b - 1.0);
    assert!((a / b - 1.0).abs() < tolerance, "{what}: the caustic: {a} with light paths, {b} without");
}

#[test]
fn light_paths_leave_the_image_the_same_in_expectation() {
    // 4096 spp without light paths against 1024 with them: each block of 192 pixels within 4%
    // or 0.0005 of luminance (measured: the lit blocks within 0.6% for the quad lamp, 1.1% for
    // the ball lamp through a thin lens and the Gaussian filter; the dark blocks of sky over
    // the glass ball's rim 2.7% and 4.7%, 0.0002 of luminance), the caustic's region too.
    // With light paths the renders are guided too.
    let quad = balls("quad.toml", QUAD_LAMP, PINHOLE);
    assert!(RenderPlan::new(&quad, &settings(1024, Caustics::Auto)).guiding);
    let on = render(&quad, &settings(1024, Caustics::Auto), true);
    let off = render(&quad, &settings(4096, Caustics::Off), false);
    assert_same_in_expectation(&on, &off, 0.04, "quad lamp");
    // The caustic is bright: the light paths carry most of that region's light.
    assert!(mean(&on, GLASS_CAUSTIC) > 1.5 * mean(&on, (0, 40, 64, 48)), "no caustic under the glass ball");

    // An emitting ball (emitting outward only, as light paths start from it), a thin lens and
    // the Gaussian filter (a splat spreads over several pixels).
    let ball = balls(
        "ball.toml",
        "[[spheres]]\ncenter = [0.3, 4.0, -0.8]\nradius = 0.6\nmaterial = \"lamp\"",
        "fov = 40\naperture = 0.1\nfocus_distance = 7.0",
    );
    let lens = |spp, caustics| RenderSettings { filter: PixelFilter::Gaussian, ..settings(spp, caustics) };
    let on = render(&ball, &lens(1024, Caustics::Auto), true);
    let off = render(&ball, &lens(4096, Caustics::Off), false);
    assert_same_in_expectation(&on, &off, 0.04, "ball lamp, thin lens, Gaussian filter");
}

#[test]
fn a_point_light_throws_the_caustic_a_small_ball_of_its_intensity_throws() {
    // Paths from the camera never find a point light through glass: without light paths its
    // caustic is missing. With them, it matches that of a ball lamp of radius 0.02 and the same
    // intensity (radiance L, intensity L·πr²) at the same place: within 5% in the caustic's
    // region (measured 1.1%; without light paths the region has 0.28 of that light).
    let point = balls(
        "point.toml",
        "[[lights]]\ntype = \"point\"\nposition = [0.0, 4.0, -1.0]\nintensity = [0.5, 0.5, 0.5]",
        PINHOLE,
    );
    let r: f32 = 0.02;
    let radiance = 0.5 / (std::f32::consts::PI * r * r);
    let ball = balls(
        "small-ball.toml",
        &format!(
            "[materials.bulb]\ntype = \"emissive\"\nemission = [{radiance}, {radiance}, {radiance}]\n\
             [[spheres]]\ncenter = [0.0, 4.0, -1.0]\nradius = {r}\nmaterial = \"bulb\""
        ),
        PINHOLE,
    );
    let with_point = render(&point, &settings(256, Caustics::Auto), true);
    let with_ball = render(&ball, &settings(256, Caustics::Auto), true);
    let without = render(&point, &settings(256, Caustics::Off), false);
    let (a, b, c) = (mean(&with_point, GLASS_CAUSTIC), mean(&with_ball, GLASS_CAUSTIC), mean(&without, GLASS_CAUSTIC));
    println!("the caustic: {a} from the point light, {b} from the ball, {c} without light paths");
    assert!((a / b - 1.0).abs() < 0.05, "the caustic: {a} from the point light, {b} from the ball");
    assert!(a > 2.0 * c, "the caustic: {a} with light paths, {c} without");
}

#[test]
fn guiding_lowers_the_noise_of_the_floor_seen_through_the_glass() {
    // The floor under the glass ball is lit through the ball, and the camera sees it through
    // the ball too: light no light path carries, which a path from the camera finds only when
    // its sample at the floor goes back through the ball to the lamp. Guided, it goes there
    // half the time. 4 seeds at 128 spp against a 4096-spp render, whole image: measured
    // 0.0187 guided against 0.0290 (0.64×; the ball's pixels hold most of the error).
    let scene = balls("guiding.toml", QUAD_LAMP, PINHOLE);
    let with = |spp, seed, guiding| RenderSettings { seed, guiding, ..settings(spp, Caustics::Auto) };
    let (reference, stats) = common::render_embree(&scene, &with(4096, 7, Guiding::Off));
    assert!(stats.plan.caustics && !stats.plan.guiding, "{}", stats.plan);
    let (mut guided, mut unguided) = (0.0, 0.0);
    for seed in 1..=4 {
        let (film, stats) = common::render_embree(&scene, &with(128, seed, Guiding::Auto));
        assert!(stats.plan.guiding && stats.nonfinite == 0, "{}", stats.plan);
        guided += common::rel_mse(&film, &reference);
        unguided += common::rel_mse(&common::render_embree(&scene, &with(128, seed, Guiding::Off)).0, &reference);
    }
    println!("relMSE guided {guided:.5}, unguided {unguided:.5}: {:.2}×", guided / unguided);
    assert!(guided < 0.75 * unguided, "relMSE guided {guided}, unguided {unguided}");
}

#[test]
fn the_light_paths_give_one_image_for_any_thread_count() {
    // Their splats land anywhere and are summed in fixed point: the same bits in any order.
    let scene = balls("threads.toml", QUAD_LAMP, PINHOLE);
    let one = render(&scene, &RenderSettings { threads: Some(1), ..settings(16, Caustics::Auto) }, true);
    for threads in [2, 3] {
        let other = render(&scene, &RenderSettings { threads: Some(threads), ..settings(16, Caustics::Auto) }, true);
        let bits = |f: &Film| f.pixels.iter().flat_map(|p| p.to_array().map(f32::to_bits)).collect::<Vec<_>>();
        assert_eq!(bits(&one), bits(&other), "{threads} threads");
    }
}

#[test]
fn the_plan_says_when_light_paths_run_and_why_not() {
    let line = |scene: &Scene, settings: &RenderSettings| {
        let plan = RenderPlan::new(scene, settings);
        let text = plan.to_string();
        let line = text.lines().find(|l| l.starts_with("caustic light paths:")).map(str::to_string);
        (plan.caustics, line)
    };
    let scene = balls("plan.toml", QUAD_LAMP, PINHOLE);
    let on = line(&scene, &settings(16, Caustics::Auto));
    assert_eq!(on, (true, Some("caustic light paths: on (mirrors or glass, lit by area or point lights)".into())));
    assert!(
        RenderPlan::new(&scene, &settings(16, Caustics::Auto))
            .image_key("accel=naive")
            .contains(" caustics=light-paths")
    );
    let off = line(&scene, &settings(16, Caustics::Off));
    assert_eq!(off, (false, Some("caustic light paths: off (--caustics off)".into())));
    let ortho = balls("ortho.toml", QUAD_LAMP, "type = \"orthographic\"\nwidth = 8.0");
    assert_eq!(
        line(&ortho, &settings(16, Caustics::Auto)).1.as_deref(),
        Some("caustic light paths: off (an orthographic camera)")
    );
    let estimator = RenderSettings { estimator: ember::integrator::Estimator::NeeOnly, ..settings(16, Caustics::Auto) };
    assert_eq!(line(&scene, &estimator).1.as_deref(), Some("caustic light paths: off (only with --estimator nee-mis)"));
    // Guiding, where the light paths run.
    let guiding = |settings: &RenderSettings| {
        let text = RenderPlan::new(&scene, settings).to_string();
        text.lines().find(|l| l.starts_with("caustic guiding:")).map(str::to_string)
    };
    assert_eq!(
        guiding(&settings(16, Caustics::Auto)).as_deref(),
        Some("caustic guiding: on (toward where the light paths landed)")
    );
    let off = RenderSettings { guiding: Guiding::Off, ..settings(16, Caustics::Auto) };
    assert_eq!(guiding(&off).as_deref(), Some("caustic guiding: off (--guiding off)"));
    assert!(!RenderPlan::new(&scene, &off).guiding);
    assert!(!RenderPlan::new(&scene, &off).image_key("accel=naive").contains("guiding"));
    assert!(
        RenderPlan::new(&scene, &settings(16, Caustics::Auto))
            .image_key("accel=naive")
            .contains(" guiding=caustic-cones")
    );
    assert_eq!(guiding(&settings(16, Caustics::Off)), None);
    // Without mirrors or glass there is nothing to say.
    let cornell = Scene::load(&common::scene_path("cornell-area.toml")).unwrap();
    assert_eq!(line(&cornell, &settings(16, Caustics::Auto)), (false, None));
}

#[test]
fn a_stop_while_the_light_paths_are_traced_writes_nothing() {
    // The light paths come before the first pixel; a stop then ends the render with nothing to
    // resume from (the CLI: "interrupted while tracing the caustics' light paths …; nothing was
    // written"), not a checkpoint whose light paths' sums are partial.
    use ember::integrator::{RenderControl, RenderError, render_controlled};
    use std::sync::atomic::AtomicBool;
    let scene = balls("stop.toml", QUAD_LAMP, PINHOLE);
    let accel = ember::accel::NaiveAccel::new(&scene.geometry);
    let stop = AtomicBool::new(true);
    let control = || RenderControl { stop: Some(&stop), ..RenderControl::default() };
    let plan = RenderPlan::new(&scene, &settings(16, Caustics::Auto));
    let r = render_controlled(&scene, &accel, &plan, control());
    assert!(matches!(r, Err(RenderError::StoppedInLightPaths)), "{:?}", r.map(|r| r.complete));
    // Without them the same stop leaves an unfinished render to resume.
    let plan = RenderPlan::new(&scene, &settings(16, Caustics::Off));
    let r = render_controlled(&scene, &accel, &plan, control()).unwrap();
    assert!(!r.complete);
}

#[test]
fn a_caustic_on_a_glossy_surface_stays_with_the_paths_from_the_camera() {
    // A light path's connection on a glossy surface can land in the peak of its lobe (a rough
    // copper ball's firefly held 2/3 of a spheres.toml render's error): light paths connect on
    // diffuse surfaces only. On a floor of rough metal they add nothing (the one diffuse
    // surface, behind the camera, keeps them running), and the image is the one without them,
    // bit for bit (the paths from the camera keep that light).
    use ember::integrator::{RenderControl, render_controlled};
    let text = format!(
        "[camera]\nposition = [0.0, 3.0, 7.0]\nlook_at = [0.0, 0.5, 0.0]\n{PINHOLE}\n\
         [materials.floor]\ntype = \"metal\"\ncolor = [0.9, 0.6, 0.5]\nroughness = 0.3\n\
         [materials.glass]\ntype = \"glass\"\nior = 1.5\n\
         [materials.lamp]\ntype = \"emissive\"\nemission = [40.0, 40.0, 40.0]\n\
         [materials.chalk]\ntype = \"diffuse\"\ncolor = [0.8, 0.8, 0.8]\n\
         [[quads]]\ncorner = [-6.0, 0.0, -6.0]\nedge1 = [0.0, 0.0, 12.0]\nedge2 = [12.0, 0.0, 0.0]\nmaterial = \"floor\"\n\
         [[spheres]]\ncenter = [-1.2, 1.0, 0.0]\nradius = 0.9\nmaterial = \"glass\"\n\
         [[spheres]]\ncenter = [0.0, 3.0, 12.0]\nradius = 1.0\nmaterial = \"chalk\"\n{QUAD_LAMP}"
    );
    let scene = Scene::load(&common::write_scene("caustics", "glossy.toml", &text)).unwrap();
    let accel = ember::accel::NaiveAccel::new(&scene.geometry);
    let run = |caustics| {
        let plan = RenderPlan::new(&scene, &settings(8, caustics));
        render_controlled(&scene, &accel, &plan, RenderControl::default()).unwrap()
    };
    let (on, off) = (run(Caustics::Auto), run(Caustics::Off));
    assert!(on.stats.plan.caustics, "the scene has glass, a lamp and a diffuse surface");
    let bare = text.replace("material = \"chalk\"", "material = \"floor\"");
    let bare = Scene::load(&common::write_scene("caustics", "glossy-only.toml", &bare)).unwrap();
    let plan = RenderPlan::new(&bare, &settings(8, Caustics::Auto)).to_string();
    assert!(plan.ends_with("caustic light paths: off (no diffuse surface to land on)"), "{plan}");
    let light = on.accum.light.as_ref().expect("light paths traced");
    assert!(light.0.iter().flatten().all(|&s| s == 0), "a light path connected on the glossy floor");
    assert_eq!(on.accum.pixels, off.accum.pixels);
}

#[test]
fn the_sample_clamp_bounds_each_splat_as_it_bounds_a_sample() {
    // A light path's splat, over its share of the pixel, is a sample's value: `--clamp X`
    // scales it down to X as it does a camera sample.
    let scene = balls("clamp.toml", QUAD_LAMP, PINHOLE);
    let run = |clamp| common::render_embree(&scene, &RenderSettings { clamp, ..settings(16, Caustics::Auto) });
    let (free, f) = run(None);
    assert_eq!(f.clamped_splats, 0);
    // Above every splat: the same bits, nothing counted.
    let (high, h) = run(Some(1e6));
    let bits = |f: &Film| f.pixels.iter().flat_map(|p| p.to_array().map(f32::to_bits)).collect::<Vec<_>>();
    assert!(bits(&high) == bits(&free), "a clamp above every splat changed the image");
    assert_eq!((h.clamped, h.clamped_splats), (0, 0));
    // Below the caustic's splats: they are counted, and the caustic darkens.
    let (low, l) = run(Some(0.1));
    assert!(l.plan.caustics && l.clamped_splats > 100, "{} splats clamped", l.clamped_splats);
    let (c_free, c_low) = (mean(&free, GLASS_CAUSTIC), mean(&low, GLASS_CAUSTIC));
    assert!(c_low < 0.9 * c_free, "the clamped caustic {c_low} is not darker than {c_free}");
}

#[test]
fn the_light_paths_report_their_progress_before_the_first_pixel() {
    // The progress bar shows "caustic light paths N%" while they are traced: reports with
    // `light_paths`, no pixel work, round 0; then the pixels' rounds.
    use ember::integrator::{Progress, RenderControl, render_controlled};
    use std::sync::Mutex;
    let scene = balls("progress.toml", QUAD_LAMP, PINHOLE);
    let accel = ember::accel::NaiveAccel::new(&scene.geometry);
    // The reports of a one-thread render with `caustics`, in order.
    let reports_of = |caustics| {
        let reports = Mutex::new(Vec::<Progress>::new());
        let report = |p: Progress| reports.lock().unwrap().push(p);
        let control = RenderControl { progress: Some(&report), ..RenderControl::default() };
        let plan = RenderPlan::new(&scene, &RenderSettings { threads: Some(1), ..settings(16, caustics) });
        render_controlled(&scene, &accel, &plan, control).unwrap();
        reports.into_inner().unwrap()
    };
    let reports = reports_of(Caustics::Auto);
    let light: Vec<_> = reports.iter().take_while(|p| p.light_paths.is_some()).collect();
    // 64 x 48 x 16 / 4 = 12,288 paths: three chunks of 4,096.
    let traced: Vec<_> = light.iter().map(|p| p.light_paths.unwrap()).collect();
    assert_eq!(traced, [(4096, 12288), (8192, 12288), (12288, 12288)]);
    assert!(light.iter().all(|p| p.round == 0 && p.work_done == 0.0 && p.rays > 0));
    let pixels = &reports[light.len()..];
    assert!(!pixels.is_empty() && pixels.iter().all(|p| p.light_paths.is_none() && p.round >= 1));
    // Without light paths there is no such report.
    assert!(reports_of(Caustics::Off).iter().all(|p| p.light_paths.is_none()));
}

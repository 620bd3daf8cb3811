//! Adaptive sampling at a fixed budget (`ember render`'s default above 8 spp): at about the
//! cost of a uniform render it gives a lower error, the same image in expectation, and the same
//! bits for any thread count and after an interruption; its progress reports follow its work
//! through both rounds, and the command line says what it did in the user's terms.

mod common;

use ember::accel::{Accel, EmbreeAccel};
use ember::embree::{BuildOptions, Device};
use ember::film::{Checkpoint, Film};
use ember::integrator::{Progress, RenderControl, RenderPlan, RenderSettings, render, render_controlled};
use ember::scene::Scene;
use std::sync::atomic::{AtomicBool, Ordering};

/// The peers' teapot: a white diffuse teapot under one point light, black background. Its
/// noise is all in the teapot's indirectly lit parts; the background is exact.
fn teapot() -> Scene {
    Scene::load(&teapot_path()).unwrap()
}

/// [`teapot`]'s scene file.
fn teapot_path() -> std::path::PathBuf {
    let obj = common::scene_path("teapot.obj");
    let text = format!(
        r#"
[camera]
position = [0.2, 4.5, 9.0]
look_at = [0.2, 1.3, 0.0]
up = [0.0, 1.0, 0.0]
fov = 40

[materials.white]
type = "diffuse"
color = [1.0, 1.0, 1.0]

[[meshes]]
file = "{}"
material = "white"
smooth = false

[[lights]]
type = "point"
position = [5.0, 10.0, 8.0]
intensity = [400.0, 400.0, 400.0]
"#,
        obj.display()
    );
    common::write_scene("adaptive_budget", "teapot.toml", &text)
}

/// The peers' relMSE: mean over pixels and channels of (x − r)² / (r² + 0.01).
fn rel_mse(a: &Film, r: &Film) -> f64 {
    let mut sum = 0.0f64;
    for (p, q) in a.pixels.iter().zip(&r.pixels) {
        for c in 0..3 {
            let (x, y) = (p[c] as f64, q[c] as f64);
            sum += (x - y) * (x - y) / (y * y + 0.01);
        }
    }
    sum / (3 * a.pixels.len()) as f64
}

fn mean(f: &Film) -> f64 {
    f.pixels.iter().map(|p| p.element_sum() as f64).sum::<f64>() / (3 * f.pixels.len()) as f64
}

#[test]
fn adaptive_gives_lower_error_at_about_the_same_cost_and_the_same_mean() {
    let scene = teapot();
    let device = Device::new().unwrap();
    let accel = EmbreeAccel::new(&device, &scene.geometry, BuildOptions::default()).unwrap();
    let base = RenderSettings { width: 64, height: 64, spp: 32, ..Default::default() };
    let reference = render(&scene, &accel, &RenderSettings { spp: 2048, seed: 99, ..base.clone() }).unwrap().0;
    let (mut uniform_err, mut adaptive_err, mut uniform_rays, mut adaptive_rays) = (0.0, 0.0, 0, 0);
    let (mut uniform_mean, mut adaptive_mean) = (0.0, 0.0);
    let seeds = 1..5u64;
    for seed in seeds.clone() {
        let (u, us) = render(&scene, &accel, &RenderSettings { seed, ..base.clone() }).unwrap();
        let (a, st) = render(&scene, &accel, &RenderSettings { seed, adaptive: true, ..base.clone() }).unwrap();
        println!(
            "seed {seed}: uniform {:.3e}, adaptive {:.3e} (spp {:?})",
            rel_mse(&u, &reference),
            rel_mse(&a, &reference),
            st.spp
        );
        uniform_err += rel_mse(&u, &reference);
        adaptive_err += rel_mse(&a, &reference);
        // The rays after the camera rays: what the budget shares out.
        (uniform_rays, adaptive_rays) = (uniform_rays + us.rays - us.samples, adaptive_rays + st.rays - st.samples);
        (uniform_mean, adaptive_mean) = (uniform_mean + mean(&u), adaptive_mean + mean(&a));
        // Samples moved from the exact background to the teapot: the first round everywhere,
        // many more somewhere.
        assert_eq!(st.spp.0, 8, "{:?}", st.spp);
        assert!(st.spp.2 >= 4 * 32, "{:?}", st.spp);
    }
    println!("relMSE uniform {uniform_err:.3e}, adaptive {adaptive_err:.3e}; rays {uniform_rays} vs {adaptive_rays}");
    // Measured: 0.45× the error (0.37–0.50× per seed).
    assert!(adaptive_err < 0.6 * uniform_err, "{adaptive_err} vs {uniform_err}");
    // About the same cost: the budget is the uniform render's rays after the camera rays (and
    // a little per sample), shared out as whole packets of samples.
    let ratio = adaptive_rays as f64 / uniform_rays as f64;
    assert!((0.9..1.15).contains(&ratio), "rays after the camera {adaptive_rays} vs {uniform_rays}");
    // The same image in expectation: the means over the image agree with the reference's
    // within 1% (the uniform render's own spread over these seeds is ~0.3%).
    let n = seeds.count() as f64;
    let m = mean(&reference);
    for (what, x) in [("uniform", uniform_mean / n), ("adaptive", adaptive_mean / n)] {
        assert!((x / m - 1.0).abs() < 0.01, "{what}: mean {x} vs reference {m}");
    }
}

#[test]
fn adaptive_renders_are_the_same_for_any_thread_count_and_after_a_resume() {
    let scene = teapot();
    let device = Device::new().unwrap();
    let accel = EmbreeAccel::new(&device, &scene.geometry, BuildOptions::default()).unwrap();
    let s = RenderSettings { width: 40, height: 32, spp: 16, adaptive: true, ..Default::default() };
    let one = render(&scene, &accel, &RenderSettings { threads: Some(1), ..s.clone() }).unwrap();
    let two = render(&scene, &accel, &RenderSettings { threads: Some(2), ..s.clone() }).unwrap();
    assert_eq!(one.0, two.0);
    assert_eq!(one.1.spp, two.1.spp);
    assert!(one.1.spp.0 < one.1.spp.2, "an adaptive render's pixels differ in samples: {:?}", one.1.spp);

    // Stopped in the first round, then in the second, resumed each time: the same image.
    let dir = common::fresh_dir("adaptive_budget", "resume");
    let ckpt = dir.join("x.exr.checkpoint");
    let plan = RenderPlan::new(&scene, &s);
    let key = plan.checkpoint_key(scene.fingerprint(), &accel.image_key());
    let mut resume: Option<Checkpoint> = None;
    let mut stops = 0;
    for stop_in_round in [1u32, 2] {
        let stop = AtomicBool::new(false);
        let progress = |p: Progress| {
            if p.round == stop_in_round {
                stop.store(true, Ordering::Relaxed);
            }
        };
        let control = RenderControl {
            stop: Some(&stop),
            checkpoint: Some((&ckpt, None)),
            resume: resume.take().map(|c| (ckpt.as_path(), c)),
            progress: Some(&progress),
            ..Default::default()
        };
        let r = render_controlled(&scene, &accel, &plan, control).unwrap();
        if !r.complete {
            stops += 1;
            resume = Some(Checkpoint::load(&ckpt, &key).unwrap());
        }
    }
    assert_eq!(stops, 2, "both rounds were interrupted");
    let control = RenderControl { resume: resume.take().map(|c| (ckpt.as_path(), c)), ..Default::default() };
    let r = render_controlled(&scene, &accel, &plan, control).unwrap();
    assert!(r.complete);
    assert_eq!(r.accum.film(), one.0);
    assert_eq!(r.accum.spp_range(), one.1.spp);
}

#[test]
fn the_cli_renders_adaptive_by_default_and_says_so() {
    let dir = common::fresh_dir("adaptive_budget", "cli");
    let scene = teapot_path();
    let args = ["render", scene.to_str().unwrap(), "--width", "32", "--height", "24"];
    let said = |extra: &[&str], name: &str| {
        let out = dir.join(name);
        let o = common::ember(&[&args[..], extra, &["-o", out.to_str().unwrap()]].concat());
        let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
        assert!(o.status.success(), "{stderr}");
        assert!(out.exists());
        stderr
    };
    // The default above 8 spp. On the teapot the samples go to the teapot, whose samples
    // trace more rays than the black background's: fewer than 16 per pixel fit in the
    // budget, and the summary says so, and why.
    let e = said(&["--spp", "16"], "a.exr");
    let line = e.lines().find(|l| l.starts_with("rendered ")).unwrap();
    assert!(line.contains(" spp on average (adaptive: 8..") && line.contains(" per pixel) in "), "{e}");
    let mean: f64 = line.split(" at ").nth(1).unwrap().split(' ').next().unwrap().parse().unwrap();
    assert!(mean < 0.95 * 16.0, "{e}");
    let why = e.lines().find(|l| l.starts_with("adaptive: ")).unwrap_or_else(|| panic!("no why: {e}"));
    assert!(why.starts_with(&format!("adaptive: {mean} spp on average for --spp 16: ")), "{e}");
    assert!(why.contains("× the image's mean sample (more bounces), so fewer samples fit"), "{e}");
    // --uniform, a target error, or 8 spp or fewer (the first round is all of it): every
    // pixel takes its samples on its own.
    for (extra, says) in [
        (&["--spp", "16", "--uniform"][..], " at 16 spp in "),
        (&["--spp", "8"], " at 8 spp in "),
        (&["--spp", "64", "--target-error", "0.05"], " spp per pixel ("),
    ] {
        let e = said(extra, "u.exr");
        assert!(!e.contains("(adaptive: ") && !e.contains("\nadaptive: "), "{extra:?}: {e}");
        assert!(e.lines().any(|l| l.starts_with("rendered ") && l.contains(says)), "{extra:?}: {e}");
    }
    // The flag that did nothing is gone.
    let o = common::ember(&[&args[..], &["--adaptive", "-o", dir.join("x.exr").to_str().unwrap()]].concat());
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("unexpected argument '--adaptive'"));
}

/// The progress reports of a real adaptive render follow its work, measured by the rays
/// traced (a sample's time follows its rays: deterministic, where times on a shared machine are
/// not): at every report the share of the work done is within 0.1 of the share of the rays
/// traced, it never goes back, and the first round ends below half of it (not at 100%, as a
/// count of samples planned round by round would have it).
#[test]
fn an_adaptive_renders_progress_follows_its_work_through_both_rounds() {
    let scene = teapot();
    let device = Device::new().unwrap();
    let accel = EmbreeAccel::new(&device, &scene.geometry, BuildOptions::default()).unwrap();
    let s = RenderSettings { width: 64, height: 48, spp: 64, adaptive: true, threads: Some(1), ..Default::default() };
    let reports = std::sync::Mutex::new(Vec::new());
    let progress = |p: Progress| reports.lock().unwrap().push(p);
    let control = RenderControl { progress: Some(&progress), ..Default::default() };
    let r = render_controlled(&scene, &accel, &RenderPlan::new(&scene, &s), control).unwrap();
    let reports = reports.into_inner().unwrap();
    let total = r.stats.rays as f64;
    let (mut worst, mut worst_time, mut last) = (0.0f64, 0.0f64, 0.0f64);
    for p in &reports {
        let fraction = p.work_done / p.work_planned;
        worst = worst.max((fraction - p.rays as f64 / total).abs());
        worst_time = worst_time.max((fraction - p.elapsed.as_secs_f64() / r.stats.elapsed.as_secs_f64()).abs());
        assert!(fraction >= last - 0.02, "back from {last} to {fraction}");
        last = fraction;
    }
    let end_of_first = reports.iter().rfind(|p| p.round == 1).unwrap();
    let first = end_of_first.work_done / end_of_first.work_planned;
    println!(
        "work vs rays: {worst:.3} at worst (vs time, for information: {worst_time:.3}); the first round ends at \
         {first:.3} of the work, {:.3} of the rays",
        end_of_first.rays as f64 / total
    );
    assert!(worst < 0.1, "the share of work done is {worst:.3} away from the share of rays traced");
    assert!(first < 0.5, "the first round ends at {first:.3} of the work");
    let end = reports.last().unwrap();
    assert!((end.work_done / end.work_planned - 1.0).abs() < 1e-9);
}

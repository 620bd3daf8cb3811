//! Convergence studies: the error of the default estimator falls as 1/spp, a depth-limited
//! estimator stops at its bias, and `ember converge` writes its table, plots and reference
//! (and refuses a reference of the wrong size).

mod common;

use ember::accel::EmbreeAccel;
use ember::embree::{BuildOptions, Device};
use ember::film::Film;
use ember::integrator::{Estimator, Progress};
use ember::scene::Scene;
use ember::tools::converge::{Study, Variant, log_log_slope, spp_ladder};
use ember::tools::report::converge::CSV_HEADER;
use std::path::Path;
use std::process::{Command, Output};
use std::sync::Mutex;

#[test]
fn nee_mis_error_falls_as_one_over_spp_and_a_depth_limit_stops_at_its_bias() {
    // cornell-area at 32×32; reference: NEE+MIS at full depth 64, 2048 spp. Renders at 4 … 64
    // spp, 8 seeds each (errors averaged). Expected relMSE = A/spp + (reference's own error
    // ≈ A/2048), which makes the fitted slope over 4..64 about 0.01 shallower than −1. The
    // few-spp points are the noisy ones (rare bright samples): with `ember converge` at this
    // size, spp range and repeats (light vertices from the lamp), seeds 1 to 8 gave slopes
    // −1.03 … −1.08 (mean −1.05); this seed gives −1.06. The test allows −1 ± 0.15.
    let scene = Scene::load(&common::scene_path("cornell-area.toml")).unwrap();
    let device = Device::new().unwrap();
    let accel = EmbreeAccel::new(&device, &scene.geometry, BuildOptions::default()).unwrap();
    let study = Study {
        width: 32,
        height: 32,
        max_depth: 64,
        rr_depth: 3,
        seed: 7,
        threads: None,
        ladder: spp_ladder(64).into_iter().filter(|&s| s >= 4).collect(),
        repeats: 8,
    };
    // Progress: one count per render of the reference, and one over all of a variant's renders.
    let reports = Mutex::new(Vec::new());
    let record = |p: Progress| reports.lock().unwrap().push(p);
    let (reference, stats) = study.render_reference(&scene, &accel, 2048, Some(&record)).unwrap();
    assert_eq!(stats.nonfinite, 0);
    check_progress(&reports.lock().unwrap(), 32 * 32 * 2048);
    reports.lock().unwrap().clear();

    let fit = |variant: Variant| {
        let points = study.measure(&scene, &accel, &reference, variant, |_| {}, Some(&record)).unwrap();
        assert_eq!(points.iter().map(|m| m.spp).collect::<Vec<_>>(), vec![4, 8, 16, 32, 64]);
        let xy: Vec<(f64, f64)> = points.iter().map(|m| (m.spp as f64, m.error.rel_mse)).collect();
        (log_log_slope(&xy).unwrap(), xy)
    };
    let (slope, xy) = fit(Variant::new(Estimator::NeeMis));
    check_progress(&reports.lock().unwrap(), 32 * 32 * (4 + 8 + 16 + 32 + 64) * 8);
    eprintln!("nee-mis: slope {slope:.3}, (spp, relMSE) {xy:?}");
    assert!((slope + 1.0).abs() <= 0.15, "relMSE vs spp slope {slope:.3} (points {xy:?})");

    // Direct light only (depth 1) against the full-depth reference: the missing indirect light
    // is a bias no number of samples removes, so the error barely falls (measured: slope
    // −0.01, relMSE 0.26 at 64 spp against 0.028 for full depth).
    let (slope1, xy1) = fit(Variant { max_depth: Some(1), ..Variant::new(Estimator::NeeMis) });
    eprintln!("nee-mis/depth=1: slope {slope1:.3}, (spp, relMSE) {xy1:?}");
    assert!(slope1 > -0.5, "depth-1 slope {slope1:.3} (points {xy1:?})");
    assert!(xy1[4].1 > 4.0 * xy[4].1, "depth-1 relMSE {:?} vs full depth {:?} at 64 spp", xy1[4], xy[4]);
}

/// Progress reports of one bar: all with the same total, none beyond it, and the last count
/// (reports come from several threads, not always in order: the largest) at the total.
fn check_progress(reports: &[Progress], total: u64) {
    assert!(reports.len() > 1, "{} progress reports", reports.len());
    // Every variant is uniform: a sample is a unit of work.
    let total = total as f64;
    assert!(reports.iter().all(|p| p.work_planned == total && p.work_done <= total), "{reports:?}");
    assert_eq!(reports.iter().map(|p| p.work_done).max_by(f64::total_cmp), Some(total));
    assert!(reports.iter().all(|p| p.rounds == 1));
}

#[test]
fn a_sun_in_an_environment_image_converges_far_faster_sampled_by_luminance() {
    // A diffuse sphere on a diffuse ground under a 64×32 OpenEXR sky: dim blue (0.2, 0.3, 0.5)
    // but for a 2×2-texel sun (5000, 4000, 3000; 0.25% of the sphere, 96% of the light) at
    // 34° elevation. 24×16 pixels, depth 4; reference: NEE+MIS with the map sampled by
    // luminance, 1024 spp. At equal spp (4, 16, 64; 8 seeds each, common to both variants) the
    // relMSE of `nee-mis/env-uniform` over that of `nee-mis`: the ratio of the samples each
    // needs to reach a given relMSE, as both fall as 1/spp (the uniform one only on average:
    // its error comes from the rare samples that find the sun, so it jumps about). Measured
    // with Sobol samples (the default): 80, 160, 58 (relMSE by luminance 0.45, 0.11, 0.026);
    // with independent samples 59, 36, 48. Asserted: above 20 at every rung. `ember converge` on scenes/gltf-sky.toml measures
    // the same over a longer ladder (docs/performance.md).
    let dir = common::fresh_dir("converge", "sun");
    let sky = image::Rgb32FImage::from_fn(64, 32, |x, y| {
        if (40..42).contains(&x) && (9..11).contains(&y) {
            image::Rgb([5000.0, 4000.0, 3000.0])
        } else {
            image::Rgb([0.2, 0.3, 0.5])
        }
    });
    image::DynamicImage::ImageRgb32F(sky).save(dir.join("sun.exr")).unwrap();
    let p = dir.join("sun.toml");
    std::fs::write(
        &p,
        r#"
        [camera]
        position = [0.0, 3.0, 5.0]
        look_at = [0.0, 0.5, 0.0]
        fov = 45
        [background]
        type = "image"
        file = "sun.exr"
        [materials.white]
        type = "diffuse"
        color = [0.7, 0.7, 0.7]
        [[quads]]
        corner = [-10.0, 0.0, -10.0]
        edge1 = [0.0, 0.0, 20.0]
        edge2 = [20.0, 0.0, 0.0]
        material = "white"
        [[spheres]]
        center = [0.0, 1.0, 0.0]
        radius = 1.0
        material = "white"
        "#,
    )
    .unwrap();
    let scene = Scene::load(&p).unwrap();
    let device = Device::new().unwrap();
    let accel = EmbreeAccel::new(&device, &scene.geometry, BuildOptions::default()).unwrap();
    let study = Study {
        width: 24,
        height: 16,
        max_depth: 4,
        rr_depth: 3,
        seed: 5,
        threads: None,
        ladder: vec![4, 16, 64],
        repeats: 8,
    };
    let (reference, stats) = study.render_reference(&scene, &accel, 1024, None).unwrap();
    assert_eq!(stats.nonfinite, 0);
    let measure = |v: &str| study.measure(&scene, &accel, &reference, v.parse().unwrap(), |_| {}, None).unwrap();
    let (luminance, uniform) = (measure("nee-mis"), measure("nee-mis/env-uniform"));
    for (a, b) in luminance.iter().zip(&uniform) {
        let ratio = b.error.rel_mse / a.error.rel_mse;
        eprintln!(
            "{} spp: relMSE {:.3e} by luminance, {:.3e} uniform, ratio {ratio:.1}",
            a.spp, a.error.rel_mse, b.error.rel_mse
        );
        assert!(ratio > 20.0, "{} spp: relMSE {} by luminance, {} uniform", a.spp, a.error.rel_mse, b.error.rel_mse);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

fn ember(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_ember")).args(args).output().expect("ember runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The (variant, spp, rel_mse, mae) columns of a converge.csv.
fn errors(csv: &str) -> Vec<String> {
    csv.lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            format!("{},{},{},{}", f[0], f[4], f[8], f[9])
        })
        .collect()
}

#[test]
fn cli_writes_table_plots_and_a_reusable_reference() {
    let scene = common::scene_path("cornell-area.toml");
    let out = common::fresh_path("converge", "run");
    let small = ["--width", "16", "--height", "12", "--max-spp", "4", "--reference-spp", "16"];
    let variants = ["--variants", "nee-mis,bsdf-uniform/no-rr,nee-mis/depth=1,nee-mis/denoise"];
    let o = ember(&[&["converge", s(&scene), "--out", s(&out)][..], &small, &variants].concat());
    assert!(o.status.success(), "{}", stderr(&o));

    let csv = std::fs::read_to_string(out.join("converge.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines[0], CSV_HEADER);
    assert_eq!(lines.len(), 1 + 4 * 3, "{csv}"); // 4 variants × (1, 2, 4 spp)
    assert!(lines[1].starts_with("nee-mis,nee-mis,true,64,1,1,"), "{}", lines[1]);
    assert!(lines[4].starts_with("bsdf-uniform/no-rr,bsdf-uniform,false,64,1,1,"), "{}", lines[4]);
    assert!(lines[9].starts_with("nee-mis/depth=1,nee-mis,true,1,4,1,"), "{}", lines[9]);
    assert!(lines[10].starts_with("nee-mis/denoise=prefilter,nee-mis,true,64,1,1,"), "{}", lines[10]);
    for l in &lines[1..] {
        // seconds, rays, rel_mse, mae, nonfinite | denoise | denoise_seconds, flip
        let cells: Vec<&str> = l.split(',').collect();
        let f: Vec<f64> = cells[6..11].iter().chain(&cells[12..]).map(|x| x.parse().unwrap()).collect();
        assert!(f.iter().all(|x| x.is_finite() && *x >= 0.0) && f[2] > 0.0, "{l}");
        let (denoised, flip) = (cells[11] != "none", f[6]);
        assert_eq!(cells[11], if l.starts_with("nee-mis/denoise") { "prefilter" } else { "none" }, "{l}");
        // FLIP is in (0, 1]; a denoised variant's time includes its denoising time.
        assert!(flip > 0.0 && flip <= 1.0, "{l}");
        assert_eq!(f[5] > 0.0, denoised, "{l}");
        assert!(f[0] >= f[5], "{l}");
    }
    // The denoised variant renders what nee-mis renders, then denoises: closer at every spp.
    for (n, d) in lines[1..4].iter().zip(&lines[10..13]) {
        let rel = |l: &str| l.split(',').nth(8).unwrap().parse::<f64>().unwrap();
        assert!(rel(d) < rel(n), "{n}\n{d}");
    }
    for png in [
        "error_vs_spp.png",
        "error_vs_time.png",
        "flip_vs_spp.png",
        "flip_vs_time.png",
        "depth_error_vs_spp.png",
        "depth_error_vs_time.png",
    ] {
        let img = image::open(out.join(png)).unwrap();
        assert_eq!((img.width(), img.height()), (900, 600), "{png}");
    }
    let reference = Film::load_exr(&out.join("reference.exr")).unwrap();
    assert_eq!((reference.width, reference.height), (16, 12));
    let table = String::from_utf8_lossy(&o.stdout);
    assert!(table.contains("time to reach relMSE 0.01"), "{table}");
    assert!(table.contains("not reached within 4 spp"), "{table}");
    assert!(table.contains("time to reach FLIP 0.05"), "{table}");
    let row = |name: &str| table.lines().find(|l| l.starts_with(&format!("{name} "))).unwrap().to_string();
    assert!(row("nee-mis").ends_with(" unbiased"), "{table}");
    assert!(row("nee-mis/depth=1").ends_with(" biased: depth limit"), "{table}");
    assert!(row("nee-mis/denoise=prefilter").ends_with(" biased: denoised"), "{table}");
    // No temporary files left behind.
    let mut names: Vec<String> =
        std::fs::read_dir(&out).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
    names.sort();
    assert_eq!(
        names,
        [
            "converge.csv",
            "depth_error_vs_spp.png",
            "depth_error_vs_time.png",
            "error_vs_spp.png",
            "error_vs_time.png",
            "flip_vs_spp.png",
            "flip_vs_time.png",
            "reference.exr"
        ]
    );

    // A second run measures against the saved reference: the same seeds give the same errors,
    // and no new reference is written.
    let out2 = common::fresh_path("converge", "rerun");
    let r = out.join("reference.exr");
    let o = ember(&[&["converge", s(&scene), "--out", s(&out2), "--reference", s(&r)][..], &small, &variants].concat());
    assert!(o.status.success(), "{}", stderr(&o));
    let csv2 = std::fs::read_to_string(out2.join("converge.csv")).unwrap();
    assert_eq!(errors(&csv2), errors(&csv));
    assert!(!out2.join("reference.exr").exists());

    // A reference of another size is refused before anything is rendered or written.
    let out3 = common::fresh_path("converge", "wrong-size");
    let o = ember(&["converge", s(&scene), "--out", s(&out3), "--reference", s(&r), "--width", "16", "--height", "16"]);
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(
        stderr(&o).trim(),
        format!("error: {}: reference is 16x12 pixels but the study renders 16x16", r.display())
    );
    assert!(!out3.exists());

    std::fs::remove_dir_all(&out).unwrap();
    std::fs::remove_dir_all(&out2).unwrap();
}

#[test]
fn cli_refuses_a_missing_reference_and_unknown_variants() {
    let scene = common::scene_path("cornell-area.toml");
    let out = common::fresh_path("converge", "refuse");
    let o = ember(&["converge", s(&scene), "--out", s(&out), "--reference", "no/such/ref.exr"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).starts_with("error: no/such/ref.exr: cannot read:"), "{}", stderr(&o));
    let o = ember(&["converge", s(&scene), "--out", s(&out), "--variants", "nee-mis,nee-mis/depth=two"]);
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(
        stderr(&o).trim(),
        "error: --variants: variant \"nee-mis/depth=two\": depth \"two\" is not a whole number"
    );
    let o = ember(&["converge", s(&scene), "--out", s(&out), "--target", "0"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--target: expected a positive number"), "{}", stderr(&o));
    assert!(!out.exists());
}

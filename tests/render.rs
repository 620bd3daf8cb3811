//! The path tracer against analytic answers, estimator agreement, accelerator agreement and
//! determinism. Small images, fixed seeds; tolerances are stated with each test.

mod common;

use ember::sampler::SamplerKind;

use ember::accel::{EmbreeAccel, NaiveAccel};
use ember::embree::{BuildOptions, Device};
use ember::film::Film;
use ember::integrator::{Estimator, RenderSettings, render};
use ember::scene::Scene;
use glam::Vec3;

fn embree_render(scene: &Scene, settings: &RenderSettings) -> Film {
    let (film, stats) = common::render_embree(scene, settings);
    assert_eq!(stats.nonfinite, 0, "non-finite samples");
    film
}

/// The average of `f` over the pixel's area (8 × 8 sub-positions), matching the renderer's
/// box filter with jittered positions.
fn pixel_average(x: u32, y: u32, w: u32, h: u32, f: impl Fn(glam::Vec2) -> f64) -> f64 {
    let mut sum = 0.0;
    for j in 0..8 {
        for i in 0..8 {
            sum += f(glam::Vec2::new(
                (x as f32 + (i as f32 + 0.5) / 8.0) / w as f32,
                (y as f32 + (j as f32 + 0.5) / 8.0) / h as f32,
            ));
        }
    }
    sum / 64.0
}

fn settings(w: u32, h: u32, spp: u32) -> RenderSettings {
    RenderSettings { width: w, height: h, spp, ..Default::default() }
}

#[test]
fn white_furnace_sphere_in_uniform_sky_is_one_everywhere() {
    // An albedo-1 diffuse sphere under uniform sky radiance 1 reflects exactly radiance 1:
    // every pixel (sphere or sky) must be 1. Tolerance: 1% per pixel (16384 spp), 0.2% for
    // the image mean.
    let p = common::write_scene(
        "render",
        "furnace.toml",
        r#"
        [camera]
        position = [0.0, 0.0, 4.0]
        look_at = [0.0, 0.0, 0.0]
        fov = 40
        [background]
        type = "constant"
        color = [1.0, 1.0, 1.0]
        [materials.white]
        type = "diffuse"
        color = [1.0, 1.0, 1.0]
        [[spheres]]
        center = [0.0, 0.0, 0.0]
        radius = 1.0
        material = "white"
        "#,
    );
    let scene = Scene::load(&p).unwrap();
    let film = embree_render(&scene, &RenderSettings { max_depth: 50, ..settings(8, 8, 16384) });
    let worst = film.pixels.iter().map(|p| (*p - Vec3::ONE).abs().max_element()).fold(0.0f32, f32::max);
    assert!(worst < 0.01, "worst pixel off by {worst}");
    assert!((common::image_mean(&film.pixels) - 1.0).abs() < 0.002, "mean {}", common::image_mean(&film.pixels));
}

/// Writes a `width` x `height` OpenEXR image (f32 RGB) of `f(x, y)` with the `exr` crate.
fn write_exr(path: &std::path::Path, width: usize, height: usize, f: impl Fn(usize, usize) -> Vec3 + Sync) {
    exr::prelude::write_rgb_file(path, width, height, |x, y| {
        let c = f(x, y);
        (c.x, c.y, c.z)
    })
    .unwrap();
}

#[test]
fn white_furnace_sphere_under_a_constant_environment_image_is_that_value_everywhere() {
    // The furnace test above with the sky a 16x8 OpenEXR image of one value, 0.25, at strength
    // 4 (radiance 1, above the 8-bit range's 1 in the image itself: read as it is) and rotated
    // 30°: sampled by luminance, the map must give the same answer, 1 everywhere. Tolerance:
    // 1% per pixel (16384 spp), 0.2% for the image mean.
    let dir = common::fresh_dir("render", "env-furnace");
    write_exr(&dir.join("constant.exr"), 16, 8, |_, _| Vec3::splat(0.25));
    let p = dir.join("furnace.toml");
    std::fs::write(
        &p,
        r#"
        [camera]
        position = [0.0, 0.0, 4.0]
        look_at = [0.0, 0.0, 0.0]
        fov = 40
        [background]
        type = "image"
        file = "constant.exr"
        strength = 4.0
        rotate = 30
        [materials.white]
        type = "diffuse"
        color = [1.0, 1.0, 1.0]
        [[spheres]]
        center = [0.0, 0.0, 0.0]
        radius = 1.0
        material = "white"
        "#,
    )
    .unwrap();
    let scene = Scene::load(&p).unwrap();
    assert!(scene.inputs.contains(&dir.join("constant.exr")), "{:?}", scene.inputs);
    let film = embree_render(&scene, &RenderSettings { max_depth: 50, ..settings(8, 8, 16384) });
    let worst = film.pixels.iter().map(|p| (*p - Vec3::ONE).abs().max_element()).fold(0.0f32, f32::max);
    assert!(worst < 0.01, "worst pixel off by {worst}");
    assert!((common::image_mean(&film.pixels) - 1.0).abs() < 0.002, "mean {}", common::image_mean(&film.pixels));
}

#[test]
fn hdr_environment_images_are_linear_and_unclamped() {
    // A Radiance RGBE file (written by the image crate) and an OpenEXR file of values above 1
    // are seen as they are (times the strength; `scale` is the older name of `strength`); a
    // PNG environment is sRGB; an EXR is refused as a surface's texture.
    let dir = common::fresh_dir("render", "env-hdr");
    let hdr = image::Rgb32FImage::from_pixel(8, 4, image::Rgb([3.0, 1.5, 0.25]));
    image::DynamicImage::ImageRgb32F(hdr).save(dir.join("sky.hdr")).unwrap();
    write_exr(&dir.join("sky.exr"), 8, 4, |_, _| Vec3::new(3.0, 1.5, 0.25));
    image::RgbImage::from_pixel(8, 4, image::Rgb([188, 188, 188])).save(dir.join("sky.png")).unwrap();
    let scene = |background: &str, texture: &str| {
        format!(
            "[camera]\nposition = [0.0, 0.0, 4.0]\nlook_at = [0.0, 0.0, 0.0]\nfov = 10\n\
             [background]\ntype = \"image\"\n{background}\n[materials.m]\ntype = \"diffuse\"\n{texture}\n\
             [[spheres]]\ncenter = [0.0, 50.0, 0.0]\nradius = 0.5\nmaterial = \"m\"\n"
        )
    };
    for (background, expected) in [
        ("file = \"sky.hdr\"", Vec3::new(3.0, 1.5, 0.25)),
        ("file = \"sky.exr\"\nstrength = 2.0", Vec3::new(6.0, 3.0, 0.5)),
        ("file = \"sky.exr\"\nscale = 0.5\nrotate = -45", Vec3::new(1.5, 0.75, 0.125)),
        ("file = \"sky.png\"", Vec3::splat(ember::film::srgb_to_linear(188.0 / 255.0))),
    ] {
        let p = dir.join("scene.toml");
        std::fs::write(&p, scene(background, "")).unwrap();
        let s = Scene::load(&p).unwrap_or_else(|e| panic!("{background}: {e}"));
        let film = embree_render(&s, &settings(4, 4, 1));
        for px in &film.pixels {
            assert!((*px - expected).abs().max_element() <= 1e-5 * expected.max_element(), "{background}: {px}");
        }
    }
    let p = dir.join("both.toml");
    std::fs::write(&p, scene("file = \"sky.exr\"\nstrength = 2.0\nscale = 2.0", "")).unwrap();
    let e = Scene::load(&p).unwrap_err().to_string();
    assert!(e.contains("duplicate field"), "{e}");
    std::fs::write(&p, scene("file = \"sky.exr\"", "texture = \"sky.exr\"")).unwrap();
    let e = Scene::load(&p).unwrap_err().to_string();
    assert!(e.contains("OpenEXR is a high-dynamic-range format, for [background]"), "{e}");
    // A NaN in the file is refused, naming the pixel.
    write_exr(&dir.join("nan.exr"), 8, 4, |x, y| if (x, y) == (5, 2) { Vec3::NAN } else { Vec3::ONE });
    std::fs::write(&p, scene("file = \"nan.exr\"", "")).unwrap();
    let e = Scene::load(&p).unwrap_err().to_string();
    assert!(e.contains("nan.exr: pixel (5, 2) is [NaN, NaN, NaN]: not a finite value"), "{e}");
}

#[test]
fn damaged_environment_files_are_refused_naming_the_file() {
    // Truncated OpenEXR and Radiance files (the first half of a good one), a text file named
    // .exr, an empty .hdr and a missing file: each an error naming the scene, the background
    // section and the image file, with the decoder's reason.
    let dir = common::fresh_dir("render", "env-bad");
    write_exr(&dir.join("good.exr"), 32, 16, |x, y| Vec3::splat((x + y) as f32));
    let hdr = image::Rgb32FImage::from_fn(32, 16, |x, y| image::Rgb([x as f32, y as f32, 1.0]));
    image::DynamicImage::ImageRgb32F(hdr).save(dir.join("good.hdr")).unwrap();
    for ext in ["exr", "hdr"] {
        let bytes = std::fs::read(dir.join(format!("good.{ext}"))).unwrap();
        std::fs::write(dir.join(format!("cut.{ext}")), &bytes[..bytes.len() / 2]).unwrap();
    }
    std::fs::write(dir.join("text.exr"), "not an image\n").unwrap();
    std::fs::write(dir.join("empty.hdr"), "").unwrap();
    let p = dir.join("scene.toml");
    for (file, reason) in [
        ("cut.exr", "Format error decoding OpenExr: invalid: reference to missing bytes"),
        ("cut.hdr", "truncated or damaged: the file ends early"),
        ("text.exr", "not an image ember reads: expected OpenEXR, Radiance HDR, PNG or JPEG"),
        ("empty.hdr", "not an image ember reads"),
        ("missing.exr", "no such file"),
    ] {
        std::fs::write(&p, format!("[background]\ntype = \"image\"\nfile = \"{file}\"\n")).unwrap();
        let e = Scene::load(&p).unwrap_err().to_string();
        eprintln!("{file}: {e}");
        assert!(
            e.contains("scene.toml:1") && e.contains(&format!("environment image {}", dir.join(file).display())),
            "{e}"
        );
        assert!(e.contains(reason), "{file}: {e}");
    }
}

#[test]
fn diffuse_plane_under_point_light_matches_inverse_square_cosine() {
    // L = albedo/π · I cosθ / r² averaged over each pixel. Direct light only: the only noise
    // is the jittered position inside the pixel (about ±1% at 64 spp, so 1024 spp). Tolerance:
    // 1% per pixel.
    let (albedo, intensity, h) = (0.5f32, 40.0f32, 2.0f32);
    let p = common::write_scene(
        "render",
        "point.toml",
        &format!(
            r#"
            [camera]
            position = [0.0, 10.0, 0.0]
            look_at = [0.0, 0.0, 0.0]
            up = [0.0, 0.0, -1.0]
            fov = 30
            [materials.plane]
            type = "diffuse"
            color = [{albedo}, {albedo}, {albedo}]
            [[quads]]
            corner = [-10.0, 0.0, -10.0]
            edge1 = [0.0, 0.0, 20.0]
            edge2 = [20.0, 0.0, 0.0]
            material = "plane"
            [[lights]]
            type = "point"
            position = [0.5, {h}, 0.3]
            intensity = [{intensity}, {intensity}, {intensity}]
            "#
        ),
    );
    let scene = Scene::load(&p).unwrap();
    let (w, hgt) = (32, 32);
    let film = embree_render(&scene, &RenderSettings { max_depth: 1, ..settings(w, hgt, 1024) });
    let cam = scene.camera(1.0);
    let light = Vec3::new(0.5, h, 0.3);
    let mut worst = 0.0f32;
    for y in 0..hgt {
        for x in 0..w {
            let expected = pixel_average(x, y, w, hgt, |film| {
                let ray = cam.ray(film, glam::Vec2::ZERO);
                let q = ray.at(-ray.o.y / ray.d.y);
                let d = light - q;
                (albedo / std::f32::consts::PI * intensity * (d.y / d.length()) / d.length_squared()) as f64
            }) as f32;
            let got = film.get(x, y).x;
            worst = worst.max((got - expected).abs() / expected);
        }
    }
    assert!(worst < 0.01, "worst relative error {worst}");
}

/// Irradiance at a point below a corner of a parallel emitting rectangle a × b at height c,
/// radiance le: E = le · π · F, with the differential-area-to-rectangle form factor
/// F = 1/(2π) [ a/√(a²+c²) atan(b/√(a²+c²)) + b/√(b²+c²) atan(a/√(b²+c²)) ].
fn corner_irradiance(a: f64, b: f64, c: f64, le: f64) -> f64 {
    let (ra, rb) = ((a * a + c * c).sqrt(), (b * b + c * c).sqrt());
    let f = (a / ra * (b / ra).atan() + b / rb * (a / rb).atan()) / (2.0 * std::f64::consts::PI);
    le * std::f64::consts::PI * f
}

/// Light: 2 × 2 quad at height 1 over [-1,1]², radiance `le`; a plane of albedo `albedo`
/// seen from above. For points under the light, E is the sum of four corner rectangles.
/// Tolerances: the image mean within 1%, 99% of pixels within 5% (1024 spp, Monte Carlo
/// noise).
fn check_plane_under_quad_light(scene: &Scene, albedo: f64, le: f64) {
    let (w, h) = (24, 24);
    let film = embree_render(scene, &RenderSettings { max_depth: 1, ..settings(w, h, 1024) });
    let cam = scene.camera(1.0);
    let (mut sum_got, mut sum_exp, mut n, mut off) = (0.0f64, 0.0f64, 0, 0);
    for y in 0..h {
        for x in 0..w {
            let expected = pixel_average(x, y, w, h, |film| {
                let ray = cam.ray(film, glam::Vec2::ZERO);
                let q = ray.at(-ray.o.y / ray.d.y);
                let (qx, qz) = (q.x as f64, q.z as f64);
                let e: f64 = [(1.0 - qx, 1.0 - qz), (1.0 + qx, 1.0 - qz), (1.0 - qx, 1.0 + qz), (1.0 + qx, 1.0 + qz)]
                    .iter()
                    .map(|&(a, b)| corner_irradiance(a, b, 1.0, le))
                    .sum();
                albedo / std::f64::consts::PI * e
            });
            let got = film.get(x, y).x as f64;
            sum_got += got;
            sum_exp += expected;
            n += 1;
            if (got - expected).abs() / expected > 0.05 {
                off += 1;
            }
        }
    }
    assert!(n > 200, "too few pixels under the light ({n})");
    let mean_err = (sum_got - sum_exp).abs() / sum_exp;
    assert!(mean_err < 0.01, "mean relative error {mean_err}");
    assert!(off * 100 <= n, "{off} of {n} pixels off by more than 5%");
}

const CAMERA_ABOVE_PLANE: &str = r#"
[camera]
position = [0.0, 0.5, 0.0]
look_at = [0.0, 0.0, 0.0]
up = [0.0, 0.0, -1.0]
fov = 90
"#;

#[test]
fn plane_under_emissive_quad_matches_form_factor() {
    let (albedo, le) = (0.8f64, 3.0f64);
    let p = common::write_scene(
        "render",
        "formfactor.toml",
        &format!(
            r#"{CAMERA_ABOVE_PLANE}
            [materials.plane]
            type = "diffuse"
            color = [{albedo}, {albedo}, {albedo}]
            [materials.light]
            type = "emissive"
            emission = [{le}, {le}, {le}]
            [[quads]]
            corner = [-10.0, 0.0, -10.0]
            edge1 = [0.0, 0.0, 20.0]
            edge2 = [20.0, 0.0, 0.0]
            material = "plane"
            [[quads]]
            corner = [-1.0, 1.0, -1.0]
            edge1 = [2.0, 0.0, 0.0]
            edge2 = [0.0, 0.0, 2.0]
            material = "light"
            "#
        ),
    );
    check_plane_under_quad_light(&Scene::load(&p).unwrap(), albedo, le);
}

/// The same scene from an OBJ whose light is an MTL material with `Ke` (and a black `Kd`):
/// `Ke` is emission.
#[test]
fn mtl_ke_is_emission() {
    let (albedo, le) = (0.8f64, 3.0f64);
    common::write_scene(
        "render",
        "ke.mtl",
        &format!("newmtl plane\nKd {albedo} {albedo} {albedo}\nnewmtl light\nKd 0 0 0\nKe {le} {le} {le}\n"),
    );
    common::write_scene(
        "render",
        "ke.obj",
        "mtllib ke.mtl\n\
         v -10 0 -10\nv 10 0 -10\nv 10 0 10\nv -10 0 10\n\
         v -1 1 -1\nv 1 1 -1\nv 1 1 1\nv -1 1 1\n\
         usemtl plane\nf 1 4 3 2\nusemtl light\nf 5 6 7 8\n",
    );
    let p = common::write_scene("render", "ke.toml", &format!("{CAMERA_ABOVE_PLANE}[[meshes]]\nfile = \"ke.obj\"\n"));
    let scene = Scene::load(&p).unwrap();
    assert!(
        scene.materials.iter().any(|m| m.emission == ember::texture::Texture::Constant(glam::Vec3::splat(le as f32))),
        "{:?}",
        scene.materials
    );
    check_plane_under_quad_light(&scene, albedo, le);
}

#[test]
fn all_estimators_agree_in_the_mean() {
    // The Cornell box with its area light, 8 independent seeds per estimator: the two image
    // means must agree within 3 combined standard errors. Independent samples: NEE alone has a
    // heavy tail here (light samples from points close to the light; its spread over seeds
    // grows from 0.0023 at 64 spp to 0.0066 at 1024), so the mean of a few renders usually
    // sits below the expectation. Independent seeds show that in their spread; Sobol renders,
    // whose spread is 8x smaller, do not (NEE alone 0.1831 ± 0.0003 at 64 spp, 0.1846 ±
    // 0.0005 at 1024, against NEE+MIS 0.1872 ± 0.0001; 16 seeds, 24x24, depth 4).
    let scene = Scene::load(&common::scene_path("cornell-area.toml")).unwrap();
    let device = Device::new().unwrap();
    let accel = EmbreeAccel::new(&device, &scene.geometry, BuildOptions::default()).unwrap();
    let stats_of = |estimator: Estimator, sampler: SamplerKind| {
        let means: Vec<f64> = (0..8)
            .map(|seed| {
                let s = RenderSettings { estimator, seed, max_depth: 4, sampler, ..settings(24, 24, 16) };
                common::image_mean(&render(&scene, &accel, &s).unwrap().0.pixels)
            })
            .collect();
        let m = means.iter().sum::<f64>() / means.len() as f64;
        let var = means.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (means.len() - 1) as f64;
        (m, (var / means.len() as f64).sqrt())
    };
    let stats = |estimator: Estimator| stats_of(estimator, SamplerKind::Independent);
    let (m1, se1) = stats(Estimator::NeeMis);
    let (m2, se2) = stats(Estimator::BsdfOnly);
    let (m3, se3) = stats(Estimator::NeeOnly);
    let (m4, se4) = stats(Estimator::BsdfUniform);
    println!("nee+mis {m1:.5} ± {se1:.5}, bsdf {m2:.5} ± {se2:.5}, nee {m3:.5} ± {se3:.5}, uniform {m4:.5} ± {se4:.5}");
    assert!((m1 - m4).abs() < 3.0 * (se1 * se1 + se4 * se4).sqrt(), "NEE+MIS {m1} vs uniform BSDF {m4}");
    assert!(se2 < se4, "cosine sampling should have lower variance than uniform");
    assert!((m1 - m2).abs() < 3.0 * (se1 * se1 + se2 * se2).sqrt(), "NEE+MIS {m1} vs BSDF-only {m2}");
    assert!((m1 - m3).abs() < 3.0 * (se1 * se1 + se3 * se3).sqrt(), "NEE+MIS {m1} vs NEE-only {m3}");
    assert!(se1 < se2, "MIS should have lower variance than BSDF sampling alone");
    // The Sobol sampler computes the same image in the mean, with less spread.
    let (m5, se5) = stats_of(Estimator::NeeMis, SamplerKind::Sobol);
    println!("nee+mis, sobol {m5:.5} ± {se5:.5}");
    assert!((m1 - m5).abs() < 3.0 * (se1 * se1 + se5 * se5).sqrt(), "independent {m1} vs Sobol {m5}");
    assert!(se5 < se1, "Sobol samples should spread less than independent ones");
}

#[test]
fn estimators_agree_under_an_environment_image() {
    // NEE alone uses the environment's sampled directions and their density, BSDF sampling
    // alone only the radiance rays that escape see, NEE+MIS both with `pdf` weighting the
    // escapes: a density inconsistent with the sampling, or a rotation applied on one side
    // only, would make them disagree. A plastic and a diffuse sphere on a diffuse ground under
    // a 32×16 OpenEXR sky (0.3 to 0.9 from bottom to top) with a 3×3-texel patch of 40 (about
    // half the light), rotated 70°. 24×24 pixels, depth 4, 8 independent seeds × 64 spp per
    // estimator: the image means agree within 3 combined standard errors, and NEE+MIS spreads
    // less than BSDF sampling alone.
    let dir = common::fresh_dir("render", "env-estimators");
    write_exr(&dir.join("patch.exr"), 32, 16, |x, y| {
        if (20..23).contains(&x) && (4..7).contains(&y) {
            Vec3::splat(40.0)
        } else {
            Vec3::splat(0.9 - 0.04 * y as f32)
        }
    });
    let p = dir.join("scene.toml");
    std::fs::write(
        &p,
        r#"
        [camera]
        position = [0.0, 2.5, 6.0]
        look_at = [0.0, 0.8, 0.0]
        fov = 45
        [background]
        type = "image"
        file = "patch.exr"
        rotate = 70
        [materials.ground]
        type = "diffuse"
        color = [0.6, 0.6, 0.6]
        [materials.red]
        type = "plastic"
        color = [0.7, 0.2, 0.1]
        roughness = 0.3
        [[quads]]
        corner = [-8.0, 0.0, -8.0]
        edge1 = [0.0, 0.0, 16.0]
        edge2 = [16.0, 0.0, 0.0]
        material = "ground"
        [[spheres]]
        center = [-1.1, 1.0, 0.0]
        radius = 1.0
        material = "red"
        [[spheres]]
        center = [1.1, 1.0, 0.0]
        radius = 1.0
        material = "ground"
        "#,
    )
    .unwrap();
    let scene = Scene::load(&p).unwrap();
    let device = Device::new().unwrap();
    let accel = EmbreeAccel::new(&device, &scene.geometry, BuildOptions::default()).unwrap();
    let stats = |estimator: Estimator| {
        let means: Vec<f64> = (0..8)
            .map(|seed| {
                let s = RenderSettings {
                    estimator,
                    seed,
                    max_depth: 4,
                    sampler: SamplerKind::Independent,
                    ..settings(24, 24, 64)
                };
                common::image_mean(&render(&scene, &accel, &s).unwrap().0.pixels)
            })
            .collect();
        let m = means.iter().sum::<f64>() / means.len() as f64;
        let var = means.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (means.len() - 1) as f64;
        (m, (var / means.len() as f64).sqrt())
    };
    let (m1, se1) = stats(Estimator::NeeMis);
    let (m2, se2) = stats(Estimator::BsdfOnly);
    let (m3, se3) = stats(Estimator::NeeOnly);
    eprintln!("nee+mis {m1:.5} ± {se1:.5}, bsdf {m2:.5} ± {se2:.5}, nee {m3:.5} ± {se3:.5}");
    assert!((m1 - m2).abs() < 3.0 * (se1 * se1 + se2 * se2).sqrt(), "NEE+MIS {m1} ± {se1} vs BSDF-only {m2} ± {se2}");
    assert!((m1 - m3).abs() < 3.0 * (se1 * se1 + se3 * se3).sqrt(), "NEE+MIS {m1} ± {se1} vs NEE-only {m3} ± {se3}");
    assert!((m2 - m3).abs() < 3.0 * (se2 * se2 + se3 * se3).sqrt(), "BSDF-only {m2} ± {se2} vs NEE-only {m3} ± {se3}");
    assert!(se1 < se2, "NEE+MIS {se1} should spread less than BSDF sampling alone {se2}");
}

#[test]
fn naive_and_embree_give_the_same_image() {
    // Same scene, seed and random streams: the images differ only where the two triangle
    // tests round differently. Tolerance: mean absolute difference below 0.5% of the mean,
    // 99% of pixels within 1e-3 absolute.
    let scene = Scene::load(&common::scene_path("spheres.toml")).unwrap();
    let s = RenderSettings { max_depth: 4, ..settings(40, 25, 4) };
    let a = embree_render(&scene, &s);
    let naive = NaiveAccel::new(&scene.geometry);
    let (b, _) = render(&scene, &naive, &s).unwrap();
    let diffs: Vec<f32> = a.pixels.iter().zip(&b.pixels).map(|(p, q)| (*p - *q).abs().max_element()).collect();
    let mean_diff = diffs.iter().sum::<f32>() / diffs.len() as f32;
    let close = diffs.iter().filter(|&&d| d <= 1e-3).count();
    assert!(mean_diff <= 0.005 * common::image_mean(&a.pixels) as f32, "mean difference {mean_diff}");
    assert!(close * 100 >= diffs.len() * 99, "{close} of {} pixels within 1e-3", diffs.len());
}

#[test]
fn every_bvh_build_gives_the_same_image() {
    // `--bvh-quality` and `--no-robust` change how Embree builds and traverses, not what is
    // hit: same tolerance as naive vs Embree above (a ray grazing an edge may round to the
    // neighbouring triangle). The teapot scene: a smooth mesh, a quad floor, an area light.
    use ember::embree::BuildQuality;
    let scene = Scene::load(&common::scene_path("teapot.toml")).unwrap();
    let s = RenderSettings { max_depth: 3, ..settings(40, 30, 4) };
    let reference = embree_render(&scene, &s);
    let device = Device::new().unwrap();
    for quality in [BuildQuality::Low, BuildQuality::Medium, BuildQuality::High] {
        for robust in [false, true] {
            let accel =
                EmbreeAccel::new(&device, &scene.geometry, BuildOptions { quality, robust, ..BuildOptions::default() })
                    .unwrap();
            let (b, _) = render(&scene, &accel, &s).unwrap();
            let diffs: Vec<f32> =
                reference.pixels.iter().zip(&b.pixels).map(|(p, q)| (*p - *q).abs().max_element()).collect();
            let mean_diff = diffs.iter().sum::<f32>() / diffs.len() as f32;
            let close = diffs.iter().filter(|&&d| d <= 1e-3).count();
            let what = format!("{quality} quality, robust {robust}");
            assert!(
                mean_diff <= 0.005 * common::image_mean(&reference.pixels) as f32,
                "{what}: mean difference {mean_diff}"
            );
            assert!(close * 100 >= diffs.len() * 99, "{what}: {close} of {} pixels within 1e-3", diffs.len());
        }
    }
}

#[test]
fn image_is_bit_identical_for_one_and_two_threads() {
    // spheres.toml (a gradient sky) and gltf-sky.toml (an environment image sampled by
    // luminance).
    for name in ["spheres.toml", "gltf-sky.toml"] {
        let scene = Scene::load(&common::scene_path(name)).unwrap();
        let device = Device::new().unwrap();
        let accel = EmbreeAccel::new(&device, &scene.geometry, BuildOptions::default()).unwrap();
        let one = render(&scene, &accel, &RenderSettings { threads: Some(1), ..settings(48, 30, 4) }).unwrap().0;
        let two = render(&scene, &accel, &RenderSettings { threads: Some(2), ..settings(48, 30, 4) }).unwrap().0;
        let again = render(&scene, &accel, &RenderSettings { threads: Some(2), ..settings(48, 30, 4) }).unwrap().0;
        assert!(
            one.pixels
                .iter()
                .zip(&two.pixels)
                .all(|(a, b)| a.to_array().map(f32::to_bits) == b.to_array().map(f32::to_bits)),
            "{name}"
        );
        assert_eq!(two, again, "{name}");
        let other_seed = render(&scene, &accel, &RenderSettings { seed: 1, ..settings(48, 30, 4) }).unwrap().0;
        assert_ne!(one, other_seed, "{name}: the seed must matter");
    }
}

#[test]
fn every_sample_scene_renders_finite() {
    for name in ["teapot.toml", "cornell.toml", "cornell-area.toml", "spheres.toml", "dof.toml", "gltf-sky.toml"] {
        let scene = Scene::load(&common::scene_path(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        let film = embree_render(&scene, &settings(32, 24, 2));
        assert!(film.pixels.iter().all(|p| p.is_finite()), "{name}");
        assert!(common::image_mean(&film.pixels) > 0.005, "{name} is black");
    }
}

#[test]
fn the_same_image_gives_the_same_exr_bytes() {
    // Many compressed blocks, so that blocks finished out of order would show.
    let (w, h) = (256u32, 256u32);
    let mut film = ember::film::Film::new(w, h);
    for (i, p) in film.pixels.iter_mut().enumerate() {
        let (x, y) = ((i as u32 % w) as f32, (i as u32 / w) as f32);
        *p = glam::Vec3::new((x * 0.37).sin().abs(), y / h as f32, (x * y * 1e-3).cos().abs());
    }
    let d = common::fresh_dir("render", "exr-bytes");
    let bytes: Vec<Vec<u8>> = (0..4)
        .map(|k| {
            let path = d.join(format!("{k}.exr"));
            film.save(&path).unwrap();
            std::fs::read(&path).unwrap()
        })
        .collect();
    assert!(bytes.iter().all(|b| *b == bytes[0]), "EXR files of one image differ");
    assert_eq!(ember::film::Film::load_exr(&d.join("0.exr")).unwrap(), film);
}

/// Two emitting 1 × 1 squares, one 5 units nearer the camera than the other, seen by an
/// orthographic camera 4 units wide at 64 × 32 pixels (a pixel is 1/16 unit): each square
/// covers exactly the 16 × 16 pixels whose edges are its own, whatever its distance, and
/// nothing else is lit (a perspective camera would show the nearer one larger).
const ORTHO_SQUARES: &str = r#"
[camera]
type = "orthographic"
position = [0.0, 0.0, 10.0]
look_at = [0.0, 0.0, 0.0]
width = 4.0

[materials.glow]
type = "emissive"
emission = [4.0, 2.0, 1.0]

[[quads]]
corner = [-1.5, -0.5, 0.0]
edge1 = [1.0, 0.0, 0.0]
edge2 = [0.0, 1.0, 0.0]
material = "glow"

[[quads]]
corner = [0.5, -0.5, 5.0]
edge1 = [1.0, 0.0, 0.0]
edge2 = [0.0, 1.0, 0.0]
material = "glow"
"#;

/// The pixels (x, y) [`ORTHO_SQUARES`] lights: x in 8..24 or 40..56, y in 8..24.
fn in_ortho_squares(x: u32, y: u32) -> bool {
    ((8..24).contains(&x) || (40..56).contains(&x)) && (8..24).contains(&y)
}

#[test]
fn an_orthographic_camera_sees_a_square_at_its_size_whatever_its_distance() {
    let scene = Scene::load(&common::write_scene("render", "ortho.toml", ORTHO_SQUARES)).unwrap();
    assert!(scene.camera(2.0).is_orthographic());
    let s = RenderSettings { max_depth: 0, ..settings(64, 32, 4) };
    let film = embree_render(&scene, &s);
    for y in 0..32 {
        for x in 0..64 {
            let expected = if in_ortho_squares(x, y) { Vec3::new(4.0, 2.0, 1.0) } else { Vec3::ZERO };
            assert_eq!(film.get(x, y), expected, "pixel ({x}, {y})");
        }
    }
    // The camera stage traces a pixel's samples as one packet of eight origins: the general
    // kernel (one ray at a time through `Camera::ray`) gives the same bits, and so does the
    // naive accelerator.
    let general = embree_render(&scene, &RenderSettings { specialize: false, ..s.clone() });
    assert_eq!(general, film);
    assert_eq!(common::render_naive(&scene, &s).0, film);
}

#[test]
fn a_sample_clamp_scales_bright_samples_down_to_it_keeping_their_hue() {
    // The squares' radiance (4, 2, 1), clamped at 2: (2, 1, 0.5), exactly; darker samples
    // are untouched.
    let scene = Scene::load(&common::write_scene("render", "ortho.toml", ORTHO_SQUARES)).unwrap();
    let s = RenderSettings { max_depth: 0, ..settings(64, 32, 4) };
    let (film, stats) = common::render_embree(&scene, &RenderSettings { clamp: Some(2.0), ..s.clone() });
    let lit = (0..32).flat_map(|y| (0..64).map(move |x| (x, y))).filter(|&(x, y)| in_ortho_squares(x, y)).count();
    assert_eq!(stats.clamped, lit as u64 * 4, "every sample of a lit pixel is clamped, no other");
    for y in 0..32 {
        for x in 0..64 {
            let expected = if in_ortho_squares(x, y) { Vec3::new(2.0, 1.0, 0.5) } else { Vec3::ZERO };
            assert_eq!(film.get(x, y), expected, "pixel ({x}, {y})");
        }
    }
    // Above the brightest sample, a clamp changes nothing.
    let (above, stats) = common::render_embree(&scene, &RenderSettings { clamp: Some(4.0), ..s.clone() });
    assert_eq!(stats.clamped, 0);
    assert_eq!(above, embree_render(&scene, &s));
}

//! A side-by-side picture of what the denoiser does: a scene at N spp as rendered (noisy),
//! the same render denoised, and a high-spp reference, each captioned with its error against
//! the reference (relMSE and mean FLIP, as `ember converge` measures them).
//!
//!     cargo run --release --example denoise_comparison -- SCENE OUT.png \
//!         [--width 320] [--height 240] [--spp 16] [--reference-spp 4096] [--reference REF.exr] \
//!         [--save-reference REF.exr] [--aux-mode prefilter] [--aux-panels] [--flip-maps] [--scale 1]
//!
//! The noisy render uses seed 1, the reference seed 0 (no shared random numbers). With
//! `--aux-panels` the albedo and normal images the denoiser was given are shown too (normals
//! mapped from [-1, 1] to [0, 1]); with `--flip-maps`, FLIP's error maps of the noisy and the
//! denoised image (black: no difference, yellow: the largest); `--scale K` shows each pixel as
//! K x K. Captions are drawn with DejaVu Sans (as the plots are).

use ember::accel::AccelKind;
use ember::film::{AuxMode, Film, denoise};
use ember::integrator::{RenderControl, RenderPlan, RenderSettings, render_controlled};
use ember::oidn::Denoiser;
use ember::scene::Scene;
use ember::tools::converge::image_difference;
use glam::Vec3;
use plotters::prelude::*;
use std::path::PathBuf;

const CAPTION_HEIGHT: u32 = 40;
const GAP: u32 = 4;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let flag = |name: &str| args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).cloned();
    let positional: Vec<&String> = {
        let mut v = Vec::new();
        let mut i = 0;
        while i < args.len() {
            if args[i].starts_with("--") {
                i += if args[i] == "--aux-panels" || args[i] == "--flip-maps" { 1 } else { 2 };
            } else {
                v.push(&args[i]);
                i += 1;
            }
        }
        v
    };
    let [scene_path, out] = positional[..] else {
        eprintln!(
            "usage: denoise_comparison SCENE OUT.png [--width W] [--height H] [--spp N] [--reference-spp M] [--reference REF.exr] [--save-reference REF.exr] [--aux-mode MODE] [--aux-panels] [--flip-maps] [--scale K]"
        );
        std::process::exit(2);
    };
    let num = |name: &str, default: u32| flag(name).map_or(default, |v| v.parse().expect(name));
    let (width, height, spp) = (num("--width", 320), num("--height", 240), num("--spp", 16));
    let reference_spp = num("--reference-spp", 4096);
    let mode: AuxMode = flag("--aux-mode").map_or(AuxMode::DEFAULT, |m| m.parse().expect("--aux-mode"));
    let aux_panels = args.iter().any(|a| a == "--aux-panels");
    let flip_maps = args.iter().any(|a| a == "--flip-maps");

    let scene = Scene::load(std::path::Path::new(scene_path)).unwrap_or_else(|e| panic!("{e}"));
    let accel = AccelKind::Embree.build(&scene.geometry).expect("Embree");
    let base = RenderSettings { width, height, ..RenderSettings::from_scene(&scene.render) };
    let render = |settings: RenderSettings| {
        let plan = RenderPlan::new(&scene, &settings);
        render_controlled(&scene, accel.as_ref(), &plan, RenderControl::default()).expect("render")
    };

    let reference = match flag("--reference") {
        Some(p) => Film::load_exr(&PathBuf::from(p)).expect("reference"),
        None => {
            let r = render(RenderSettings { spp: reference_spp, seed: 0, ..base.clone() });
            eprintln!("reference: {reference_spp} spp in {:.1} s", r.stats.elapsed.as_secs_f64());
            r.accum.film()
        }
    };
    if let Some(p) = flag("--save-reference") {
        reference.save(&PathBuf::from(p)).expect("save reference");
    }
    let noisy = render(RenderSettings { spp, seed: 1, aux: true, ..base.clone() });
    let denoiser = Denoiser::new().unwrap_or_else(|e| panic!("{e}"));
    let t = std::time::Instant::now();
    let denoised = denoise(&denoiser, &noisy.accum, mode).expect("denoise");
    let denoise_s = t.elapsed().as_secs_f64();
    let noisy_film = noisy.accum.film();
    let e_noisy = image_difference(&noisy_film, &reference).unwrap();
    let e_denoised = image_difference(&denoised, &reference).unwrap();
    println!(
        "{scene_path} {width}x{height}: {spp} spp noisy: relMSE {:.4e}, FLIP {:.4}; denoised ({mode}, {denoise_s:.2} s): relMSE {:.4e}, FLIP {:.4}; render {:.2} s",
        e_noisy.rel_mse,
        e_noisy.flip,
        e_denoised.rel_mse,
        e_denoised.flip,
        noisy.stats.elapsed.as_secs_f64()
    );

    let mut panels: Vec<(Film, String)> = vec![
        (noisy_film, format!("{spp} spp: relMSE {:.3}, FLIP {:.3}", e_noisy.rel_mse, e_noisy.flip)),
        (denoised, format!("{spp} spp denoised: relMSE {:.3}, FLIP {:.3}", e_denoised.rel_mse, e_denoised.flip)),
        (reference, format!("reference, {reference_spp} spp")),
    ];
    if flip_maps {
        // FLIP's per-pixel error maps (magma: black 0, yellow 1), where a viewer sees the
        // difference from the reference.
        let reference = &panels[2].0;
        let maps: Vec<(Film, String)> = panels[..2]
            .iter()
            .zip(["noisy", "denoised"])
            .map(|((film, _), name)| (flip_map(film, reference), format!("FLIP map, {name}")))
            .collect();
        panels.extend(maps);
    }
    if aux_panels {
        let albedo = noisy.accum.albedo().unwrap();
        let mut normal = noisy.accum.normal().unwrap();
        for p in &mut normal.pixels {
            // Shown as colour: [-1, 1] → [0, 1], then undo the sRGB curve the panel applies.
            *p = (*p * 0.5 + Vec3::splat(0.5)).map(ember::film::srgb_to_linear);
        }
        panels.push((albedo, "albedo".into()));
        panels.push((normal, "normal".into()));
    }
    let scale = num("--scale", 1).max(1);
    if scale > 1 {
        // Each pixel shown as scale x scale (nearest): small renders, readable captions.
        for (film, _) in &mut panels {
            *film = magnify(film, scale);
        }
    }
    compose(&panels, width * scale, height * scale).save(out).expect("write PNG");
    eprintln!("wrote {out}");
}

/// FLIP's error map of `image` against `reference` (as `ember converge` measures it), coloured
/// with FLIP's magma scale, as a linear film for [`compose`].
fn flip_map(image: &Film, reference: &Film) -> Film {
    let rgb8 = |f: &Film| nv_flip::FlipImageRgb8::with_data(f.width, f.height, &f.to_rgb8());
    let map = nv_flip::flip(rgb8(reference), rgb8(image), ember::tools::converge::FLIP_PIXELS_PER_DEGREE);
    let bytes = map.apply_color_lut(&nv_flip::magma_lut()).to_vec();
    let pixels = bytes
        .chunks_exact(3)
        .map(|c| Vec3::from_array([c[0], c[1], c[2]].map(|b| ember::film::srgb_to_linear(b as f32 / 255.0))))
        .collect();
    Film { width: image.width, height: image.height, pixels }
}

/// `film` with each pixel repeated `k` x `k` times.
fn magnify(film: &Film, k: u32) -> Film {
    let (w, h) = (film.width * k, film.height * k);
    let pixels = (0..w * h).map(|i| film.get(i % w / k, i / w / k)).collect();
    Film { width: w, height: h, pixels }
}

/// The panels in a row, each with its caption below, on a dark background.
fn compose(panels: &[(Film, String)], width: u32, height: u32) -> image::RgbImage {
    let n = panels.len() as u32;
    let (w, h) = (n * width + (n - 1) * GAP, height + CAPTION_HEIGHT);
    let mut buf = vec![24u8; (w * h * 3) as usize];
    for (i, (film, _)) in panels.iter().enumerate() {
        let rgb = film.to_rgb8();
        let x0 = i as u32 * (width + GAP);
        for y in 0..height {
            let src = &rgb[(y * width * 3) as usize..((y + 1) * width * 3) as usize];
            let at = ((y * w + x0) * 3) as usize;
            buf[at..at + src.len()].copy_from_slice(src);
        }
    }
    let font =
        std::fs::read("/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf").expect("DejaVu Sans (fonts-dejavu-core)");
    plotters::style::register_font("sans-serif", FontStyle::Normal, Box::leak(font.into_boxed_slice()))
        .map_err(|_| "font")
        .unwrap();
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        let size = (CAPTION_HEIGHT as f64 * 0.42).min(width as f64 / 18.0);
        let style = ("sans-serif", size).into_font().color(&RGBColor(235, 235, 235));
        for (i, (_, caption)) in panels.iter().enumerate() {
            let x = (i as u32 * (width + GAP) + 6) as i32;
            root.draw(&Text::new(caption.clone(), (x, (height + CAPTION_HEIGHT / 4) as i32), style.clone()))
                .expect("caption");
        }
        root.present().expect("draw");
    }
    image::RgbImage::from_raw(w, h, buf).expect("buffer size")
}

//! A camera inside a closed sphere or capped cylinder whose inner surface is diffuse with
//! albedo 0.5 and emits 0.5: in a closed enclosure L = Le + ρL everywhere, so L = 1 in every
//! direction. Every camera ray starts inside the shape, and so does every continuation ray.
//!
//! - BSDF sampling, no Russian roulette, 40 bounces: each sample is exactly Σ 0.5^(k+1) =
//!   1 − 2⁻⁴¹, so every pixel must be 1 within float rounding (1e-5); a ray that leaks out
//!   (to the black background) or a lost bounce lowers it.
//! - The default estimator (NEE + MIS, Russian roulette): the image mean must be 1 within
//!   4 standard errors.

use super::super::pixel::grey;
use super::super::scenes::CaseSceneBuilder;
use super::{CaseRun, CheckError, Verdict, worst_abs};
use crate::integrator::RenderSettings;
use crate::material::{DiffuseMaterial, MaterialKind};
use crate::scene::Scene;
use crate::texture::Texture;
use glam::Vec3;

/// The enclosure check for `scene` (camera already inside).
pub(super) fn enclosure(run: &CaseRun, scene: &Scene) -> Result<Verdict, CheckError> {
    let (w, h, spp) = run.by_quality((24, 24, 4), (48, 48, 16));
    let exact = run.render(scene, &run.bsdf_settings(w, h, spp, 40))?;
    let worst = worst_abs(&exact, 1.0);
    let noisy = run.render(scene, &RenderSettings { max_depth: 40, ..run.settings(w, h, spp) })?;
    let vals: Vec<f64> = noisy.pixels.iter().map(|p| grey(*p)).collect();
    let n = vals.len() as f64;
    let mean = vals.iter().sum::<f64>() / n;
    let se = (vals.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / (n - 1.0) / n).sqrt();
    Ok(Verdict::new(
        worst,
        1e-5,
        "max |px − 1|",
        format!("BSDF sampling: every pixel 1; NEE+MIS: mean {mean:.4} ± {se:.4}"),
    )
    .require((mean - 1.0).abs() <= 4.0 * se + 1e-4, format!("NEE+MIS mean {mean:.4} is not 1 within 4 × {se:.4}")))
}

fn glowing(builder: &mut CaseSceneBuilder) -> u32 {
    builder.material(
        MaterialKind::Diffuse(DiffuseMaterial { color: Texture::Constant(Vec3::splat(0.5)) }),
        Vec3::splat(0.5),
    )
}

pub fn sphere(run: &CaseRun) -> Result<Verdict, CheckError> {
    let mut builder = CaseSceneBuilder::new("inside-sphere");
    let m = glowing(&mut builder);
    builder.sphere(Vec3::new(0.3, 0.2, -0.1), 2.0, m);
    builder.camera(Vec3::new(0.9, 0.5, 0.4), Vec3::new(0.0, 0.0, -1.0), Vec3::Y, 90.0);
    enclosure(run, &builder.build())
}

pub fn cylinder(run: &CaseRun) -> Result<Verdict, CheckError> {
    let mut builder = CaseSceneBuilder::new("inside-cylinder");
    let m = glowing(&mut builder);
    builder.cylinder(Vec3::new(0.2, -2.0, 0.1), Vec3::new(-0.3, 2.0, 0.4), 1.5, m);
    builder.camera(Vec3::new(0.5, -1.2, 0.3), Vec3::new(-0.5, 1.0, -0.4), Vec3::Z, 100.0);
    enclosure(run, &builder.build())
}

//! Roughness exactly 0 and exactly 1 for metal (white, F0 = 1) and plastic (white base), each
//! a sphere alone under a uniform sky of 1, rendered with the default estimator (NEE + MIS).
//!
//! - Metal at roughness 0 is a perfect mirror reflecting everything: every pixel exactly 1.
//! - The others may lose energy but never gain it: over 8 seeds (4 quick), the mean of every
//!   5 × 5 block of pixels must be at most 1 + 4 standard errors + 1%. A block's standard
//!   error pools its 25 pixels' (each from the spread of its 8 seeds), which is steady; one
//!   pixel's, from 8 or 4 values, is not: checked pixel by pixel, correct renders failed on 4
//!   of 80 seeds (40 × both sizes), at edge pixels where the sky (exactly 1) meets plastic at
//!   grazing angles (Fresnel → 1, so nearly 1 too). A plastic without the coating's Fresnel
//!   loss on its diffuse part (which gains up to 100% at grazing angles) fails by a wide
//!   margin.
//! - Metal at roughness 1, seen head-on, reflects 1 − ln 2 ≈ 0.3069 (the single-scattering
//!   albedo of GGX with α = 1 at normal incidence, see `src/material/conductor.rs`): the
//!   3 × 3 pixels at the centre must hold that within 4 standard errors + 1%.

use super::super::pixel::{blocks, grey};
use super::super::scenes::CaseSceneBuilder;
use super::{CaseRun, CheckError, Verdict, worst_abs};
use crate::film::Film;
use crate::integrator::RenderSettings;
use crate::light::Background;
use crate::material::{MaterialKind, MetalMaterial, PlasticMaterial};
use crate::scene::Scene;
use crate::texture::Texture;
use glam::Vec3;

fn sphere(kind: MaterialKind) -> Scene {
    let mut builder = CaseSceneBuilder::new("roughness");
    let m = builder.material(kind, Vec3::ZERO);
    builder.sphere(Vec3::new(0.1, -0.2, 0.3), 1.0, m);
    builder.background(Background::Constant(Vec3::ONE));
    builder.camera(Vec3::new(0.1, -0.2, 4.3), Vec3::new(0.1, -0.2, 0.3), Vec3::Y, 35.0);
    builder.build()
}

pub fn check(run: &CaseRun) -> Result<Verdict, CheckError> {
    let white = || Texture::Constant(Vec3::ONE);
    let (w, h, spp, seeds) = run.by_quality((25, 25, 8, 4), (45, 45, 16, 8));
    let s = RenderSettings { max_depth: 2, ..run.settings(w, h, spp) };
    let mirror = run.render(&sphere(MaterialKind::Metal(MetalMaterial { color: white(), roughness: 0.0 })), &s)?;
    let mirror_err = worst_abs(&mirror, 1.0);
    let mut v = Verdict::new(mirror_err, 1e-4, "max |px − 1|", "metal r=0: every pixel 1");
    let bounded = [
        ("metal r=1", MaterialKind::Metal(MetalMaterial { color: white(), roughness: 1.0 })),
        ("plastic r=0", MaterialKind::Plastic(PlasticMaterial { color: white(), roughness: 0.0 })),
        ("plastic r=1", MaterialKind::Plastic(PlasticMaterial { color: white(), roughness: 1.0 })),
    ];
    for (i, (name, kind)) in bounded.into_iter().enumerate() {
        let (mean, se) = run.render_seeds(&sphere(kind), &s, seeds)?;
        let (worst, (x, y), block_mean) = worst_block_excess(&mean, &se);
        v.detail.push_str(&format!("; {name}: max (block − 1)/(4SE + 1%) = {worst:.2}"));
        v = v.require(worst <= 1.0, format!("{name} gains energy: the 5 × 5 block at ({x}, {y}) = {block_mean:.4}"));
        if i == 0 {
            // The 3 × 3 pixels at the centre (normals within ~6° of the view at the quick
            // size, where they reflect 0.4% more than head-on), whose standard error pools 9
            // pixels' estimates: one pixel's, from 4 seeds, can be several times too small.
            let centre: Vec<usize> = (0..9).map(|k| ((h / 2 + k / 3 - 1) * w + w / 2 + k % 3 - 1) as usize).collect();
            let got = centre.iter().map(|&c| grey(mean.pixels[c])).sum::<f64>() / 9.0;
            let se_centre = centre.iter().map(|&c| se[c] * se[c]).sum::<f64>().sqrt() / 9.0;
            let want = 1.0 - std::f64::consts::LN_2;
            v.detail.push_str(&format!(", centre {got:.4} (1 − ln 2 = {want:.4})"));
            v = v.require(
                (got - want).abs() <= 4.0 * se_centre + 0.01 * want,
                format!("metal r=1 head-on reflects {got:.4}, want 1 − ln 2 = {want:.4}"),
            );
        }
    }
    Ok(v)
}

/// Side of the pixel blocks whose mean must not exceed 1 (the images are 25 and 45 wide).
const BLOCK: u32 = 5;

/// Over `BLOCK` × `BLOCK` blocks of `mean` (per-pixel standard errors `se`) other than those
/// exactly 1 without noise: the largest (block mean − 1) / (4 SE + 1%), the block's top-left
/// pixel, and its mean.
fn worst_block_excess(mean: &Film, se: &[f64]) -> (f64, (u32, u32), f64) {
    let mut worst = (f64::NEG_INFINITY, (0, 0), 0.0);
    for (corner, pixels) in blocks(mean.width, mean.height, BLOCK) {
        let n = pixels.len() as f64;
        let m = pixels.iter().map(|&i| grey(mean.pixels[i])).sum::<f64>() / n;
        let block_se = pixels.iter().map(|&i| se[i] * se[i]).sum::<f64>().sqrt() / n;
        let excess = (m - 1.0) / (4.0 * block_se + 0.01);
        // Blocks of sky alone (exactly 1, no noise) are left out, so the figure reported is
        // the sphere's margin.
        if (m != 1.0 || block_se != 0.0) && excess > worst.0 {
            worst = (excess, corner, m);
        }
    }
    worst
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_block_over_1_by_more_than_its_noise_is_found() {
        let mut film = Film::new(10, 5);
        film.pixels.iter_mut().for_each(|p| *p = Vec3::splat(0.9));
        // One pixel far above 1 in the right-hand block: its mean is 0.9 + 0.5/25 = 0.92.
        film.pixels[7] = Vec3::splat(1.4);
        let se = vec![0.0; 50];
        let (worst, at, m) = worst_block_excess(&film, &se);
        assert_eq!(at, (5, 0));
        assert!((m - 0.92).abs() < 1e-6 && worst < 0.0, "{worst} {m}");
        // The whole right-hand block at 1.03, with standard errors of 0.02 per pixel
        // (0.004 for the block): (1.03 − 1) / (4 · 0.004 + 0.01) = 1.15.
        for y in 0..5 {
            for x in 5..10 {
                film.pixels[y * 10 + x] = Vec3::splat(1.03);
            }
        }
        let (worst, at, _) = worst_block_excess(&film, &vec![0.02; 50]);
        assert_eq!(at, (5, 0));
        assert!((worst - 0.03 / 0.026).abs() < 1e-3, "{worst}");
    }
}

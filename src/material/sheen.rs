//! The sheen of glTF's `KHR_materials_sheen`: back-scattering fibres (velvet, cloth), as the
//! extension defines it. The lobe is `colour × D(θh) × V`, with the "Charlie" distribution of
//! A. Conty Estevez and C. Kulla ("Production Friendly Microfacet Sheen BRDF", 2017),
//! D = (2 + 1/α) sin(θh)^(1/α) / 2π with α = roughness², and the same paper's visibility,
//! V = 1 / ((1 + Λ(cos θo) + Λ(cos θi)) 4 cos θo cos θi), Λ from its published fit (the
//! extension's first choice; D. Neubelt and M. Pettineo's cheaper 1 / (4 (cos θi + cos θo −
//! cos θi cos θo)) brightens the rim far more than Blender Cycles' sheen). The layers under it keep
//! 1 − max(colour) E(μo) of the light, E being the lobe's directional albedo for a white
//! colour (albedo scaling, as the extension suggests), tabulated here once.

use glam::Vec3;
use rayon::prelude::*;
use std::f32::consts::PI;
use std::sync::OnceLock;

/// The narrowest width used: rougher than this the lobe is finite and the table smooth.
const ALPHA_MIN: f32 = 0.01;
/// Table resolution in cos θo and in roughness (both 0 to 1 inclusive).
const N: usize = 32;
/// Stratified quadrature per side, over (cos θi, φi).
const STRATA: usize = 48;

/// The sheen lobe's width for a glTF sheen roughness.
#[inline]
pub(super) fn alpha_of(roughness: f32) -> f32 {
    let r = if roughness.is_nan() { 0.0 } else { roughness.clamp(0.0, 1.0) };
    (r * r).max(ALPHA_MIN)
}

/// f(wo, wi) of a white sheen of width `alpha`, for directions above the surface (local
/// frame, z the normal).
#[inline]
pub(super) fn eval(wo: Vec3, wi: Vec3, alpha: f32) -> f32 {
    let Some(wm) = (wo + wi).try_normalize() else { return 0.0 };
    let sin2 = (1.0 - wm.z * wm.z).max(0.0);
    let d = (2.0 + 1.0 / alpha) * sin2.powf(0.5 / alpha) / (2.0 * PI);
    let (ci, co) = (wi.z.max(1e-4), wo.z.max(1e-4));
    let v = 1.0 / ((1.0 + lambda(co, alpha) + lambda(ci, alpha)) * 4.0 * co * ci);
    d * v
}

/// The fit L(x) = a / (1 + b x^c) + d x + e of Conty Estevez and Kulla, its coefficients
/// blended between those published for α = 0 and α = 1 by (1 − α)².
#[inline]
fn fit(x: f32, alpha: f32) -> f32 {
    const AT_0: [f32; 5] = [25.3245, 3.32435, 0.16801, -1.27393, -4.85967];
    const AT_1: [f32; 5] = [21.5473, 3.82987, 0.19823, -1.97760, -4.32054];
    let t = (1.0 - alpha) * (1.0 - alpha);
    let p: [f32; 5] = std::array::from_fn(|k| AT_1[k] + (AT_0[k] - AT_1[k]) * t);
    p[0] / (1.0 + p[1] * x.powf(p[2])) + p[3] * x + p[4]
}

/// The sheen's Λ at cos θ = `c`.
#[inline]
fn lambda(c: f32, alpha: f32) -> f32 {
    if c < 0.5 { fit(c, alpha).exp() } else { (2.0 * fit(0.5, alpha) - fit(1.0 - c, alpha)).exp() }
}

fn table() -> &'static [f32] {
    static TABLE: OnceLock<Vec<f32>> = OnceLock::new();
    TABLE.get_or_init(|| {
        (0..N * N)
            .into_par_iter()
            .map(|k| {
                let (i, j) = (k / N, k % N);
                let mu = (i as f32 / (N - 1) as f32).max(1e-3);
                let alpha = alpha_of(j as f32 / (N - 1) as f32);
                let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
                let mut sum = 0.0f64;
                for a in 0..STRATA {
                    for b in 0..STRATA {
                        // Midpoints of an area-preserving grid: uniform in cos θi and φi.
                        let z = (a as f32 + 0.5) / STRATA as f32;
                        let phi = 2.0 * PI * (b as f32 + 0.5) / STRATA as f32;
                        let r = (1.0 - z * z).sqrt();
                        let wi = Vec3::new(r * phi.cos(), r * phi.sin(), z);
                        sum += (eval(wo, wi, alpha) * z) as f64;
                    }
                }
                (sum * 2.0 * PI as f64 / (STRATA * STRATA) as f64) as f32
            })
            .collect()
    })
}

/// The directional albedo of a white sheen lobe of glTF roughness `roughness` at cos θo =
/// `mu` (bilinear in the table).
pub(super) fn albedo(mu: f32, roughness: f32) -> f32 {
    let t = table();
    let at = |x: f32| {
        let x = x.clamp(0.0, 1.0) * (N - 1) as f32;
        let i = (x as usize).min(N - 2);
        (i, x - i as f32)
    };
    let ((i, fi), (j, fj)) = (at(mu), at(roughness));
    let e = |i: usize, j: usize| t[i * N + j];
    let a = e(i, j) + (e(i, j + 1) - e(i, j)) * fj;
    let b = e(i + 1, j) + (e(i + 1, j + 1) - e(i + 1, j)) * fj;
    (a + (b - a) * fi).clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_albedo_is_a_fraction_that_grows_toward_grazing_views() {
        for r in [0.0f32, 0.3, 0.6, 1.0] {
            let (head_on, grazing) = (albedo(1.0, r), albedo(0.1, r));
            assert!(head_on > 0.0 && head_on < 1.0 && grazing < 1.0, "r={r}: {head_on} {grazing}");
            assert!(grazing > head_on, "r={r}: fibres shine toward the rim: {head_on} {grazing}");
        }
        // The lobe is symmetric in its two directions.
        let (a, b) = (Vec3::new(0.6, 0.0, 0.8), Vec3::new(-0.28, 0.96, 0.0).normalize() * 0.5 + Vec3::Z * 0.5);
        let b = b.normalize();
        assert!((eval(a, b, 0.25) - eval(b, a, 0.25)).abs() < 1e-6);
    }
}

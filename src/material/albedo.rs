//! Directional albedo of GGX reflection, tabulated once: what fraction of light arriving at
//! cos θo = μ a single-scattering GGX lobe of width α sends back, with a Fresnel of 1
//! ([`ggx_albedo`]) or the exact dielectric Fresnel of an index η ([`dielectric_albedo`]).
//!
//! The glTF material ([`super::pbr`]) uses them twice, as Blender Cycles' Principled BSDF
//! does: to put back the energy single scattering loses (the multiple-scattering
//! compensation of E. Turquin, "Practical multiple scattering compensation for microfacet
//! models", 2019: the lobe times 1 + F0 (1 − E(μo)) / E(μo)), and to give the diffuse base
//! the light the specular layer leaves it (1 − E_spec(μo): albedo scaling).
//!
//! Each entry is the mean of f cos θi / pdf over 16×16 stratified visible-normal samples,
//! computed with the very `Ggx` terms the BSDFs use (`microfacet.rs`); a table is built the
//! first time it is needed (a few tens of milliseconds) and is the same in every run.

use super::fresnel::fresnel_dielectric;
use super::microfacet::Ggx;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::sync::OnceLock;

/// Table resolution in cos θo and in α (both from 0 to 1 inclusive).
const N: usize = 32;
/// Table resolution in t = √F0 of the dielectric (from 0 to [`T_MAX`] inclusive).
const NT: usize = 16;
/// The largest √F0 tabulated: F0 = 0.36, η = 4. Larger indices read the last entry.
const T_MAX: f32 = 0.6;
/// Samples per side of the stratified grid of each entry.
const STRATA: usize = 16;

struct Tables {
    /// `[μ][α]`, Fresnel 1.
    ggx: Vec<f32>,
    /// `[t][μ][α]`, exact dielectric Fresnel of index η(t) = (1 + t) / (1 − t).
    dielectric: Vec<f32>,
}

fn tables() -> &'static Tables {
    static TABLES: OnceLock<Tables> = OnceLock::new();
    TABLES.get_or_init(|| {
        let entry = |k: usize, fresnel: Option<f32>| {
            let (i, j) = (k / N, k % N);
            albedo(grid(i, N, 1.0), grid(j, N, 1.0), fresnel)
        };
        let ggx = (0..N * N).into_par_iter().map(|k| entry(k, None)).collect();
        let dielectric = (0..NT * N * N)
            .into_par_iter()
            .map(|k| entry(k % (N * N), Some(eta_of(grid(k / (N * N), NT, T_MAX)))))
            .collect();
        Tables { ggx, dielectric }
    })
}

/// The `i`-th of `n` grid points from 0 to `max`.
fn grid(i: usize, n: usize, max: f32) -> f32 {
    max * i as f32 / (n - 1) as f32
}

/// The index of refraction whose normal-incidence reflectance is t².
fn eta_of(t: f32) -> f32 {
    (1.0 + t) / (1.0 - t)
}

/// The directional albedo at cos θo = `mu` of GGX of width `alpha` with Fresnel 1 (`None`)
/// or the exact dielectric Fresnel of index `eta`.
fn albedo(mu: f32, alpha: f32, eta: Option<f32>) -> f32 {
    let f = |c: f32| eta.map_or(1.0, |eta| fresnel_dielectric(c, eta));
    let mu = mu.max(1e-3);
    let wo = Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
    let ggx = Ggx::from_alpha(alpha);
    if ggx.is_smooth() {
        return f(mu);
    }
    let mut sum = 0.0f64;
    for a in 0..STRATA {
        for b in 0..STRATA {
            let u = Vec2::new((a as f32 + 0.5) / STRATA as f32, (b as f32 + 0.5) / STRATA as f32);
            let wm = ggx.sample_visible_normal(wo, u);
            let wi = 2.0 * wo.dot(wm) * wm - wo;
            if wi.z <= 0.0 {
                continue;
            }
            let pdf = ggx.reflection_pdf(wo, wm);
            if pdf > 0.0 {
                sum += (f(wo.dot(wm)) * ggx.d(wm) * ggx.visibility(wo, wi) * wi.z / pdf) as f64;
            }
        }
    }
    (sum / (STRATA * STRATA) as f64) as f32
}

/// Linear interpolation weights of `x` in a grid of `n` points over [0, max]: (index, t).
fn locate(x: f32, n: usize, max: f32) -> (usize, f32) {
    let s = (x / max).clamp(0.0, 1.0) * (n - 1) as f32;
    let i = (s as usize).min(n - 2);
    (i, s - i as f32)
}

/// Bilinear lookup in a `[μ][α]` table.
fn lookup2(table: &[f32], mu: f32, alpha: f32) -> f32 {
    let (i, s) = locate(mu, N, 1.0);
    let (j, t) = locate(alpha, N, 1.0);
    let at = |i: usize, j: usize| table[i * N + j];
    let lo = at(i, j) + (at(i, j + 1) - at(i, j)) * t;
    let hi = at(i + 1, j) + (at(i + 1, j + 1) - at(i + 1, j)) * t;
    lo + (hi - lo) * s
}

/// The directional albedo of single-scattering GGX of width `alpha` with Fresnel 1, at
/// cos θo = `mu`: 1 for a smooth surface, about 0.69 at α = 1 and normal incidence.
pub(super) fn ggx_albedo(mu: f32, alpha: f32) -> f32 {
    lookup2(&tables().ggx, mu, alpha)
}

/// The directional albedo of single-scattering GGX of width `alpha` with the exact
/// dielectric Fresnel of index `eta` (> 1), at cos θo = `mu`.
pub(super) fn dielectric_albedo(mu: f32, alpha: f32, eta: f32) -> f32 {
    let t = ((eta - 1.0) / (eta + 1.0)).max(0.0);
    let (k, w) = locate(t, NT, T_MAX);
    let table = &tables().dielectric;
    let a = lookup2(&table[k * N * N..(k + 1) * N * N], mu, alpha);
    let b = lookup2(&table[(k + 1) * N * N..(k + 2) * N * N], mu, alpha);
    a + (b - a) * w
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn smooth_and_rough_ends_have_their_known_values() {
        // A smooth lobe reflects everything (Fresnel 1) or exactly the Fresnel reflectance.
        assert_eq!(ggx_albedo(0.7, 0.0), 1.0);
        assert!((dielectric_albedo(1.0, 0.0, 1.5) - 0.04).abs() < 1e-4);
        // Single scattering loses energy with roughness.
        let (a, b, c) = (ggx_albedo(1.0, 0.1), ggx_albedo(1.0, 0.5), ggx_albedo(1.0, 1.0));
        assert!(a > 0.99 && b < a && c < b, "{a} {b} {c}");
        // At α = 1 and normal incidence: 1 − ln 2 (derived in tests/materials.rs).
        assert!((c - (1.0 - std::f32::consts::LN_2)).abs() < 0.005, "{c}");
        // A dielectric reflects less than a Fresnel-1 lobe, more at a larger index.
        for mu in [0.2, 0.6, 1.0] {
            let d = dielectric_albedo(mu, 0.3, 1.5);
            assert!(d > 0.0 && d < ggx_albedo(mu, 0.3), "{mu}: {d}");
            assert!(dielectric_albedo(mu, 0.3, 2.0) > d);
        }
    }

    #[test]
    fn lookups_interpolate_between_entries() {
        // At a grid point the lookup is the entry; between two it lies between them.
        let (mu0, mu1) = (grid(10, N, 1.0), grid(11, N, 1.0));
        let (e0, e1) = (albedo(mu0, 0.5, None), albedo(mu1, 0.5, None));
        let alpha = grid(16, N, 1.0);
        assert!((ggx_albedo(mu0, alpha) - albedo(mu0, alpha, None)).abs() < 1e-6);
        let mid = ggx_albedo(0.5 * (mu0 + mu1), 0.5);
        assert!(mid >= e0.min(e1) - 1e-3 && mid <= e0.max(e1) + 1e-3, "{e0} {mid} {e1}");
    }
}

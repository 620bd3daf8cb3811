//! The GGX (Trowbridge-Reitz) microfacet distribution, isotropic.
//!
//! - Normal distribution D and Smith Λ: B. Walter, S. Marschner, H. Li, K. Torrance,
//!   "Microfacet Models for Refraction through Rough Surfaces", EGSR 2007.
//! - Masking-shadowing: the **height-correlated** Smith G2 = 1 / (1 + Λ(wo) + Λ(wi)) of
//!   E. Heitz, "Understanding the Masking-Shadowing Function in Microfacet-Based BRDFs",
//!   JCGT 3(2), 2014.
//! - Sampling: the distribution of visible normals, E. Heitz, "Sampling the GGX Distribution
//!   of Visible Normals", JCGT 7(4), 2018.
//!
//! All terms are written so that no cosine is ever divided by: with
//! s(w) = √(cos²θ + α² sin²θ) we have Λ(w) = (s/|cos θ| − 1)/2, hence
//! G1(w) = 2|cos θ| / (|cos θ| + s(w)) and
//! G2 / (4 |cos θo| |cos θi|) = 1 / (2 (|cos θo| s(wi) + |cos θi| s(wo))).

use std::f32::consts::PI;

use glam::{Vec2, Vec3};

/// Below this alpha the surface is treated as perfectly smooth (a delta lobe).
pub(super) const MIN_ALPHA: f32 = 1e-3;

/// An isotropic GGX distribution with width `alpha`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Ggx {
    alpha: f32,
}

impl Ggx {
    /// alpha = roughness², roughness clamped to [0, 1] (NaN counts as 0).
    pub(super) fn from_roughness(roughness: f32) -> Self {
        let r = if roughness.is_nan() { 0.0 } else { roughness.clamp(0.0, 1.0) };
        Ggx { alpha: r * r }
    }

    /// The distribution of width `alpha` (NaN counts as 0; at most 1).
    pub(super) fn from_alpha(alpha: f32) -> Self {
        Ggx { alpha: if alpha.is_nan() { 0.0 } else { alpha.clamp(0.0, 1.0) } }
    }

    /// Its width α.
    pub(super) fn alpha(&self) -> f32 {
        self.alpha
    }

    /// True if the distribution is too narrow to be sampled: use a mirror instead.
    pub(super) fn is_smooth(&self) -> bool {
        self.alpha < MIN_ALPHA
    }

    /// D(wm): microfacet normal density, normalised so that ∫ D(wm) cos θm dwm = 1.
    /// Written as 1 / (π α² (x²/α² + y²/α² + z²)²), bounded by 1/(π α²) for α ≤ 1.
    pub(super) fn d(&self, wm: Vec3) -> f32 {
        if wm.z <= 0.0 {
            return 0.0;
        }
        let a2 = self.alpha * self.alpha;
        let t = (wm.x * wm.x + wm.y * wm.y) / a2 + wm.z * wm.z;
        1.0 / (PI * a2 * t * t)
    }

    /// s(w) = √(cos²θ + α² sin²θ) = |cos θ| (1 + 2Λ(w)).
    fn s(&self, w: Vec3) -> f32 {
        let a2 = self.alpha * self.alpha;
        (w.z * w.z + a2 * (w.x * w.x + w.y * w.y)).sqrt()
    }

    /// Smith masking G1(w) = 1 / (1 + Λ(w)).
    #[cfg(test)]
    pub(super) fn g1(&self, w: Vec3) -> f32 {
        let c = w.z.abs();
        2.0 * c / (c + self.s(w))
    }

    /// The height-correlated G2(wo, wi) / (4 |cos θo| |cos θi|), i.e. the factor such that the
    /// single-scattering BRDF is D · F · visibility. Requires wo.z, wi.z ≠ 0.
    pub(super) fn visibility(&self, wo: Vec3, wi: Vec3) -> f32 {
        0.5 / (wo.z.abs() * self.s(wi) + wi.z.abs() * self.s(wo))
    }

    /// Solid-angle pdf of wi = reflect(wo, wm) when wm is drawn by
    /// [`sample_visible_normal`](Self::sample_visible_normal):
    /// D_wo(wm) / (4 wo·wm) with D_wo(wm) = G1(wo) (wo·wm) D(wm) / cos θo, which simplifies to
    /// D(wm) / (2 (cos θo + s(wo))). Requires wo.z > 0 and wo·wm > 0.
    pub(super) fn reflection_pdf(&self, wo: Vec3, wm: Vec3) -> f32 {
        self.d(wm) / (2.0 * (wo.z + self.s(wo)))
    }

    /// Draws a microfacet normal from the distribution of normals visible from `wo`
    /// (wo.z > 0), with density D_wo(wm) = G1(wo) max(0, wo·wm) D(wm) / cos θo.
    /// Heitz 2018, listing 1 (isotropic case).
    pub(super) fn sample_visible_normal(&self, wo: Vec3, u: Vec2) -> Vec3 {
        let a = self.alpha;
        // Stretch the view direction to the hemisphere configuration (α = 1).
        let vh = Vec3::new(a * wo.x, a * wo.y, wo.z).normalize();
        // Orthonormal basis around vh (any tangent if vh is the pole).
        let t1 = Vec3::new(-vh.y, vh.x, 0.0).try_normalize().unwrap_or(Vec3::X);
        let t2 = vh.cross(t1);
        // Uniform point on the projected disk, warped to the visible half.
        let r = u.x.sqrt();
        let (sin_phi, cos_phi) = (2.0 * PI * u.y).sin_cos();
        let p1 = r * cos_phi;
        let s = 0.5 * (1.0 + vh.z);
        let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * r * sin_phi;
        // Reproject onto the hemisphere, then unstretch. |nh| = 1 and α ≥ MIN_ALPHA, so the
        // vector below has length ≥ α and normalising is safe.
        let nh = p1 * t1 + p2 * t2 + (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt() * vh;
        Vec3::new(a * nh.x, a * nh.y, nh.z.max(0.0)).normalize()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Midpoint-rule integral of `g` over the upper hemisphere in (θ, φ), dω = sin θ dθ dφ.
    /// Uniform steps in θ resolve the narrow peak around the normal at low roughness.
    fn hemisphere_integral(g: impl Fn(Vec3) -> f64) -> f64 {
        let (n_theta, n_phi) = (2000, 400);
        let d_theta = std::f64::consts::FRAC_PI_2 / n_theta as f64;
        let d_phi = 2.0 * std::f64::consts::PI / n_phi as f64;
        let mut sum = 0.0;
        for i in 0..n_theta {
            let theta = (i as f64 + 0.5) * d_theta;
            let (sin_t, cos_t) = theta.sin_cos();
            for j in 0..n_phi {
                let (sin_p, cos_p) = ((j as f64 + 0.5) * d_phi).sin_cos();
                let w = Vec3::new((sin_t * cos_p) as f32, (sin_t * sin_p) as f32, cos_t as f32);
                sum += g(w) * sin_t;
            }
        }
        sum * d_theta * d_phi
    }

    #[test]
    fn projected_microfacet_area_is_one() {
        // ∫ D(wm) cos θm dwm = 1 (Walter et al. 2007, eq. 4).
        for roughness in [0.3f32, 0.6, 1.0] {
            let ggx = Ggx::from_roughness(roughness);
            let area = hemisphere_integral(|wm| (ggx.d(wm) * wm.z) as f64);
            assert!((area - 1.0).abs() < 2e-3, "roughness {roughness}: {area}");
        }
    }

    #[test]
    fn visible_normals_are_normalised() {
        // ∫ G1(wo) max(0, wo·wm) D(wm) / cos θo dwm = 1 (Heitz 2014, eq. 2): checks Λ against D.
        for roughness in [0.3f32, 0.6, 1.0] {
            let ggx = Ggx::from_roughness(roughness);
            for theta in [0.0f32, 1.0, 1.4] {
                let wo = Vec3::new(theta.sin(), 0.0, theta.cos());
                let g1 = ggx.g1(wo);
                let total = hemisphere_integral(|wm| (g1 * wo.dot(wm).max(0.0) * ggx.d(wm) / wo.z) as f64);
                assert!((total - 1.0).abs() < 2e-3, "roughness {roughness}, θ {theta}: {total}");
            }
        }
    }

    #[test]
    fn visible_normals_face_the_viewer() {
        let ggx = Ggx::from_roughness(0.8);
        let wo = Vec3::new(0.9, 0.1, 0.1).normalize();
        for i in 0..64 {
            for j in 0..64 {
                let u = Vec2::new(i as f32 / 64.0, j as f32 / 64.0);
                let wm = ggx.sample_visible_normal(wo, u);
                assert!((wm.length() - 1.0).abs() < 1e-5);
                assert!(wm.z >= 0.0 && wo.dot(wm) > -1e-5, "{wm}");
            }
        }
    }
}

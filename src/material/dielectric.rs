//! Smooth glass: a delta reflection and a delta refraction weighted by the exact dielectric
//! Fresnel reflectance (pbrt 4th ed., §9.5 `DielectricBxDF`, smooth case).
//!
//! The lobe is chosen with probability F (reflect) or 1 − F (refract), so every sample carries
//! the throughput 1 (reflection) or `tint` (refraction). Refraction does *not* apply the
//! 1/η² radiance compression: it cancels for light that enters and leaves a closed object,
//! and omitting it keeps reflection + transmission = 1 (no energy bookkeeping across media).

use glam::{Vec2, Vec3};

use super::fresnel::{fresnel_dielectric, refracted_cos};
use super::{BsdfModel, BsdfSample, Lobes, MIN_COS, MaterialModel, coated, reflect_z};
use crate::hash::Fingerprint;
use crate::texture::TexCoords;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dielectric {
    /// IOR inside / outside (outside is the side +Z points to).
    ior: f32,
    tint: Vec3,
}

impl Dielectric {
    /// A non-positive or non-finite `ior` is replaced by 1 (no interface).
    pub fn new(ior: f32, tint: Vec3) -> Self {
        let ior = if ior.is_finite() && ior > 0.0 { ior } else { 1.0 };
        Dielectric { ior, tint }
    }
}

impl BsdfModel for Dielectric {
    /// Only delta lobes: nothing to evaluate.
    fn eval(&self, _wo: Vec3, _wi: Vec3) -> Vec3 {
        Vec3::ZERO
    }

    fn pdf(&self, _wo: Vec3, _wi: Vec3) -> f32 {
        0.0
    }

    /// Reflection or refraction.
    #[inline(always)]
    fn chooses_lobe(&self) -> bool {
        true
    }

    fn is_delta(&self) -> bool {
        true
    }

    fn is_transmissive(&self) -> bool {
        true
    }

    /// (η on `wo`'s side / η on `wi`'s side)² across the interface, 1 for a reflection.
    fn light_path_scale(&self, wo: Vec3, wi: Vec3) -> f32 {
        match (wo.z > 0.0, wi.z > 0.0) {
            (true, false) => 1.0 / (self.ior * self.ior),
            (false, true) => self.ior * self.ior,
            _ => 1.0,
        }
    }

    /// 1: renders follow glass to the surface seen through it; this is used only where a
    /// path ends on glass.
    fn denoise_albedo(&self) -> Vec3 {
        Vec3::ONE
    }

    /// Picks reflection with probability F(wo), else refraction. `uc` in [0, 1).
    fn sample(&self, wo: Vec3, _u: Vec2, uc: f32) -> Option<BsdfSample> {
        if wo.z.abs() <= MIN_COS {
            return None;
        }
        let fr = fresnel_dielectric(wo.z, self.ior);
        if uc < fr {
            let wi = reflect_z(wo);
            let f = Vec3::splat(fr / wi.z.abs());
            return Some(BsdfSample { wi, f, pdf: fr, delta: true });
        }
        // fr < 1 here, so refraction exists (refract and fresnel_dielectric agree on TIR).
        let wi = refract(wo, self.ior)?;
        let ft = 1.0 - fr;
        let f = self.tint * (ft / wi.z.abs());
        Some(BsdfSample { wi, f, pdf: ft, delta: true })
    }
}

/// Refracts `wo` through the interface with the normal +Z, the inside having IOR `ior`
/// relative to the outside. Works from either side; None on total internal reflection.
///
/// The tangential part scales by 1/η and the normal part is cos θt, so the result is unit
/// length by Snell's law; for η = 1 it is exactly −wo.
pub(super) fn refract(wo: Vec3, ior: f32) -> Option<Vec3> {
    let (eta, side) = if wo.z > 0.0 { (ior, 1.0) } else { (1.0 / ior, -1.0) };
    let cos_t = refracted_cos(wo.z.abs(), eta)?;
    Some(Vec3::new(-wo.x / eta, -wo.y / eta, -side * cos_t))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refraction_obeys_snell_from_both_sides() {
        for ior in [1.33f32, 1.5, 3.0] {
            for i in 1..50 {
                let theta = i as f32 / 50.0 * std::f32::consts::FRAC_PI_2;
                for outside in [true, false] {
                    let z = if outside { theta.cos() } else { -theta.cos() };
                    let wo = Vec3::new(theta.sin() * 0.6, theta.sin() * 0.8, z);
                    let (n_i, n_t) = if outside { (1.0, ior) } else { (ior, 1.0) };
                    match refract(wo, ior) {
                        Some(wi) => {
                            assert!((wi.length() - 1.0).abs() < 1e-5);
                            assert!(wi.z * wo.z < 0.0, "must cross the interface");
                            let sin_i = wo.truncate().length();
                            let sin_t = wi.truncate().length();
                            assert!((n_i * sin_i - n_t * sin_t).abs() < 1e-5);
                        }
                        None => assert!(n_i * theta.sin() >= n_t * 0.9999, "spurious TIR"),
                    }
                }
            }
        }
    }

    #[test]
    fn index_one_passes_straight_through() {
        let wo = Vec3::new(0.3, -0.4, 0.2).normalize();
        assert_eq!(refract(wo, 1.0), Some(-wo));
        assert_eq!(refract(-wo, 1.0), Some(wo));
    }
}

/// Smooth glass of index of refraction `ior`, its transmission tinted by `tint` (scene files:
/// `type = "glass"`).
#[derive(Clone, Debug, PartialEq)]
pub struct GlassMaterial {
    pub ior: f32,
    pub tint: Vec3,
    /// Absorption coefficient of the inside per unit length, per channel (Beer–Lambert: light
    /// that travels `d` inside keeps `exp(−absorption · d)`); zero: clear.
    pub absorption: Vec3,
}

impl GlassMaterial {
    /// Clear glass of index `ior`, tinted at each transmission by `tint`.
    pub fn clear(ior: f32, tint: Vec3) -> GlassMaterial {
        GlassMaterial { ior, tint, absorption: Vec3::ZERO }
    }

    /// The absorption coefficient that leaves `color` of the light after `distance` inside (as
    /// glTF's `KHR_materials_volume` gives it: σ = −ln(color) / distance); zero where the
    /// distance is infinite or a channel is 1 or more. A channel of 0 absorbs as if it kept
    /// 10⁻⁶ of the light.
    pub fn absorption_for(color: Vec3, distance: f32) -> Vec3 {
        if !(distance > 0.0 && distance.is_finite()) {
            return Vec3::ZERO;
        }
        (-color.clamp(Vec3::splat(1e-6), Vec3::ONE).map(f32::ln) / distance).max(Vec3::ZERO)
    }
}

impl MaterialModel for GlassMaterial {
    type Bsdf = Dielectric;
    #[inline(always)]
    fn bsdf<const TEX: bool>(&self, _at: &TexCoords) -> Dielectric {
        Dielectric::new(self.ior, self.tint)
    }
    /// The reflected fraction F0 = ((η − 1)/(η + 1))² plus the tint times the rest.
    fn albedo(&self) -> f32 {
        coated(((self.ior - 1.0) / (self.ior + 1.0)).powi(2), self.tint.max_element())
    }
    fn scatters(&self) -> bool {
        true
    }
    fn lobes(&self) -> Lobes {
        Lobes { glass: true, ..Lobes::default() }
    }
    fn fingerprint(&self, h: &mut Fingerprint) {
        h.str("glass");
        h.f32s(&[self.ior]);
        h.v3(&[self.tint]);
        if self.absorption != Vec3::ZERO {
            h.str("absorption");
            h.v3(&[self.absorption]);
        }
    }
}

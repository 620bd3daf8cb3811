//! Fresnel reflectance: the exact unpolarised equations for dielectrics and Schlick's
//! approximation for conductors.
//!
//! References: the Fresnel equations as written in Pharr, Jakob, Humphreys, *Physically Based
//! Rendering* 4th ed., §9.3 (`FrDielectric`); C. Schlick, "An Inexpensive BRDF Model for
//! Physically-based Rendering", Computer Graphics Forum 13(3), 1994.

use glam::Vec3;

/// Unpolarised Fresnel reflectance of a smooth interface between two dielectrics.
///
/// `cos_i` is the cosine between the incident direction (pointing away from the surface) and
/// the normal; `eta` is the relative index of refraction η_inside / η_outside, "inside" being
/// the side the normal does not point to (η > 0). A negative `cos_i` means the light arrives
/// from inside, and the interface is seen with relative IOR 1/η (pbrt's convention).
///
/// Returns 1 on total internal reflection and exactly 0 for η = 1.
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> f32 {
    debug_assert!(eta > 0.0, "eta = {eta}");
    let (cos_i, eta) = if cos_i < 0.0 { (-cos_i, 1.0 / eta) } else { (cos_i, eta) };
    if eta == 1.0 {
        return 0.0;
    }
    let cos_i = cos_i.min(1.0);
    let Some(cos_t) = refracted_cos(cos_i, eta) else {
        return 1.0;
    };
    // Both denominators are > 0: cos_t > 0 whenever refraction exists.
    let r_parallel = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perpendicular = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (r_parallel * r_parallel + r_perpendicular * r_perpendicular)
}

/// cos θt of the refracted direction by Snell's law, for `cos_i` in [0, 1] and relative IOR
/// `eta` (transmitted / incident side); None on total internal reflection.
///
/// Computed as √(cos²θi + η² − 1) / η, which equals √(1 − sin²θi / η²) but is exact for
/// η = 1 (no cancellation at grazing angles).
pub(super) fn refracted_cos(cos_i: f32, eta: f32) -> Option<f32> {
    let eta2 = eta * eta;
    let cos2_t = (cos_i * cos_i + (eta2 - 1.0)) / eta2;
    (cos2_t > 0.0).then(|| cos2_t.sqrt())
}

/// Schlick's approximation F0 + (1 − F0)(1 − cos θ)⁵, per colour channel.
#[inline]
pub(super) fn fresnel_schlick(f0: Vec3, cos: f32) -> Vec3 {
    let m = 1.0 - cos.clamp(0.0, 1.0);
    let m2 = m * m;
    f0 + (Vec3::ONE - f0) * (m2 * m2 * m)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_incidence_matches_closed_form() {
        // ((η − 1) / (η + 1))², the same from both sides.
        for eta in [1.33f32, 1.5, 3.0] {
            let expected = ((eta - 1.0) / (eta + 1.0)).powi(2);
            assert!((fresnel_dielectric(1.0, eta) - expected).abs() < 1e-6);
            assert!((fresnel_dielectric(-1.0, eta) - expected).abs() < 1e-6);
        }
    }

    #[test]
    fn total_internal_reflection_and_grazing() {
        // Critical angle for η = 1.5 from inside: sin θc = 1/1.5, θc ≈ 41.8°.
        let cos = |deg: f32| deg.to_radians().cos();
        assert_eq!(fresnel_dielectric(-cos(45.0), 1.5), 1.0);
        assert!(fresnel_dielectric(-cos(40.0), 1.5) < 1.0);
        assert!((fresnel_dielectric(0.0, 1.5) - 1.0).abs() < 1e-6);
        assert_eq!(fresnel_dielectric(0.3, 1.0), 0.0);
        assert_eq!(fresnel_dielectric(-0.3, 1.0), 0.0);
    }

    #[test]
    fn reflectance_is_the_same_from_both_sides_of_a_refracted_pair() {
        // Stokes relations: a ray and its refracted counterpart see the same reflectance.
        for eta in [1.2f32, 1.5, 3.0] {
            for i in 1..100 {
                let cos_i = i as f32 / 100.0;
                let cos_t = refracted_cos(cos_i, eta).unwrap();
                let outside = fresnel_dielectric(cos_i, eta);
                let inside = fresnel_dielectric(-cos_t, eta);
                // Near the critical angle cos_t → cos_i loses ~3 digits to cancellation in f32.
                assert!((outside - inside).abs() < 2e-4, "{eta} {cos_i}: {outside} vs {inside}");
            }
        }
    }

    #[test]
    fn schlick_endpoints() {
        let f0 = Vec3::new(0.9, 0.5, 0.1);
        assert!((fresnel_schlick(f0, 1.0) - f0).abs().max_element() < 1e-7);
        assert!((fresnel_schlick(f0, 0.0) - Vec3::ONE).abs().max_element() < 1e-7);
    }
}

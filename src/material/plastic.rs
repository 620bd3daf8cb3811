//! Glossy plastic: a dielectric coating (IOR 1.5) over a Lambertian base.
//!
//! f(wo, wi) = f_coat(wo, wi) + diffuse/π · (1 − F(cos θo)) (1 − F(cos θi))
//!
//! - `f_coat` is GGX microfacet reflection (Walter et al. 2007) with the exact dielectric
//!   Fresnel at the microfacet, the height-correlated Smith G2 (Heitz 2014) and visible-normal
//!   sampling (Heitz 2018); for alpha < 1e-3 it is a delta mirror weighted by F(cos θo).
//! - The base is attenuated by the Fresnel *transmittance* of the macro-surface on the way in
//!   and on the way out, F being the exact dielectric Fresnel at the shading normal. This is
//!   symmetric in wo and wi (reciprocal) and needs no tables. It ignores the light that the
//!   coating reflects back down onto the base (internal reflections), so it is darker than a
//!   full layered model: with a white base the diffuse part alone has albedo
//!   (1 − F(cos θo)) (1 − F̄) where F̄ ≈ 0.092 is the hemispherical-cosine average of F, and
//!   the coating adds what it reflects. For a smooth coating that is exactly F(cos θo), so the
//!   albedo F + (1 − F)(1 − F̄) < 1 provably; for rough coatings (whose single-scattering
//!   reflection loses energy) the white furnace tests check albedo ≤ 1 numerically over
//!   roughness 0–1 and cos θo down to 0.003 (maximum measured: 0.998, smooth, at grazing).
//!
//! Lobe choice: specular with probability p = F(cos θo) / (F(cos θo) + (1 − F(cos θo)) d̄),
//! d̄ the mean of the base colour's channels (p = 1 for a black base); [`Plastic::pdf`] is
//! the matching mixture p · pdf_coat + (1 − p) · cos θi / π (only the diffuse part when the
//! coating is a delta).

use std::f32::consts::FRAC_1_PI;

use glam::{Vec2, Vec3};

use super::diffuse::{cosine_hemisphere_pdf, sample_cosine_hemisphere};
use super::fresnel::fresnel_dielectric;
use super::microfacet::Ggx;
use super::{BsdfModel, BsdfSample, Lobes, MIN_COS, MaterialModel, coated, reflect, reflect_z, same_hemisphere_above};
use crate::hash::Fingerprint;
use crate::texture::{TexCoords, Texture};

/// Index of refraction of the coating.
const COATING_IOR: f32 = 1.5;

/// A Lambertian base under a GGX dielectric coating.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plastic {
    diffuse: Vec3,
    ggx: Ggx,
}

impl Plastic {
    pub fn new(diffuse: Vec3, roughness: f32) -> Self {
        Plastic { diffuse, ggx: Ggx::from_roughness(roughness) }
    }

    /// Probability of sampling the coating rather than the base, for wo.z > 0.
    fn specular_probability(&self, wo: Vec3) -> f32 {
        let fr = fresnel_dielectric(wo.z, COATING_IOR);
        let base = (1.0 - fr) * self.diffuse.max(Vec3::ZERO).element_sum() / 3.0;
        // fr ≥ 0.04 for IOR 1.5, so the denominator is positive.
        if base > 0.0 { fr / (fr + base) } else { 1.0 }
    }
}

impl BsdfModel for Plastic {
    /// Coating or base.
    #[inline(always)]
    fn chooses_lobe(&self) -> bool {
        true
    }

    /// The coating's reflectance at normal incidence (4 %) plus the base colour times what
    /// passes the coating.
    fn denoise_albedo(&self) -> Vec3 {
        Vec3::splat(COATING_F0) + (1.0 - COATING_F0) * self.diffuse
    }

    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if !same_hemisphere_above(wo, wi) {
            return Vec3::ZERO;
        }
        let transmit = (1.0 - fresnel_dielectric(wo.z, COATING_IOR)) * (1.0 - fresnel_dielectric(wi.z, COATING_IOR));
        let base = self.diffuse * (transmit * FRAC_1_PI);
        if self.ggx.is_smooth() {
            return base;
        }
        let coat = match (wo + wi).try_normalize() {
            Some(wm) => {
                let fr = fresnel_dielectric(wo.dot(wm), COATING_IOR);
                fr * self.ggx.d(wm) * self.ggx.visibility(wo, wi)
            }
            None => 0.0,
        };
        base + Vec3::splat(coat)
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if !same_hemisphere_above(wo, wi) {
            return 0.0;
        }
        let p = self.specular_probability(wo);
        let diffuse = (1.0 - p) * cosine_hemisphere_pdf(wi);
        if self.ggx.is_smooth() {
            return diffuse;
        }
        let coat = match (wo + wi).try_normalize() {
            Some(wm) => self.ggx.reflection_pdf(wo, wm),
            None => 0.0,
        };
        p * coat + diffuse
    }

    fn sample(&self, wo: Vec3, u: Vec2, uc: f32) -> Option<BsdfSample> {
        if wo.z <= MIN_COS {
            return None;
        }
        let p = self.specular_probability(wo);
        let wi = if uc < p {
            if self.ggx.is_smooth() {
                let wi = reflect_z(wo);
                let f = Vec3::splat(fresnel_dielectric(wo.z, COATING_IOR) / wo.z);
                return Some(BsdfSample { wi, f, pdf: p, delta: true });
            }
            reflect(wo, self.ggx.sample_visible_normal(wo, u))
        } else {
            sample_cosine_hemisphere(u)
        };
        if wi.z <= MIN_COS {
            return None;
        }
        Some(BsdfSample { wi, f: self.eval(wo, wi), pdf: self.pdf(wo, wi), delta: false })
    }
}

/// Reflectance at normal incidence of the coating (IOR 1.5).
const COATING_F0: f32 = 0.04;

/// Glossy plastic: a base of colour `color` under a coating of roughness `roughness` (scene
/// files: `type = "plastic"`).
#[derive(Clone, Debug, PartialEq)]
pub struct PlasticMaterial {
    pub color: Texture,
    pub roughness: f32,
}

impl MaterialModel for PlasticMaterial {
    type Bsdf = Plastic;
    #[inline(always)]
    fn bsdf<const TEX: bool>(&self, at: &TexCoords) -> Plastic {
        Plastic::new(self.color.at::<TEX>(at), self.roughness)
    }
    /// The coating's 4 % plus the base colour times the 96 % that passes the coating.
    fn albedo(&self) -> f32 {
        coated(COATING_F0, self.color.max().max_element())
    }
    /// Always: the coating reflects whatever the base colour.
    fn scatters(&self) -> bool {
        true
    }
    fn lobes(&self) -> Lobes {
        Lobes { diffuse: true, glossy: true, ..Lobes::default() }
    }
    fn textures(&self) -> Vec<&Texture> {
        self.color.varying().into_iter().collect()
    }
    fn fingerprint(&self, h: &mut Fingerprint) {
        h.str("plastic");
        self.color.fingerprint(h);
        h.f32s(&[self.roughness]);
    }
}

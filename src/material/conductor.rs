//! Rough metal: single-scattering GGX microfacet reflection (Walter et al. 2007) with Schlick
//! Fresnel (F0 = colour), sampled through the visible normals (Heitz 2018); a perfect mirror
//! below the smoothness threshold. See [`super::microfacet`] for the terms.
//!
//! Single scattering loses the energy of light that bounces more than once between
//! microfacets, so a white rough conductor reflects less than 1: about 0.99 at roughness 0.3,
//! 0.82 at 0.6 and only 1 − ln 2 ≈ 0.31 at roughness 1 (alpha 1), normal incidence, where
//! half of the reflected directions point into the surface.

use glam::{Vec2, Vec3};

use super::fresnel::fresnel_schlick;
use super::microfacet::Ggx;
use super::{BsdfModel, BsdfSample, Lobes, MIN_COS, MaterialModel, reflect, reflect_z, same_hemisphere_above};
use crate::hash::Fingerprint;
use crate::texture::{TexCoords, Texture};

/// Reflectance F0 at normal incidence and a GGX distribution.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Conductor {
    /// Reflectance at normal incidence (Schlick's F0), per channel.
    f0: Vec3,
    ggx: Ggx,
}

impl Conductor {
    pub fn new(color: Vec3, roughness: f32) -> Self {
        Conductor { f0: color, ggx: Ggx::from_roughness(roughness) }
    }
}

impl BsdfModel for Conductor {
    /// A perfect mirror: the only lobe is a delta.
    fn is_delta(&self) -> bool {
        self.ggx.is_smooth()
    }

    /// Its reflectance at normal incidence (the colour).
    fn denoise_albedo(&self) -> Vec3 {
        self.f0
    }

    /// D(wm) F(wo·wm) G2(wo, wi) / (4 cos θo cos θi) with wm the half vector.
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if self.is_delta() || !same_hemisphere_above(wo, wi) {
            return Vec3::ZERO;
        }
        // wo + wi has z > 0 here, so the half vector exists and faces both directions.
        let Some(wm) = (wo + wi).try_normalize() else {
            return Vec3::ZERO;
        };
        let f = fresnel_schlick(self.f0, wo.dot(wm));
        f * (self.ggx.d(wm) * self.ggx.visibility(wo, wi))
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if self.is_delta() || !same_hemisphere_above(wo, wi) {
            return 0.0;
        }
        match (wo + wi).try_normalize() {
            Some(wm) => self.ggx.reflection_pdf(wo, wm),
            None => 0.0,
        }
    }

    fn sample(&self, wo: Vec3, u: Vec2, _uc: f32) -> Option<BsdfSample> {
        if wo.z <= MIN_COS {
            return None;
        }
        if self.is_delta() {
            let wi = reflect_z(wo);
            let f = fresnel_schlick(self.f0, wo.z) / wo.z;
            return Some(BsdfSample { wi, f, pdf: 1.0, delta: true });
        }
        let wm = self.ggx.sample_visible_normal(wo, u);
        let wi = reflect(wo, wm);
        if wi.z <= MIN_COS {
            return None; // Reflected into the surface: the single-scattering energy loss.
        }
        Some(BsdfSample { wi, f: self.eval(wo, wi), pdf: self.pdf(wo, wi), delta: false })
    }
}

/// Rough metal of reflectance `color` at normal incidence; roughness 0 is a mirror (scene
/// files: `type = "metal"`).
#[derive(Clone, Debug, PartialEq)]
pub struct MetalMaterial {
    pub color: Texture,
    pub roughness: f32,
}

impl MaterialModel for MetalMaterial {
    type Bsdf = Conductor;
    #[inline(always)]
    fn bsdf<const TEX: bool>(&self, at: &TexCoords) -> Conductor {
        Conductor::new(self.color.at::<TEX>(at), self.roughness)
    }
    /// Its colour: the reflectance at normal incidence (only towards grazing angles does it
    /// rise to 1).
    fn albedo(&self) -> f32 {
        self.color.max().max_element()
    }
    fn scatters(&self) -> bool {
        !matches!(self.color, Texture::Constant(c) if c.max_element() <= 0.0)
    }
    fn lobes(&self) -> Lobes {
        if Conductor::new(Vec3::ONE, self.roughness).is_delta() {
            Lobes { mirror: true, ..Lobes::default() }
        } else {
            Lobes { glossy: true, ..Lobes::default() }
        }
    }
    fn textures(&self) -> Vec<&Texture> {
        self.color.varying().into_iter().collect()
    }
    fn fingerprint(&self, h: &mut Fingerprint) {
        h.str("metal");
        self.color.fingerprint(h);
        h.f32s(&[self.roughness]);
    }
}

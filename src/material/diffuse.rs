//! Lambertian reflection with cosine-weighted hemisphere sampling (Malley's method: a uniform
//! point on the unit disk projected up onto the hemisphere).

use std::f32::consts::FRAC_1_PI;

use crate::fastmath::sin_cos_turns;

use glam::{Vec2, Vec3};

use super::{BsdfModel, BsdfSample, Lobes, MIN_COS, MaterialModel, same_hemisphere_above};
use crate::hash::Fingerprint;
use crate::texture::{TexCoords, Texture};

/// f = albedo / π.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lambert {
    albedo: Vec3,
}

impl Lambert {
    /// Black: what a kind that does not scatter gives.
    pub const BLACK: Lambert = Lambert { albedo: Vec3::ZERO };

    #[inline(always)]
    pub fn new(albedo: Vec3) -> Self {
        Lambert { albedo }
    }

    /// [`BsdfModel::sample`] without its branch, for lanes computed together: the same
    /// sample where that gives one, and one of density 0 (and f 0) where it gives none.
    #[inline(always)]
    pub fn sample_branchless(&self, wo: Vec3, u: Vec2) -> BsdfSample {
        let wi = sample_cosine_hemisphere(u);
        BsdfSample { wi, f: self.eval(wo, wi), pdf: self.pdf(wo, wi), delta: false }
    }

    /// Its albedo (the colour).
    pub fn albedo(&self) -> Vec3 {
        self.albedo
    }
}

impl BsdfModel for Lambert {
    #[inline(always)]
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if same_hemisphere_above(wo, wi) { self.albedo * FRAC_1_PI } else { Vec3::ZERO }
    }

    #[inline(always)]
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if same_hemisphere_above(wo, wi) { cosine_hemisphere_pdf(wi) } else { 0.0 }
    }

    #[inline(always)]
    fn sample(&self, wo: Vec3, u: Vec2, _uc: f32) -> Option<BsdfSample> {
        if wo.z <= MIN_COS {
            return None;
        }
        Some(self.sample_branchless(wo, u))
    }

    /// Its colour.
    fn denoise_albedo(&self) -> Vec3 {
        self.albedo
    }
}

/// A direction in the upper hemisphere with density cos θ / π, for `u` in [0, 1)².
/// cos θ = √(1 − u.x) ≥ 2⁻¹² for f32 inputs below 1, so the result is never in the plane.
#[inline(always)]
pub fn sample_cosine_hemisphere(u: Vec2) -> Vec3 {
    let r = u.x.sqrt();
    let (sin_phi, cos_phi) = sin_cos_turns(u.y);
    let z = (1.0 - u.x).max(0.0).sqrt();
    Vec3::new(r * cos_phi, r * sin_phi, z)
}

/// The density of [`sample_cosine_hemisphere`]: cos θ / π (0 below the horizon).
#[inline(always)]
pub(super) fn cosine_hemisphere_pdf(wi: Vec3) -> f32 {
    wi.z.max(0.0) * FRAC_1_PI
}

/// A Lambertian surface of colour `color` (scene files: `type = "diffuse"`).
#[derive(Clone, Debug, PartialEq)]
pub struct DiffuseMaterial {
    pub color: Texture,
}

impl MaterialModel for DiffuseMaterial {
    type Bsdf = Lambert;
    #[inline(always)]
    fn bsdf<const TEX: bool>(&self, at: &TexCoords) -> Lambert {
        Lambert::new(self.color.at::<TEX>(at))
    }
    #[inline(always)]
    fn lambert<const TEX: bool>(&self, at: &TexCoords) -> Lambert {
        self.bsdf::<TEX>(at)
    }
    /// Its colour.
    fn albedo(&self) -> f32 {
        self.color.max().max_element()
    }
    fn scatters(&self) -> bool {
        !matches!(self.color, Texture::Constant(c) if c.max_element() <= 0.0)
    }
    fn lobes(&self) -> Lobes {
        Lobes { diffuse: true, ..Lobes::default() }
    }
    fn textures(&self) -> Vec<&Texture> {
        self.color.varying().into_iter().collect()
    }
    fn fingerprint(&self, h: &mut Fingerprint) {
        h.str("diffuse");
        self.color.fingerprint(h);
    }
}

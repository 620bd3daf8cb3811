//! Surface descriptions as the scene file gives them (with textures); turned into a
//! [`Bsdf`] at each shading point.

use crate::material::Bsdf;
use crate::texture::Texture;
use glam::{Vec2, Vec3};

/// What a surface is made of.
#[derive(Clone, Debug, PartialEq)]
pub enum MaterialKind {
    /// Lambertian.
    Diffuse { color: Texture },
    /// GGX rough metal; roughness 0 is a mirror.
    Metal { color: Texture, roughness: f32 },
    /// Diffuse base under a GGX dielectric coat.
    Plastic { color: Texture, roughness: f32 },
    /// Smooth glass.
    Glass { ior: f32, tint: Vec3 },
    /// Emits and reflects nothing.
    Emissive,
}

/// A named material; any material may also emit (`emission`, radiance, both faces).
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    pub kind: MaterialKind,
    pub emission: Vec3,
}

impl Material {
    pub fn diffuse(name: &str, color: Vec3) -> Material {
        Material {
            name: name.into(),
            kind: MaterialKind::Diffuse { color: Texture::Constant(color) },
            emission: Vec3::ZERO,
        }
    }

    /// The BSDF at `uv`. With `TEX == false` the caller knows no texture is in use, so colours
    /// are read as the constants they are, without looking at `uv`.
    #[inline]
    pub fn bsdf_at<const TEX: bool>(&self, uv: Vec2) -> Bsdf {
        let c = |t: &Texture| if TEX { t.eval(uv) } else { t.average() };
        match &self.kind {
            MaterialKind::Diffuse { color } => Bsdf::Diffuse { albedo: c(color) },
            MaterialKind::Metal { color, roughness } => Bsdf::Conductor { color: c(color), roughness: *roughness },
            MaterialKind::Plastic { color, roughness } => Bsdf::Plastic { diffuse: c(color), roughness: *roughness },
            MaterialKind::Glass { ior, tint } => Bsdf::Dielectric { ior: *ior, tint: *tint },
            MaterialKind::Emissive => Bsdf::Diffuse { albedo: Vec3::ZERO },
        }
    }

    /// The Lambertian BSDF of a scene whose every surface is diffuse or purely emissive (the
    /// caller knows): the same value as [`Material::bsdf_at`] gives there, without dispatch.
    #[inline]
    pub fn lambert_at<const TEX: bool>(&self, uv: Vec2) -> Bsdf {
        match &self.kind {
            MaterialKind::Diffuse { color } => {
                Bsdf::Diffuse { albedo: if TEX { color.eval(uv) } else { color.average() } }
            }
            _ => Bsdf::Diffuse { albedo: Vec3::ZERO },
        }
    }

    pub fn is_emissive(&self) -> bool {
        self.emission.max_element() > 0.0
    }

    /// The texture, if the colour varies over the surface.
    pub fn texture(&self) -> Option<&Texture> {
        match &self.kind {
            MaterialKind::Diffuse { color }
            | MaterialKind::Metal { color, .. }
            | MaterialKind::Plastic { color, .. } => (!color.is_constant()).then_some(color),
            _ => None,
        }
    }
}

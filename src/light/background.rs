//! The background: what a ray that leaves the scene sees (a constant or gradient sky, or an
//! environment image), and, unless black, a light that next-event estimation samples
//! (uniformly over the sphere of directions).

use super::choice::LightBounds;
use super::{LightSample, luminance, uniform_sphere};
use crate::hash::Fingerprint;
use crate::texture::Image;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;
use std::sync::Arc;

/// What a ray that leaves the scene sees: radiance as a function of direction (Y up).
#[derive(Clone, Debug, PartialEq)]
pub enum Background {
    Black,
    /// The same radiance in every direction.
    Constant(Vec3),
    /// `zenith` straight up blending to `horizon`, then to `ground` straight down.
    Gradient {
        zenith: Vec3,
        horizon: Vec3,
        ground: Vec3,
    },
    /// An equirectangular (latitude-longitude) environment image, scaled.
    Image {
        image: Arc<Image>,
        scale: f32,
    },
}

impl Background {
    /// Radiance arriving from the unit direction `d` (the path tracer's ray directions and
    /// sampled directions are unit vectors).
    #[inline]
    pub fn radiance(&self, d: Vec3) -> Vec3 {
        match self {
            Background::Black => Vec3::ZERO,
            Background::Constant(c) => *c,
            Background::Gradient { zenith, horizon, ground } => {
                // `d` is a unit vector: its y is the sine of the elevation.
                let y = d.y;
                if y >= 0.0 { horizon.lerp(*zenith, y.min(1.0)) } else { horizon.lerp(*ground, (-y).min(1.0)) }
            }
            Background::Image { image, scale } => {
                let d = d.normalize();
                let u = 0.5 + d.x.atan2(-d.z) / (2.0 * PI);
                let v = 1.0 - d.y.clamp(-1.0, 1.0).acos() / PI;
                image.bilinear(Vec2::new(u, v)) * *scale
            }
        }
    }

    pub fn is_black(&self) -> bool {
        match self {
            Background::Black => true,
            Background::Constant(c) => c.max_element() <= 0.0,
            Background::Gradient { zenith, horizon, ground } => {
                zenith.max_element() <= 0.0 && horizon.max_element() <= 0.0 && ground.max_element() <= 0.0
            }
            Background::Image { scale, .. } => *scale <= 0.0,
        }
    }

    /// Average radiance over the sphere (approximate for images), for light selection.
    pub fn average(&self) -> Vec3 {
        match self {
            Background::Black => Vec3::ZERO,
            Background::Constant(c) => *c,
            Background::Gradient { zenith, horizon, ground } => 0.5 * *horizon + 0.25 * (*zenith + *ground),
            Background::Image { image, scale } => image.mean() * *scale,
        }
    }

    /// Luminance of the power it sends into a scene whose bounding sphere has radius `r`
    /// (its cross-section πr² times the radiance over 4π sr; never quite zero).
    pub(super) fn power(&self, r: f32) -> f32 {
        luminance(self.average()).max(1e-6) * 4.0 * PI * PI * r * r
    }

    pub(super) fn bounds(&self) -> LightBounds {
        LightBounds::background(luminance(self.average()))
    }

    /// A direction uniform over the sphere; the background was chosen with probability `sel`.
    #[inline(never)]
    pub(super) fn sample(&self, sel: f32, u: Vec2) -> Option<LightSample> {
        let wi = uniform_sphere(u);
        Some(LightSample {
            wi,
            point: None,
            normal: Vec3::ZERO,
            radiance: self.radiance(wi),
            pdf: sel / (4.0 * PI),
            delta: false,
        })
    }

    /// Solid-angle density of [`Background::sample`], chosen with probability `sel`.
    pub(super) fn pdf(sel: f32) -> f32 {
        sel / (4.0 * PI)
    }

    pub fn fingerprint(&self, h: &mut Fingerprint) {
        match self {
            Background::Image { image, scale } => {
                h.str("image");
                image.fingerprint(h);
                h.f32s(&[*scale]);
            }
            other => h.str(&format!("{other:?}")),
        }
    }
}

//! The background: what a ray that leaves the scene sees (a constant or gradient sky, or an
//! environment image), and, unless black, a light that next-event estimation samples: the
//! skies uniformly over the sphere of directions, an environment image by its luminance
//! (`environment.rs`).

use super::choice::LightBounds;
use super::environment::Environment;
use super::{LightSample, luminance, uniform_sphere};
use crate::hash::Fingerprint;
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
    /// An equirectangular (latitude-longitude) environment image, rotated and scaled.
    Image(Arc<Environment>),
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
            Background::Image(env) => env.radiance(d),
        }
    }

    pub fn is_black(&self) -> bool {
        match self {
            Background::Black => true,
            Background::Constant(c) => c.max_element() <= 0.0,
            Background::Gradient { zenith, horizon, ground } => {
                zenith.max_element() <= 0.0 && horizon.max_element() <= 0.0 && ground.max_element() <= 0.0
            }
            Background::Image(env) => env.average().max_element() <= 0.0,
        }
    }

    /// Average radiance over the sphere (for images: texels weighted by their solid angle),
    /// for light selection.
    pub fn average(&self) -> Vec3 {
        match self {
            Background::Black => Vec3::ZERO,
            Background::Constant(c) => *c,
            Background::Gradient { zenith, horizon, ground } => 0.5 * *horizon + 0.25 * (*zenith + *ground),
            Background::Image(env) => env.average(),
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

    /// A direction toward the background, chosen with probability `sel`: uniform over the
    /// sphere for the skies, by luminance for an environment image.
    #[inline(never)]
    pub(super) fn sample(&self, sel: f32, u: Vec2) -> Option<LightSample> {
        if let Background::Image(env) = self {
            return env.sample(sel, u);
        }
        let wi = uniform_sphere(u);
        Some(LightSample {
            wi,
            point: None,
            normal: Vec3::ZERO,
            radiance: self.radiance(wi),
            pdf: sel / (4.0 * PI),
            delta: false,
            light: 0,
        })
    }

    /// Solid-angle density with which [`Background::sample`], chosen with probability `sel`,
    /// picks the unit direction `d`.
    #[inline]
    pub(super) fn pdf(&self, sel: f32, d: Vec3) -> f32 {
        match self {
            Background::Image(env) => sel * env.pdf(d),
            _ => sel / (4.0 * PI),
        }
    }

    pub fn fingerprint(&self, h: &mut Fingerprint) {
        match self {
            Background::Image(env) => {
                h.str("image");
                env.fingerprint(h);
            }
            other => h.str(&format!("{other:?}")),
        }
    }
}

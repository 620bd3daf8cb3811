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
}

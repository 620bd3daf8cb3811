//! The background: what a ray that leaves the scene sees (a constant or gradient sky, or an
//! environment image), and, unless black, a light that next-event estimation samples: an
//! environment image by its luminance (`environment.rs`); a constant or gradient sky by the
//! cosine about the normal of the opaque surface it lights (cos θ / π over the hemisphere that
//! surface can receive light from: a sky's contribution is then its radiance times the BSDF's
//! cosine-weighted mean, and no sample goes below the surface, where half of a uniform
//! sphere's did), or uniformly over the sphere where the point is not on one (glass, which
//! takes light from both sides).

use super::choice::LightBounds;
use super::environment::Environment;
use super::{LightSample, luminance, uniform_sphere};
use crate::geometry::Frame;
use crate::hash::Fingerprint;
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};
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

    /// A direction toward the background, chosen with probability `sel`, from a point whose
    /// lit side faces `n` (zero: both sides): see the module documentation.
    #[inline(never)]
    pub(super) fn sample(&self, sel: f32, u: Vec2, n: Vec3) -> Option<LightSample> {
        if let Background::Image(env) = self {
            return env.sample(sel, u);
        }
        let (wi, pdf) = if n == Vec3::ZERO {
            (uniform_sphere(u), sel / (4.0 * PI))
        } else {
            let local = crate::material::sample_cosine_hemisphere(u);
            if !(local.z > 0.0) {
                return None; // on the horizon: density 0
            }
            (Frame::from_normal(n).to_world(local), sel * local.z * FRAC_1_PI)
        };
        Some(LightSample {
            wi,
            point: None,
            normal: Vec3::ZERO,
            radiance: self.radiance(wi),
            pdf,
            delta: false,
            light: 0,
        })
    }

    /// Solid-angle density with which [`Background::sample`], chosen with probability `sel`
    /// at a point facing `n`, picks the unit direction `d`.
    #[inline]
    pub(super) fn pdf(&self, sel: f32, d: Vec3, n: Vec3) -> f32 {
        match self {
            Background::Image(env) => sel * env.pdf(d),
            _ if n == Vec3::ZERO => sel / (4.0 * PI),
            _ => sel * d.dot(n).max(0.0) * FRAC_1_PI,
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Rng;

    fn sky() -> Background {
        Background::Gradient {
            zenith: Vec3::new(0.2, 0.4, 1.0),
            horizon: Vec3::new(0.9, 0.9, 0.8),
            ground: Vec3::new(0.3, 0.2, 0.1),
        }
    }

    fn normals() -> [Vec3; 4] {
        [Vec3::Y, -Vec3::Z, Vec3::new(0.3, -0.8, 0.52).normalize(), Vec3::new(-0.6, 0.1, 0.79).normalize()]
    }

    #[test]
    fn sky_samples_have_the_density_pdf_gives() {
        let mut rng = Rng::new(7, 1);
        for n in normals().into_iter().chain([Vec3::ZERO]) {
            for _ in 0..2000 {
                let s = sky().sample(0.25, rng.next_2d(), n).expect("a sample off the horizon");
                assert!((s.wi.length() - 1.0).abs() < 1e-5);
                if n != Vec3::ZERO {
                    assert!(s.wi.dot(n) > 0.0, "toward the side lit: {:?} for {n:?}", s.wi);
                }
                let pdf = sky().pdf(0.25, s.wi, n);
                assert!((s.pdf - pdf).abs() <= 1e-4 * pdf, "{} against {pdf}", s.pdf);
                assert_eq!(s.radiance, sky().radiance(s.wi));
            }
            // Below the surface nothing is sampled.
            if n != Vec3::ZERO {
                assert_eq!(sky().pdf(0.25, -n, n), 0.0);
            }
        }
        assert_eq!(sky().pdf(0.25, Vec3::X, Vec3::ZERO), 0.25 / (4.0 * PI));
    }

    /// The irradiance E = ∫ L(ω) max(ω·n, 0) dω, estimated from cosine samples, agrees with
    /// the same estimated from uniform ones (64k each, fixed seeds; the standard errors are
    /// below 0.3%), and for a constant sky every cosine sample gives π L exactly.
    #[test]
    fn cosine_samples_estimate_the_irradiance_uniform_ones_do() {
        let estimate = |bg: &Background, n: Vec3, facing: Vec3, seed: u64| {
            let mut rng = Rng::new(seed, 2);
            let k = 1 << 16;
            let mut sum = Vec3::ZERO;
            for _ in 0..k {
                let s = bg.sample(1.0, rng.next_2d(), facing).unwrap();
                sum += s.radiance * s.wi.dot(n).max(0.0) / s.pdf;
            }
            sum / k as f32
        };
        for n in normals() {
            let cosine = estimate(&sky(), n, n, 3);
            let uniform = estimate(&sky(), n, Vec3::ZERO, 4);
            assert!(
                (cosine - uniform).abs().max_element() < 0.01 * uniform.max_element(),
                "{cosine} against {uniform}"
            );
            let c = Vec3::new(0.5, 1.0, 2.0);
            let mut rng = Rng::new(5, 3);
            for _ in 0..100 {
                let s = Background::Constant(c).sample(1.0, rng.next_2d(), n).unwrap();
                let e = s.radiance * s.wi.dot(n) / s.pdf;
                assert!((e - PI * c).abs().max_element() < 1e-4 * PI * 2.0, "{e}");
            }
        }
    }
}

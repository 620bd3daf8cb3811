//! Emitting spheres: sampled uniformly within the cone they subtend from the shading point
//! (by area from inside or on them). Each is a group of its own for the choice by importance.

use super::choice::LightBounds;
use super::{LightSample, luminance, uniform_sphere};
use crate::geometry::{Frame, Sphere};
use crate::texture::{TexCoords, Texture};
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

#[derive(Clone, Debug, PartialEq)]
pub(super) struct EmissiveSphere {
    pub sphere: Sphere,
    /// Its radiance, or for a texture its mean (for power and bounds).
    pub emission: Vec3,
    /// A radiance that varies over the sphere (by the spheres' texture mapping).
    texture: Option<Box<Texture>>,
}

impl EmissiveSphere {
    /// `sphere` emitting `emission`: its radiance at a point is the texture there.
    pub(super) fn new(sphere: Sphere, emission: &Texture) -> EmissiveSphere {
        match emission {
            Texture::Constant(c) => EmissiveSphere { sphere, emission: *c, texture: None },
            t => EmissiveSphere { sphere, emission: t.average(), texture: Some(Box::new(t.clone())) },
        }
    }

    /// Luminance of the power it emits.
    pub(super) fn power(&self) -> f32 {
        let r = self.sphere.radius;
        luminance(self.emission) * 4.0 * PI * r * r * PI
    }

    pub(super) fn tree_bounds(&self) -> super::tree::Bounds {
        let (c, r) = (self.sphere.center, self.sphere.radius);
        let aabb = crate::geometry::Aabb::new(c - Vec3::splat(r), c + Vec3::splat(r));
        super::tree::Bounds { aabb, phi: luminance(self.emission) * PI * r * r, cone: super::tree::Cone::ALL }
    }

    pub(super) fn bounds(&self) -> LightBounds {
        LightBounds::sphere(self.sphere.center, self.sphere.radius, luminance(self.emission))
    }

    /// A point on the sphere as seen from `p`; the sphere was chosen with probability `sel`.
    #[inline(never)]
    pub(super) fn sample(&self, p: Vec3, sel: f32, u: Vec2) -> Option<LightSample> {
        let (q, n, pdf) = sample_sphere(&self.sphere, p, u)?;
        let wi = (q - p).normalize();
        let pdf = pdf * sel;
        (pdf.is_finite() && pdf > 0.0).then_some(LightSample {
            wi,
            point: Some(q),
            normal: n,
            radiance: self.radiance_at(n),
            pdf,
            delta: false,
            light: 0,
        })
    }

    /// A point light leaves the sphere from, for a path from the light: uniform by area
    /// (`u`), with the radiance there; it emits outward (light it sheds inward is left to
    /// paths from the camera: see [`super::Emitters::covers`]).
    pub(super) fn emit_point(&self, u: Vec2) -> Option<super::emission::EmissionPoint> {
        let r = self.sphere.radius;
        let n = uniform_sphere(u);
        let p = self.sphere.center + r * n;
        let le = self.radiance_at(n);
        (r > 0.0).then_some(super::emission::EmissionPoint { p, n, le, area: 4.0 * PI * r * r, two_sided: false })
    }

    /// The radiance where the outward normal is `n`.
    fn radiance_at(&self, n: Vec3) -> Vec3 {
        match &self.texture {
            None => self.emission,
            Some(t) => {
                let (u, v) = Sphere::uv(n);
                t.eval(&TexCoords::new(Vec2::new(u, v)))
            }
        }
    }

    /// Solid-angle density of [`EmissiveSphere::sample`] from `p` at the point `q` (normal
    /// `n`) on it, chosen with probability `sel`.
    pub(super) fn pdf(&self, sel: f32, p: Vec3, q: Vec3, n: Vec3) -> f32 {
        sel * pdf_sphere(&self.sphere, p, q, n)
    }
}

/// 1 − cosθmax of the cone a sphere subtends from a point at distance² `d2` from its centre
/// (outside), computed as sin²θmax / (1 + cosθmax): no cancellation for small or distant
/// spheres.
pub(super) fn cone_one_minus_cos(radius: f32, d2: f32) -> f32 {
    let sin2 = (radius * radius / d2).min(1.0);
    let cos = (1.0 - sin2).max(0.0).sqrt();
    sin2 / (1.0 + cos)
}

/// Whether `p` is inside the sphere or on its surface within rounding. A shading point on
/// the sphere itself (a camera inside a glowing sphere) is computed with an error of a few
/// float steps of the coordinates, so it lands outside about half the time; there the cone
/// toward the sphere degenerates to a half-space whose near intersection is `p` itself, and
/// light from the sphere would be lost. Sampling by area is valid from anywhere (only
/// noisier), so it is used within that rounding margin.
fn inside_or_on(s: &Sphere, p: Vec3) -> bool {
    let magnitude = s.center.abs().max_element().max(p.abs().max_element()) + s.radius;
    let r = s.radius + 8.0 * f32::EPSILON * magnitude;
    (s.center - p).length_squared() <= r * r
}

/// Samples a point on a sphere as seen from `p`: uniformly in the subtended cone when outside
/// (solid-angle density 1 / (2π(1 − cosθmax))), uniformly by area when inside or on it.
fn sample_sphere(s: &Sphere, p: Vec3, u: Vec2) -> Option<(Vec3, Vec3, f32)> {
    let to_c = s.center - p;
    let d2 = to_c.length_squared();
    if inside_or_on(s, p) {
        let n = uniform_sphere(u);
        let q = s.center + s.radius * n;
        let d = q - p;
        let dd = d.length_squared();
        let cos = n.dot(d / dd.sqrt()).abs();
        let pdf = dd / (cos * 4.0 * PI * s.radius * s.radius);
        return (cos > 0.0).then_some((q, n, pdf));
    }
    let d = d2.sqrt();
    let one_minus_cos = cone_one_minus_cos(s.radius, d2);
    let cos_t = 1.0 - u.x * one_minus_cos;
    let sin2_t = (1.0 - cos_t * cos_t).max(0.0);
    let phi = 2.0 * PI * u.y;
    // Distance along the sampled direction to the near intersection with the sphere.
    let ds = d * cos_t - (s.radius * s.radius - d2 * sin2_t).max(0.0).sqrt();
    let frame = Frame::from_normal(to_c / d);
    let dir = frame.to_world(Vec3::new(sin2_t.sqrt() * phi.cos(), sin2_t.sqrt() * phi.sin(), cos_t));
    let q = p + ds * dir;
    let n = (q - s.center).normalize();
    Some((q, n, 1.0 / (2.0 * PI * one_minus_cos)))
}

/// A direction uniform in the cone about the unit `axis` whose 1 − cos of its half-angle is
/// `one_minus_cos`, for `u` in [0, 1)² (density 1 / (2π · one_minus_cos)).
pub(crate) fn sample_cone(axis: Vec3, one_minus_cos: f32, u: Vec2) -> Vec3 {
    let cos_t = 1.0 - u.x * one_minus_cos;
    let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Frame::from_normal(axis).to_world(Vec3::new(sin_t * phi.cos(), sin_t * phi.sin(), cos_t))
}

fn pdf_sphere(s: &Sphere, p: Vec3, q: Vec3, n: Vec3) -> f32 {
    let d2 = (s.center - p).length_squared();
    if inside_or_on(s, p) {
        let d = q - p;
        let dd = d.length_squared();
        let cos = n.normalize().dot(d / dd.sqrt()).abs();
        return if cos > 0.0 { dd / (cos * 4.0 * PI * s.radius * s.radius) } else { 0.0 };
    }
    1.0 / (2.0 * PI * cone_one_minus_cos(s.radius, d2))
}

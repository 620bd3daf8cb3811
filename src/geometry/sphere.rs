use super::ray::face_ray;
use super::{Aabb, Ray, Shape, ShapeHit};
use glam::Vec3;
use std::f32::consts::PI;

/// A sphere. Texture coordinates follow the seed paper's mapping of the unit direction
/// `n = (p - c) / r`: `u = atan2(n.y, n.x)`, `v = asin(n.z)`, both rescaled to [0, 1].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    pub center: Vec3,
    pub radius: f32,
}

impl Sphere {
    pub fn new(center: Vec3, radius: f32) -> Self {
        Sphere { center, radius }
    }

    /// Both roots of |o + t d - c|² = r², smaller first, or `None` when the ray misses.
    ///
    /// Follows Haines et al., "Precision Improvements for Ray/Sphere Intersection" (Ray Tracing
    /// Gems, ch. 7): the discriminant is computed from the distance between the centre and the
    /// ray's closest approach (no catastrophic cancellation in b² − 4ac when the sphere is small
    /// or far), and the second root comes from c/q rather than a difference of near-equal terms.
    pub fn roots(&self, ray: &Ray) -> Option<(f32, f32)> {
        let f = ray.o - self.center;
        let a = ray.d.length_squared();
        let b = -f.dot(ray.d); // b' = -b/2
        let c = f.length_squared() - self.radius * self.radius;
        let l = f + (b / a) * ray.d;
        let disc = a * (self.radius * self.radius - l.length_squared());
        if !(disc >= 0.0) {
            return None;
        }
        let q = b + b.signum() * disc.sqrt();
        if q == 0.0 {
            // b' = 0 and tangent: the single root is at t = 0 (c = 0 too) or nowhere.
            return if c == 0.0 { Some((0.0, 0.0)) } else { None };
        }
        let (t0, t1) = (c / q, q / a);
        Some(if t0 <= t1 { (t0, t1) } else { (t1, t0) })
    }

    /// Texture coordinates of the unit outward direction `n`, +Y up (the scenes' up): v is
    /// the latitude, 0 at the south pole (−Y) to 1 at the north pole (+Y); u the longitude,
    /// ½ toward +Z and growing eastward (toward +X from there), so that a world map's centre
    /// faces a camera on +Z, right side up and not mirrored.
    pub fn uv(n: Vec3) -> (f32, f32) {
        let u = 0.5 + n.x.atan2(n.z) / (2.0 * PI);
        let v = (n.y.clamp(-1.0, 1.0).asin() + 0.5 * PI) / PI;
        (u, v)
    }

    /// The hit at `t`; `entering`: `t` is the smaller root (the ray comes from outside).
    fn hit_at(&self, ray: &Ray, t: f32, entering: bool) -> ShapeHit {
        let n = (ray.at(t) - self.center) / self.radius;
        let (u, v) = Sphere::uv(n.normalize_or_zero());
        ShapeHit { t, u, v, ng: face_ray(n, ray.d, entering) }
    }
}

impl Shape for Sphere {
    fn bounds(&self) -> Aabb {
        if !(self.radius > 0.0) || !self.center.is_finite() || !self.radius.is_finite() {
            return Aabb::EMPTY;
        }
        let r = Vec3::splat(self.radius);
        Aabb::new(self.center - r, self.center + r)
    }

    fn intersect(&self, ray: &Ray, tmin: f32, tmax: f32) -> Option<ShapeHit> {
        let (t0, t1) = self.roots(ray)?;
        if t0 > tmin && t0 < tmax {
            Some(self.hit_at(ray, t0, true))
        } else if t1 > tmin && t1 < tmax {
            Some(self.hit_at(ray, t1, false))
        } else {
            None
        }
    }

    fn occludes(&self, ray: &Ray, tmin: f32, tmax: f32) -> bool {
        match self.roots(ray) {
            Some((t0, t1)) => (t0 > tmin && t0 < tmax) || (t1 > tmin && t1 < tmax),
            None => false,
        }
    }
}

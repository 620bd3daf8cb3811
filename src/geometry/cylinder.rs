use super::ray::face_ray;
use super::{Aabb, Frame, Ray, Shape, ShapeHit};
use glam::Vec3;
use std::f32::consts::PI;

/// A capped cylinder: the disc of `radius` around the axis `p0 → p1`, swept along it,
/// closed by a disc at each end. Any axis direction.
///
/// Texture coordinates: on the side `u` = angle around the axis / 2π, `v` = height / length;
/// on the caps `u` = angle / 2π and `v` = distance from the axis / radius.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cylinder {
    pub p0: Vec3,
    pub p1: Vec3,
    pub radius: f32,
}

/// Which part of a cylinder a hit lies on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CylinderPart {
    Side,
    Cap0,
    Cap1,
}

impl Cylinder {
    pub fn new(p0: Vec3, p1: Vec3, radius: f32) -> Self {
        Cylinder { p0, p1, radius }
    }

    fn is_valid(&self) -> bool {
        self.p0.is_finite()
            && self.p1.is_finite()
            && self.radius.is_finite()
            && self.radius > 0.0
            && (self.p1 - self.p0).length_squared() > 0.0
    }

    /// The closest hit of the ray with the closed surface in `(tmin, tmax)`, with the part hit.
    ///
    /// The solid is the intersection of the infinite cylinder and the slab between the cap
    /// planes, so the ray is inside it over the intersection of two parameter intervals (as
    /// in the slab test for boxes). The entry is whichever interval starts last, the exit
    /// whichever ends first. Deciding by comparing interval ends, rather than testing the
    /// side hit's height and the cap hit's radius separately, makes the surface watertight:
    /// a ray through the rim, where both of those tests can fail by rounding, still hits.
    fn closest(&self, ray: &Ray, tmin: f32, tmax: f32) -> Option<(f32, CylinderPart, bool)> {
        let axis = self.p1 - self.p0;
        let h = axis.length();
        let a = axis / h;
        let f = ray.o - self.p0;
        let oz = f.dot(a);
        let dz = ray.d.dot(a);
        // Components perpendicular to the axis: a 2-D ray/circle problem, solved as for spheres
        // (Ray Tracing Gems ch. 7 form) to avoid cancellation for thin or distant cylinders.
        let fp = f - oz * a;
        let dp = ray.d - dz * a;
        let r2 = self.radius * self.radius;
        let qa = dp.length_squared();
        let (s0, s1) = if qa > 0.0 {
            let b = -fp.dot(dp);
            let c = fp.length_squared() - r2;
            let l = fp + (b / qa) * dp;
            let disc = qa * (r2 - l.length_squared());
            if !(disc >= 0.0) {
                return None;
            }
            let q = b + b.signum() * disc.sqrt();
            if q == 0.0 {
                return None; // tangent to the side at t = 0, or nowhere
            }
            let (x, y) = (c / q, q / qa);
            (x.min(y), x.max(y))
        } else if fp.length_squared() <= r2 {
            (f32::NEG_INFINITY, f32::INFINITY) // along the axis, inside the side all the way
        } else {
            return None;
        };
        let (z0, z1, cap_in, cap_out) = if dz != 0.0 {
            let (u, v) = ((0.0 - oz) / dz, (h - oz) / dz);
            if u <= v {
                (u, v, CylinderPart::Cap0, CylinderPart::Cap1)
            } else {
                (v, u, CylinderPart::Cap1, CylinderPart::Cap0)
            }
        } else if (0.0..=h).contains(&oz) {
            (f32::NEG_INFINITY, f32::INFINITY, CylinderPart::Side, CylinderPart::Side)
        } else {
            return None;
        };
        let (enter, enter_part) = if s0 >= z0 { (s0, CylinderPart::Side) } else { (z0, cap_in) };
        let (exit, exit_part) = if s1 <= z1 { (s1, CylinderPart::Side) } else { (z1, cap_out) };
        if !(enter <= exit) {
            return None;
        }
        if enter > tmin && enter < tmax {
            Some((enter, enter_part, true))
        } else if exit > tmin && exit < tmax {
            Some((exit, exit_part, false))
        } else {
            None
        }
    }

    /// The hit at `t` on `part`; `entering`: the ray comes from outside.
    fn hit_at(&self, ray: &Ray, t: f32, part: CylinderPart, entering: bool) -> ShapeHit {
        let axis = self.p1 - self.p0;
        let h = axis.length();
        let a = axis / h;
        let frame = Frame::from_normal(a);
        let rel = ray.at(t) - self.p0;
        let z = rel.dot(a);
        let radial = rel - z * a;
        let angle = (radial.dot(frame.b).atan2(radial.dot(frame.t)) + PI) / (2.0 * PI);
        match part {
            CylinderPart::Side => ShapeHit {
                t,
                u: angle,
                v: (z / h).clamp(0.0, 1.0),
                ng: face_ray(radial / self.radius, ray.d, entering),
            },
            CylinderPart::Cap0 => ShapeHit { t, u: angle, v: (radial.length() / self.radius).min(1.0), ng: -a },
            CylinderPart::Cap1 => ShapeHit { t, u: angle, v: (radial.length() / self.radius).min(1.0), ng: a },
        }
    }

    /// The part of the closest hit, for callers that need it (e.g. tests).
    pub fn closest_part(&self, ray: &Ray, tmin: f32, tmax: f32) -> Option<(f32, CylinderPart)> {
        if !self.is_valid() {
            return None;
        }
        self.closest(ray, tmin, tmax).map(|(t, part, _)| (t, part))
    }

    /// A hit point `p` with geometric normal `ng` (as this cylinder reports it) moved onto
    /// the surface: onto the side, or onto the cap plane its normal points out of. A hit
    /// point computed as `o + t·d` carries the rounding error of the ray's origin, which can
    /// be far larger than the point's own coordinates (a cylinder seen from afar); the
    /// projection's error is a few float steps of |p0|, the height and the radius. Returns
    /// the point and that error bound per component (for
    /// [`crate::geometry::offset_ray_origin_bounded`]).
    pub fn project(&self, p: Vec3, ng: Vec3) -> (Vec3, Vec3) {
        let axis = self.p1 - self.p0;
        let h = axis.length();
        let a = axis / h;
        let rel = p - self.p0;
        let z = rel.dot(a);
        let radial = rel - z * a;
        let along = ng.dot(a);
        let q = if along > 0.5 * ng.length() {
            self.p1 + radial
        } else if along < -0.5 * ng.length() {
            self.p0 + radial
        } else {
            self.p0 + z.clamp(0.0, h) * a + self.radius * radial.normalize_or_zero()
        };
        let magnitude = self.p0.abs().max(self.p1.abs()) + Vec3::splat(self.radius);
        (q, 8.0 * f32::EPSILON * magnitude)
    }
}

impl Shape for Cylinder {
    fn bounds(&self) -> Aabb {
        if !self.is_valid() {
            return Aabb::EMPTY;
        }
        let a = (self.p1 - self.p0).normalize();
        // Extent of a disc of radius r with normal a along axis i: r·sqrt(1 − a_i²).
        let e = self.radius * (Vec3::ONE - a * a).max(Vec3::ZERO).sqrt();
        Aabb::new(self.p0.min(self.p1) - e, self.p0.max(self.p1) + e)
    }

    fn intersect(&self, ray: &Ray, tmin: f32, tmax: f32) -> Option<ShapeHit> {
        if !self.is_valid() {
            return None;
        }
        let (t, part, entering) = self.closest(ray, tmin, tmax)?;
        Some(self.hit_at(ray, t, part, entering))
    }

    fn occludes(&self, ray: &Ray, tmin: f32, tmax: f32) -> bool {
        self.closest_part(ray, tmin, tmax).is_some()
    }
}

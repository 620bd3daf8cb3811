//! Pinhole and thin-lens cameras.

use crate::geometry::{Aabb, Ray};
use glam::{Vec2, Vec3};

/// A perspective camera. With `aperture_radius > 0` it is a thin lens focused at
/// `focus_distance` (depth of field); otherwise a pinhole.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub position: Vec3,
    /// Unit vectors: right, up, forward (view direction).
    right: Vec3,
    up: Vec3,
    forward: Vec3,
    /// Half extents of the image plane at distance 1.
    half_w: f32,
    half_h: f32,
    pub aperture_radius: f32,
    pub focus_distance: f32,
}

impl Camera {
    /// A camera at `position` looking at `look_at`, with vertical field of view `vfov_deg` and
    /// image aspect `width / height`. When `up` is parallel to the view direction another up
    /// vector is chosen rather than producing NaNs.
    pub fn look_at(
        position: Vec3,
        look_at: Vec3,
        up: Vec3,
        vfov_deg: f32,
        aspect: f32,
        aperture_radius: f32,
        focus_distance: f32,
    ) -> Camera {
        let forward = (look_at - position).normalize_or(Vec3::NEG_Z);
        // Normalised first, so that the parallel test below does not depend on up's length.
        let mut right = forward.cross(up.normalize_or_zero());
        if right.length_squared() < 1e-12 {
            // Up parallel to the view: pick any perpendicular.
            let alt = if forward.x.abs() < 0.9 { Vec3::X } else { Vec3::Z };
            right = forward.cross(alt.cross(forward));
        }
        let right = right.normalize();
        let up = right.cross(forward);
        let half_h = (0.5 * vfov_deg.to_radians()).tan();
        Camera { position, right, up, forward, half_w: half_h * aspect, half_h, aperture_radius, focus_distance }
    }

    /// A camera that frames `bounds` from the front-right-above, the way a user would first
    /// look at a model (Y up).
    pub fn framing(bounds: &Aabb, vfov_deg: f32, aspect: f32) -> Camera {
        let center = bounds.center();
        let radius = (0.5 * bounds.diagonal().length()).max(1e-6);
        let dir = Vec3::new(0.55, 0.45, 1.0).normalize();
        let fov = vfov_deg.min(vfov_deg * aspect).to_radians();
        let dist = radius / (0.5 * fov).sin() * 1.05;
        Camera::look_at(center + dir * dist, center, Vec3::Y, vfov_deg, aspect, 0.0, dist)
    }

    /// View direction.
    pub fn forward(&self) -> Vec3 {
        self.forward
    }

    /// Primary ray through film position `film` in [0,1]² (x right, y down) with lens sample
    /// `lens` in [0,1]² (ignored for a pinhole). The direction is normalized.
    #[inline]
    pub fn ray(&self, film: Vec2, lens: Vec2) -> Ray {
        let d = self.pinhole_dir(film);
        if self.aperture_radius <= 0.0 {
            return Ray::new(self.position, d);
        }
        self.lens_ray(d, lens)
    }

    /// Pinhole direction (unnormalized would do, but normalized keeps t in world units).
    #[inline]
    pub fn pinhole_dir(&self, film: Vec2) -> Vec3 {
        let sx = (2.0 * film.x - 1.0) * self.half_w;
        let sy = (1.0 - 2.0 * film.y) * self.half_h;
        (self.forward + sx * self.right + sy * self.up).normalize()
    }

    /// Thin-lens ray for a pinhole direction `d`: the ray through the lens point that reaches
    /// the same point on the plane of focus.
    #[inline]
    pub fn lens_ray(&self, d: Vec3, lens: Vec2) -> Ray {
        let focus = self.position + d * (self.focus_distance / d.dot(self.forward));
        let disk = concentric_disk(lens) * self.aperture_radius;
        let o = self.position + disk.x * self.right + disk.y * self.up;
        Ray::new(o, (focus - o).normalize())
    }
}

/// Shirley–Chiu concentric map of [0,1]² onto the unit disk.
#[inline]
pub fn concentric_disk(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) = if o.x.abs() > o.y.abs() {
        (o.x, std::f32::consts::FRAC_PI_4 * (o.y / o.x))
    } else {
        (o.y, std::f32::consts::FRAC_PI_2 - std::f32::consts::FRAC_PI_4 * (o.x / o.y))
    };
    r * Vec2::new(theta.cos(), theta.sin())
}

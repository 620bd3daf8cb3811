//! Cameras: pinhole, thin lens and orthographic.

use crate::geometry::{Aabb, LANES, Ray};
use glam::{Vec2, Vec3};

/// The direction from a model's centre to a camera that shows it front-right-above, the way a
/// user would first look at it (Y up): azimuth 28.8°, elevation 21.5° ([`orbit_dir`]).
pub fn model_view_dir() -> Vec3 {
    Vec3::new(0.55, 0.45, 1.0).normalize()
}

/// The unit direction from a centre to a camera orbiting it at `azimuth` and `elevation`
/// (degrees), Y up: azimuth turns about +Y from +Z towards +X, elevation rises from the XZ
/// plane towards +Y. (0, 0) looks along −Z; (90, 0) along −X; (0, 90) straight down.
pub fn orbit_dir(azimuth_deg: f32, elevation_deg: f32) -> Vec3 {
    let (a, e) = (azimuth_deg.to_radians(), elevation_deg.to_radians());
    Vec3::new(a.sin() * e.cos(), e.sin(), a.cos() * e.cos())
}

/// The azimuth and elevation, in degrees, of a direction ([`orbit_dir`] inverted).
pub fn orbit_angles(dir: Vec3) -> (f32, f32) {
    let d = dir.normalize_or(Vec3::Z);
    // Straight up or down, the azimuth is any: 0 rather than rounding's.
    let azimuth = if d.x.hypot(d.z) < 1e-4 { 0.0 } else { d.x.atan2(d.z).to_degrees() };
    (azimuth, d.y.clamp(-1.0, 1.0).asin().to_degrees())
}

/// A camera. Perspective: with `aperture_radius > 0` a thin lens focused at `focus_distance`
/// (depth of field), otherwise a pinhole. Orthographic: parallel rays along the view
/// direction, from a plane through `position`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub position: Vec3,
    /// Unit vectors: right, up, forward (view direction).
    right: Vec3,
    up: Vec3,
    forward: Vec3,
    /// Half extents of the image plane: at distance 1 (perspective), or in world units
    /// (orthographic).
    half_w: f32,
    half_h: f32,
    pub aperture_radius: f32,
    pub focus_distance: f32,
    orthographic: bool,
}

/// The camera's frame looking from `position` at `look_at`: (forward, right, up), unit vectors.
/// When `up` is parallel to the view direction another up vector is chosen rather than
/// producing NaNs.
fn frame(position: Vec3, look_at: Vec3, up: Vec3) -> (Vec3, Vec3, Vec3) {
    let forward = (look_at - position).normalize_or(Vec3::NEG_Z);
    // Normalised first, so that the parallel test below does not depend on up's length.
    let mut right = forward.cross(up.normalize_or_zero());
    if right.length_squared() < 1e-12 {
        // Up parallel to the view: pick any perpendicular.
        let alt = if forward.x.abs() < 0.9 { Vec3::X } else { Vec3::Z };
        right = forward.cross(alt.cross(forward));
    }
    let right = right.normalize();
    (forward, right, right.cross(forward))
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
        let (forward, right, up) = frame(position, look_at, up);
        let half_h = (0.5 * vfov_deg.to_radians()).tan();
        Camera {
            position,
            right,
            up,
            forward,
            half_w: half_h * aspect,
            half_h,
            aperture_radius,
            focus_distance,
            orthographic: false,
        }
    }

    /// An orthographic camera looking from `position` towards `look_at`: its rays are parallel
    /// to that direction and start on the plane through `position` across it, over a view
    /// `width` wide (world units) and `width / aspect` high. What lies behind that plane is not
    /// seen.
    pub fn orthographic(position: Vec3, look_at: Vec3, up: Vec3, width: f32, aspect: f32) -> Camera {
        let (forward, right, up) = frame(position, look_at, up);
        let half_w = 0.5 * width;
        Camera {
            position,
            right,
            up,
            forward,
            half_w,
            half_h: half_w / aspect,
            aperture_radius: 0.0,
            focus_distance: 1.0,
            orthographic: true,
        }
    }

    /// Whether the rays are parallel (orthographic).
    pub fn is_orthographic(&self) -> bool {
        self.orthographic
    }

    /// A camera that frames `bounds` from the front-right-above, the way a user would first
    /// look at a model (Y up), far enough that its bounding sphere fits the image. The
    /// benchmark's camera rays use it; scenes without a camera use [`Camera::fitting`].
    pub fn framing(bounds: &Aabb, vfov_deg: f32, aspect: f32) -> Camera {
        let center = bounds.center();
        let radius = (0.5 * bounds.diagonal().length()).max(1e-6);
        let dir = model_view_dir();
        let fov = vfov_deg.min(vfov_deg * aspect).to_radians();
        let dist = radius / (0.5 * fov).sin() * 1.05;
        Camera::look_at(center + dir * dist, center, Vec3::Y, vfov_deg, aspect, 0.0, dist)
    }

    /// A camera that frames a model whose surface lies within the convex hull of `points`
    /// (its vertices) and inside `bounds`, from the same front-right-above direction as
    /// [`Camera::framing`], but as close as keeps every point in the image with a 5% margin
    /// on each side. It looks at the centre of `bounds`. A bounding sphere is loose for flat or
    /// elongated models (the teapot filled under half the width of the frame); this fit is
    /// tight on the side that limits it.
    pub fn fitting(points: impl Iterator<Item = Vec3>, bounds: &Aabb, vfov_deg: f32, aspect: f32) -> Camera {
        Camera::fitting_from(model_view_dir(), points, bounds, vfov_deg, aspect)
    }

    /// [`Camera::fitting`] from direction `dir` (from the centre of `bounds` towards the
    /// camera; a unit vector) instead of the front-right-above one.
    pub fn fitting_from(
        dir: Vec3,
        points: impl Iterator<Item = Vec3>,
        bounds: &Aabb,
        vfov_deg: f32,
        aspect: f32,
    ) -> Camera {
        let center = bounds.center();
        let radius = (0.5 * bounds.diagonal().length()).max(1e-6);
        let view = Camera::look_at(center + dir, center, Vec3::Y, vfov_deg, aspect, 0.0, 1.0);
        let (tan_w, tan_h) = (0.9 * view.half_w, 0.9 * view.half_h);
        // A point at offset r from the centre is (dist + r·forward) in front of a camera
        // `dist` away, and inside the frame if its sideways offsets are within that depth
        // times the half-extents.
        let mut dist = 0.0f32;
        for p in points {
            let r = p - center;
            let depth = r.dot(view.forward);
            let need = (r.dot(view.right).abs() / tan_w).max(r.dot(view.up).abs() / tan_h) - depth;
            // Every point stays in front of the camera, not merely inside the frustum.
            dist = dist.max(need).max(0.05 * radius - depth);
        }
        if !(dist.is_finite() && dist > 0.05 * radius) {
            // A point-like model (or NaN): the bounding sphere's framing.
            let fov = vfov_deg.min(vfov_deg * aspect).to_radians();
            dist = radius / (0.5 * fov).sin() * 1.05;
        }
        Camera::look_at(center + dir * dist, center, Vec3::Y, vfov_deg, aspect, 0.0, dist)
    }

    /// View direction.
    pub fn forward(&self) -> Vec3 {
        self.forward
    }

    /// Primary ray through film position `film` in [0,1]² (x right, y down) with lens sample
    /// `lens` in [0,1]² (ignored for a pinhole and an orthographic camera). The direction is
    /// normalized.
    #[inline]
    pub fn ray(&self, film: Vec2, lens: Vec2) -> Ray {
        if self.orthographic {
            let o = self.ortho_origins(&[film.x; LANES], &[film.y; LANES]);
            return Ray::new(Vec3::new(o[0][0], o[1][0], o[2][0]), self.forward);
        }
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

    /// [`Camera::pinhole_dir`] of [`LANES`] film positions at once, structure-of-arrays
    /// (`fx[i]`, `fy[i]` in, coordinate k of direction i at `[k][i]` out): the same arithmetic
    /// lane by lane, so the same bits, in loops over the lanes that compile to SIMD.
    #[inline]
    pub fn pinhole_dirs(&self, fx: &[f32; LANES], fy: &[f32; LANES]) -> [[f32; LANES]; 3] {
        // As glam evaluates `forward + sx * right + sy * up` and `normalize` (a multiply by
        // 1 / √(x² + y² + z²)), operation for operation.
        let mut d = self.across_view(self.forward, fx, fy);
        let [dx, dy, dz] = &mut d;
        for ((x, y), z) in dx.iter_mut().zip(dy.iter_mut()).zip(dz.iter_mut()) {
            let inv = 1.0 / ((*x * *x) + (*y * *y) + (*z * *z)).sqrt();
            (*x, *y, *z) = (*x * inv, *y * inv, *z * inv);
        }
        d
    }

    /// The origins of an orthographic camera's rays through [`LANES`] film positions,
    /// structure-of-arrays as [`Camera::pinhole_dirs`]: the point `position + sx·right +
    /// sy·up` of the view plane (their direction is [`Camera::forward`]).
    #[inline]
    pub fn ortho_origins(&self, fx: &[f32; LANES], fy: &[f32; LANES]) -> [[f32; LANES]; 3] {
        self.across_view(self.position, fx, fy)
    }

    /// `base + sx·right + sy·up` for [`LANES`] film positions, sx and sy the positions
    /// across the view's half extents, evaluated as glam evaluates that sum.
    #[inline]
    fn across_view(&self, base: Vec3, fx: &[f32; LANES], fy: &[f32; LANES]) -> [[f32; LANES]; 3] {
        let (p, r, u) = (base, self.right, self.up);
        let mut o = [[0.0; LANES]; 3];
        for i in 0..LANES {
            let sx = (2.0 * fx[i] - 1.0) * self.half_w;
            let sy = (1.0 - 2.0 * fy[i]) * self.half_h;
            (o[0][i], o[1][i], o[2][i]) =
                ((p.x + sx * r.x) + sy * u.x, (p.y + sx * r.y) + sy * u.y, (p.z + sx * r.z) + sy * u.z);
        }
        o
    }

    /// Where the camera sees the point `p` through the lens point drawn with `lens` (in
    /// [0, 1]², ignored by a pinhole), for light splatted onto the film by a path traced from a
    /// light: the inverse of [`Camera::ray`]. `None` if `p` is behind the lens or outside the
    /// image, and for an orthographic camera (its rays reach a point from one direction only).
    #[inline]
    pub fn sees(&self, p: Vec3, lens: Vec2) -> Option<CameraView> {
        if self.orthographic {
            return None;
        }
        let o = if self.aperture_radius > 0.0 {
            let disk = concentric_disk(lens) * self.aperture_radius;
            self.position + disk.x * self.right + disk.y * self.up
        } else {
            self.position
        };
        let v = p - o;
        let depth = v.dot(self.forward);
        let d2 = v.length_squared();
        if !(depth > 0.0 && d2 > 0.0) {
            return None;
        }
        // The pinhole direction of the film position whose lens ray this is: through the point
        // where `v` crosses the plane of focus.
        let d = if self.aperture_radius > 0.0 { o + v * (self.focus_distance / depth) - self.position } else { v };
        let dz = d.dot(self.forward);
        let sx = d.dot(self.right) / (dz * self.half_w);
        let sy = d.dot(self.up) / (dz * self.half_h);
        let film = Vec2::new(0.5 * (sx + 1.0), 0.5 * (1.0 - sy));
        if !(film.x >= 0.0 && film.x < 1.0 && film.y >= 0.0 && film.y < 1.0) {
            return None;
        }
        let cos = depth / d2.sqrt();
        let area = 4.0 * self.half_w * self.half_h;
        let weight = 1.0 / (area * cos * cos * cos * d2);
        weight.is_finite().then_some(CameraView { lens: o, film, weight })
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

/// How the camera sees a point ([`Camera::sees`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraView {
    /// The lens point (the camera's position for a pinhole).
    pub lens: Vec3,
    /// The film position, in [0, 1)² as [`Camera::ray`] takes it.
    pub film: Vec2,
    /// 1 / (A cos³θ r²): A the image's area on the plane at distance 1, θ the angle of the ray
    /// to the view direction, r its length. Radiance leaving the point toward the lens, times
    /// this, times the cosine at the point and the image's pixel count, is the point's
    /// contribution (per unit of its area) to the mean of the pixel it lands in, a box filter's.
    pub weight: f32,
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_point_is_seen_where_the_cameras_ray_through_it_starts() {
        let mut rng = crate::sampler::Rng::new(5, 2);
        for aperture in [0.0, 0.3] {
            let c =
                Camera::look_at(Vec3::new(1.0, 2.0, 6.0), Vec3::new(0.2, 0.5, 0.0), Vec3::Y, 40.0, 1.5, aperture, 5.0);
            for _ in 0..200 {
                let (film, lens) = (rng.next_2d(), rng.next_2d());
                let ray = c.ray(film, lens);
                let p = ray.o + ray.d * (1.0 + 9.0 * rng.next_f32());
                let seen = c.sees(p, lens).expect("in view");
                assert!((seen.film - film).abs().max_element() < 2e-4, "{film} seen at {}", seen.film);
                assert!((seen.lens - ray.o).length() < 1e-5);
            }
            assert!(c.sees(Vec3::new(1.0, 2.0, 9.0), Vec2::splat(0.5)).is_none(), "behind the camera");
        }
        // At distance 1 the weight is the image's density per solid angle, 1 / (A cos³θ): over
        // the directions the image spans it integrates to 1.
        let c = Camera::look_at(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 60.0, 2.0, 0.0, 1.0);
        let n = 400;
        let mut total = 0.0f64;
        for i in 0..n {
            for j in 0..n {
                // Points on the unit sphere around the camera, in the image's quarter-sphere.
                let (u, v) = ((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
                let z = -u; // cos θ over (0, 1]: the half-space in front
                let r = (1.0 - z * z).sqrt();
                let phi = 2.0 * std::f64::consts::PI * v;
                let p = Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32);
                if let Some(s) = c.sees(p, Vec2::ZERO) {
                    // dω = dz dφ over the hemisphere: 2π / n² per cell.
                    total += s.weight as f64 * 2.0 * std::f64::consts::PI / (n * n) as f64;
                }
            }
        }
        // ∫ dω / (A cos³θ) over the image = (film area at distance 1) / A = 1.
        assert!((total - 1.0).abs() < 0.01, "{total}");
    }

    #[test]
    fn pinhole_directions_in_lanes_are_the_single_ones_bit_for_bit() {
        let mut rng = crate::sampler::Rng::new(3, 1);
        for (pos, at, fov, aspect) in [
            (Vec3::new(278.0, 273.0, -800.0), Vec3::new(278.0, 273.0, 0.0), 37.0, 1.0),
            (Vec3::new(7.0, 5.2, 9.5), Vec3::new(0.2, 1.3, 0.0), 34.0, 4.0 / 3.0),
            (Vec3::new(-1.0, 0.3, 2.0), Vec3::new(0.5, -0.2, -3.0), 90.0, 0.5),
        ] {
            let c = Camera::look_at(pos, at, Vec3::Y, fov, aspect, 0.0, 1.0);
            for _ in 0..200 {
                let fx: [f32; LANES] = std::array::from_fn(|_| rng.next_f32());
                let fy: [f32; LANES] = std::array::from_fn(|_| rng.next_f32());
                let d = c.pinhole_dirs(&fx, &fy);
                for i in 0..LANES {
                    let one = c.pinhole_dir(Vec2::new(fx[i], fy[i]));
                    assert_eq!([d[0][i], d[1][i], d[2][i]].map(f32::to_bits), one.to_array().map(f32::to_bits));
                }
            }
        }
    }

    #[test]
    fn orthographic_origins_in_lanes_are_the_single_rays_bit_for_bit() {
        let mut rng = crate::sampler::Rng::new(5, 2);
        for (pos, at, up, width, aspect) in [
            (Vec3::new(0.0, 0.0, 10.0), Vec3::ZERO, Vec3::Y, 4.0, 2.0),
            (Vec3::new(3.0, 7.5, -2.0), Vec3::new(0.1, 0.2, 0.3), Vec3::new(0.2, 1.0, 0.1), 13.7, 0.75),
        ] {
            let c = Camera::orthographic(pos, at, up, width, aspect);
            for _ in 0..200 {
                let fx: [f32; LANES] = std::array::from_fn(|_| rng.next_f32());
                let fy: [f32; LANES] = std::array::from_fn(|_| rng.next_f32());
                let o = c.ortho_origins(&fx, &fy);
                for i in 0..LANES {
                    let one = c.ray(Vec2::new(fx[i], fy[i]), Vec2::new(0.5, 0.5));
                    assert_eq!([o[0][i], o[1][i], o[2][i]].map(f32::to_bits), one.o.to_array().map(f32::to_bits));
                    assert_eq!(one.d, c.forward());
                }
            }
            // The view is `width` wide and `width / aspect` high, centred on the position.
            let (a, b) = (c.ray(Vec2::ZERO, Vec2::ZERO).o, c.ray(Vec2::ONE, Vec2::ZERO).o);
            assert!(((b - a).dot(c.right) - width).abs() < 1e-4 * width);
            assert!(((a - b).dot(c.up) - width / aspect).abs() < 1e-4 * width);
            assert!(((a + b) * 0.5 - pos).length() < 1e-4 * width);
        }
    }

    /// Where `p` lands on the image plane, as fractions of the half-width and half-height
    /// (±1 at the edges), and its depth along the view.
    fn project(c: &Camera, p: Vec3) -> (f32, f32, f32) {
        let r = p - c.position;
        let depth = r.dot(c.forward);
        (r.dot(c.right) / (depth * c.half_w), r.dot(c.up) / (depth * c.half_h), depth)
    }

    #[test]
    fn a_fitted_camera_keeps_every_point_in_frame_and_touches_the_margin() {
        // A flat, wide model (like the teapot), a tall one and a single-axis stick, in wide
        // and tall images.
        let models: [&[Vec3]; 3] = [
            &[
                Vec3::new(-3.0, 0.0, -2.0),
                Vec3::new(3.5, 0.2, 2.0),
                Vec3::new(0.0, 1.6, 0.3),
                Vec3::new(-1.0, 0.4, 1.9),
            ],
            &[Vec3::new(0.0, -5.0, 0.0), Vec3::new(0.5, 5.0, 0.2), Vec3::new(-0.4, 0.0, -0.3)],
            &[Vec3::new(10.0, 1.0, 1.0), Vec3::new(20.0, 1.0, 1.0)],
        ];
        for points in models {
            let bounds = points.iter().fold(Aabb::EMPTY, |b, &p| b.grow(p));
            for aspect in [0.5, 1.0, 16.0 / 9.0] {
                let c = Camera::fitting(points.iter().copied(), &bounds, 40.0, aspect);
                let mut widest = 0.0f32;
                for &p in points {
                    let (x, y, depth) = project(&c, p);
                    assert!(depth > 0.0, "{p} is behind the camera");
                    assert!(x.abs() <= 0.9 + 1e-4 && y.abs() <= 0.9 + 1e-4, "{p} outside the frame: {x} {y}");
                    widest = widest.max(x.abs()).max(y.abs());
                }
                // Tight: the limiting point sits on the 5% margin, not well inside it.
                assert!((widest - 0.9).abs() < 1e-3, "aspect {aspect}: the widest point is at {widest}, not 0.9");
                // It looks at the centre of the bounds.
                let (x, y, _) = project(&c, bounds.center());
                assert!(x.abs() < 1e-4 && y.abs() < 1e-4);
            }
        }
    }

    #[test]
    fn a_fitted_camera_is_closer_than_the_bounding_sphere_one_for_a_flat_model() {
        let points = [Vec3::new(-3.0, 0.0, -2.0), Vec3::new(3.0, 1.5, 2.0)];
        let bounds = Aabb::new(points[0], points[1]);
        let fitted = Camera::fitting(points.iter().copied(), &bounds, 40.0, 4.0 / 3.0);
        let sphere = Camera::framing(&bounds, 40.0, 4.0 / 3.0);
        let d = |c: &Camera| (c.position - bounds.center()).length();
        assert!(d(&fitted) < 0.8 * d(&sphere), "fitted {} vs bounding sphere {}", d(&fitted), d(&sphere));
    }

    #[test]
    fn a_single_point_gives_a_finite_camera_in_front_of_it() {
        let p = Vec3::new(1.0, 2.0, 3.0);
        let c = Camera::fitting(std::iter::once(p), &Aabb::from_point(p), 40.0, 1.0);
        assert!(c.position.is_finite() && c.forward.is_finite());
        let (x, y, depth) = project(&c, p);
        assert!(depth > 0.0 && x.abs() <= 1.0 && y.abs() <= 1.0, "{x} {y} {depth}");
    }
}

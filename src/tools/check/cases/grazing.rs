//! Grazing and tangent rays: a plane (two triangles) seen at less than 0.01°, and the
//! silhouettes of a sphere and a cylinder seen through a field of view a few dozen float
//! steps wide. Each scene is turned and moved off the origin (so no coordinate is
//! conveniently 0). Two checks:
//!
//! - the one-bounce white furnace (albedo 1 under a sky of 1, BSDF sampling, one bounce):
//!   every sample is exactly 1, hit or miss, unless a continuation ray hits the surface it
//!   leaves (then the path ends at the depth limit with 0), so every pixel must be 1;
//! - the camera's rays on a 96 × 96 grid, through Embree and the naive loop, must agree with
//!   double precision (see `versus_f64.rs`): grazing rays neither slip through nor hit where there
//!   is nothing.

use super::super::analytic::Solid;
use super::super::scenes::CaseSceneBuilder;
use super::super::versus_f64::{compare_with_f64, float_steps};
use super::{CaseRun, CheckError, Verdict, camera_of, one_bounce_furnace};
use crate::accel::{Accel, NaiveAccel};
use crate::light::Background;
use crate::scene::Scene;
use glam::{Quat, Vec2, Vec3};

/// The rigid motion applied to the grazing and tangent cases.
fn motion() -> (Quat, Vec3) {
    (Quat::from_axis_angle(Vec3::new(1.0, 2.0, 3.0).normalize(), 0.7), Vec3::new(123.4, -56.7, 89.1))
}

fn moved(p: Vec3) -> Vec3 {
    let (r, t) = motion();
    r * p + t
}

/// The scene of a grazing case: one shape under a uniform sky of radiance 1, and a camera
/// whose rays graze it (all in world coordinates).
pub(super) struct GrazingScene {
    pub shape: GrazedShape,
    pub eye: Vec3,
    pub look: Vec3,
    pub up: Vec3,
    pub fov: f32,
}

/// The shape the rays graze.
#[derive(Clone, Copy)]
pub(super) enum GrazedShape {
    /// Corner and the two edge vectors.
    Quad(Vec3, Vec3, Vec3),
    /// Centre and radius.
    Sphere(Vec3, f32),
    /// The axis' two ends and the radius.
    Cylinder(Vec3, Vec3, f32),
}

impl GrazingScene {
    fn scene(&self, albedo: f32) -> Scene {
        let mut builder = CaseSceneBuilder::new("grazing");
        let m = builder.diffuse(albedo);
        match self.shape {
            GrazedShape::Quad(c, e1, e2) => builder.quad(c, e1, e2, m),
            GrazedShape::Sphere(c, r) => builder.sphere(c, r, m),
            GrazedShape::Cylinder(p0, p1, r) => builder.cylinder(p0, p1, r, m),
        }
        builder.background(Background::Constant(Vec3::ONE));
        builder.camera(self.eye, self.look, self.up, self.fov);
        builder.build()
    }

    /// The shape in double precision, a point on it and its size (for the rounding scale).
    fn solid(&self) -> (Solid, Vec3, f32) {
        match self.shape {
            GrazedShape::Quad(c, e1, e2) => (
                Solid::Quad { corner: c.as_dvec3(), e1: e1.as_dvec3(), e2: e2.as_dvec3() },
                c,
                e1.length() + e2.length(),
            ),
            GrazedShape::Sphere(c, r) => (Solid::Sphere { center: c.as_dvec3(), radius: r as f64 }, c, r),
            GrazedShape::Cylinder(p0, p1, r) => {
                (Solid::Cylinder { p0: p0.as_dvec3(), p1: p1.as_dvec3(), radius: r as f64 }, p0, (p1 - p0).length() + r)
            }
        }
    }

    /// Both checks; `max_angle_deg`: the largest angle between a hitting ray and the surface
    /// the case may have (it checks that its rays really graze).
    pub fn check(&self, run: &CaseRun, max_angle_deg: f64) -> Result<Verdict, CheckError> {
        let (w, h, spp) = run.by_quality((24, 24, 8), (48, 48, 32));
        let furnace = one_bounce_furnace(run, &self.scene(1.0), w, h, spp)?;

        let scene = self.scene(1.0);
        let cam = camera_of(&scene, w, h);
        let n = run.by_quality(48, 96);
        let rays: Vec<_> = (0..n * n)
            .map(|i| cam.ray(Vec2::new((i % n) as f32 + 0.5, (i / n) as f32 + 0.5) / n as f32, Vec2::ZERO))
            .collect();
        let (solid, at, size) = self.solid();
        let embree = run.embree(&scene)?;
        let naive = NaiveAccel::new(&scene.geometry);
        let a = compare_with_f64(&[&embree as &dyn Accel, &naive], &[solid], &rays, |r| {
            float_steps(((r.o - at).length() + size) as f64)
        })?;
        run.add_nonfinite(a.nonfinite);
        let angles: Vec<f64> = rays
            .iter()
            .filter_map(|r| {
                solid
                    .hit(r.o.as_dvec3(), r.d.as_dvec3(), 0.0)
                    .map(|h| h.normal.dot(r.d.as_dvec3().normalize()).abs().asin().to_degrees())
            })
            .collect();
        let lo = angles.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = angles.iter().copied().fold(0.0, f64::max);
        Ok(Verdict::new(
            furnace,
            1e-4,
            "max |px − 1|",
            format!(
                "one-bounce furnace; {} of {} rays hit at {lo:.1e}..{hi:.1e}°; {}",
                angles.len(),
                rays.len(),
                a.summary()
            ),
        )
        .require(a.wrong == 0, format!("{} grazing answers differ from double precision", a.wrong))
        .require(
            !angles.is_empty() && hi <= max_angle_deg,
            format!("the rays are not grazing: angles up to {hi:.2e}° (want ≤ {max_angle_deg}°)"),
        ))
    }
}

/// A 2e5 × 1e5 plane seen from height 1, all rays between 0.001° and 0.009° to it.
pub fn plane(run: &CaseRun) -> Result<Verdict, CheckError> {
    let a = 0.005f32.to_radians();
    let c = Vec3::new(-1e5, 0.0, -1e3);
    let grazing = GrazingScene {
        shape: GrazedShape::Quad(
            moved(c),
            moved(Vec3::new(1e5, 0.0, -1e3)) - moved(c),
            moved(Vec3::new(-1e5, 0.0, 1e5)) - moved(c),
        ),
        eye: moved(Vec3::new(0.0, 1.0, 0.0)),
        look: moved(Vec3::new(0.0, 1.0 - 1e4 * a.tan(), 1e4)),
        up: motion().0 * Vec3::Y,
        fov: 0.008,
    };
    grazing.check(run, 0.01)
}

/// A camera 6 units from a unit sphere looking along a tangent, through a 5e-4° field of
/// view: every ray passes within 3e-5 of the silhouette.
pub fn sphere(run: &CaseRun) -> Result<Verdict, CheckError> {
    let (r, dist) = (1.0f32, 6.0f32);
    let theta = (r / dist).asin();
    let eye = Vec3::new(0.0, 0.0, dist);
    let grazing = GrazingScene {
        shape: GrazedShape::Sphere(moved(Vec3::ZERO), r),
        eye: moved(eye),
        look: moved(eye + 6.0 * Vec3::new(theta.sin(), 0.0, -theta.cos())),
        up: motion().0 * Vec3::Y,
        fov: 5e-4,
    };
    grazing.check(run, 1.0)
}

/// The same along a tangent to the side of a unit cylinder.
pub fn cylinder(run: &CaseRun) -> Result<Verdict, CheckError> {
    let (r, dist) = (1.0f32, 6.0f32);
    let theta = (r / dist).asin();
    let eye = Vec3::new(0.0, 0.3, dist);
    let grazing = GrazingScene {
        shape: GrazedShape::Cylinder(moved(Vec3::new(0.0, -2.0, 0.0)), moved(Vec3::new(0.0, 2.0, 0.0)), r),
        eye: moved(eye),
        look: moved(eye + 6.0 * Vec3::new(theta.sin(), 0.0, -theta.cos())),
        up: motion().0 * Vec3::Y,
        fov: 5e-4,
    };
    grazing.check(run, 1.0)
}

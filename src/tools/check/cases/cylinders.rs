//! Thin and long cylinders, with the two renders of the grazing cases (one-bounce furnace,
//! and coverage against double precision).

use super::grazing::{GrazedShape, GrazingScene};
use super::{CaseRun, CheckError, Verdict};
use glam::Vec3;

/// Radius 1e-3 on a 10-unit axis (1e-4 of the scene's size), seen from 5 units through a
/// 0.6° field of view: about 2.5 pixels wide at 48 pixels.
pub fn thin(run: &CaseRun) -> Result<Verdict, CheckError> {
    let axis = Vec3::new(0.8, 0.3, -0.52).normalize();
    let mid = Vec3::new(3.1, 2.7, -1.9);
    let side = axis.cross(Vec3::Y).normalize();
    let grazing = GrazingScene {
        shape: GrazedShape::Cylinder(mid - 5.0 * axis, mid + 5.0 * axis, 1e-3),
        eye: mid + 5.0 * side,
        look: mid,
        up: axis,
        fov: 0.6,
    };
    grazing.check(run, 90.0)
}

/// Radius 0.01, length 100 (1e4 radii), seen 80 units from its first end.
pub fn long(run: &CaseRun) -> Result<Verdict, CheckError> {
    let axis = Vec3::new(0.3, 0.2, 0.93).normalize();
    let p0 = Vec3::new(-40.0, -20.0, -70.0);
    let at = p0 + 80.0 * axis;
    let side = axis.cross(Vec3::Y).normalize();
    let grazing = GrazingScene {
        shape: GrazedShape::Cylinder(p0, p0 + 100.0 * axis, 0.01),
        eye: at + 1.0 * side + 0.2 * axis,
        look: at,
        up: axis,
        fov: 2.0,
    };
    grazing.check(run, 90.0)
}

/// A unit cylinder at the origin seen from 1000 units away. Its hit points are computed as
/// o + t·d, whose rounding follows the ray's origin (about 6e-5 here), not the point (about
/// 1): larger than any offset derived from the point alone, so continuation rays start
/// inside the cylinder unless the hit point is re-projected onto the surface (as spheres'
/// are) or offset by its real error bound (`Cylinder::project` gives both).
pub fn seen_from_afar(run: &CaseRun) -> Result<Verdict, CheckError> {
    let eye = Vec3::new(300.0, 400.0, 866.0);
    let grazing = GrazingScene {
        shape: GrazedShape::Cylinder(Vec3::new(-0.2, -1.0, 0.1), Vec3::new(0.3, 1.2, -0.2), 1.0),
        eye,
        look: Vec3::ZERO,
        up: Vec3::Y,
        fov: 0.2,
    };
    grazing.check(run, 90.0)
}

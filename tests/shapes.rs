//! Analytic checks of the sphere and cylinder intersection routines, through both
//! accelerators where it matters (Embree calls the same code as user geometry).

use ember::accel::{Accel, EmbreeAccel, NaiveAccel};
use ember::embree::{BuildOptions, Device};
use ember::geometry::{Cylinder, CylinderPart, Geometry, Ray, Shape, Sphere};
use glam::Vec3;

fn rel(a: f32, b: f32) -> f32 {
    (a - b).abs() / b.abs().max(1e-30)
}

#[test]
fn sphere_from_outside_hits_near_side_with_outward_normal() {
    let s = Sphere::new(Vec3::new(0.0, 0.0, 5.0), 1.0);
    let h = s.intersect(&Ray::new(Vec3::ZERO, Vec3::Z), 0.0, f32::INFINITY).unwrap();
    assert!(rel(h.t, 4.0) < 1e-6, "t = {}", h.t);
    assert!((h.ng - Vec3::new(0.0, 0.0, -1.0)).length() < 1e-6);
}

#[test]
fn sphere_from_inside_hits_far_side() {
    let s = Sphere::new(Vec3::new(1.0, 2.0, 3.0), 2.5);
    for d in [Vec3::X, -Vec3::Y, Vec3::new(1.0, 1.0, 1.0).normalize()] {
        let h = s.intersect(&Ray::new(s.center, d), 0.0, f32::INFINITY).unwrap();
        assert!(rel(h.t, 2.5) < 1e-6, "t = {}", h.t);
        // Normal points outward, along the ray.
        assert!(h.ng.dot(d) > 0.999);
    }
}

#[test]
fn sphere_tangent_and_near_tangent_rays() {
    let s = Sphere::new(Vec3::ZERO, 1.0);
    // Passing just outside: miss. Just inside: two hits close to x = 0.
    assert!(s.intersect(&Ray::new(Vec3::new(-5.0, 1.0 + 1e-5, 0.0), Vec3::X), 0.0, f32::INFINITY).is_none());
    let h = s.intersect(&Ray::new(Vec3::new(-5.0, 1.0 - 1e-4, 0.0), Vec3::X), 0.0, f32::INFINITY).unwrap();
    let expected = 5.0 - (1.0f32 - (1.0f32 - 1e-4).powi(2)).sqrt();
    assert!(rel(h.t, expected) < 1e-5, "t = {} vs {}", h.t, expected);
    // Exactly tangent: if reported at all, at the touching point.
    if let Some(h) = s.intersect(&Ray::new(Vec3::new(-5.0, 1.0, 0.0), Vec3::X), 0.0, f32::INFINITY) {
        assert!((h.t - 5.0).abs() < 1e-3, "tangent t = {}", h.t);
    }
}

#[test]
fn sphere_small_and_far_is_precise() {
    // The textbook b² − 4ac loses the whole discriminant here; the RTG ch. 7 form does not.
    let s = Sphere::new(Vec3::new(0.0, 0.0, 1e4), 0.01);
    let h = s.intersect(&Ray::new(Vec3::ZERO, Vec3::Z), 0.0, f32::INFINITY).unwrap();
    assert!((h.t - (1e4 - 0.01)).abs() < 2e-3, "t = {}", h.t);
    // Off-centre by half the radius: still a hit, at the right depth.
    let h = s
        .intersect(&Ray::new(Vec3::new(0.005, 0.0, 0.0), Vec3::Z), 0.0, f32::INFINITY)
        .expect("off-centre ray must hit");
    let expected = 1e4 - (0.01f32 * 0.01 - 0.005 * 0.005).sqrt();
    assert!((h.t - expected).abs() < 2e-3, "t = {} vs {}", h.t, expected);
}

#[test]
fn sphere_texture_coordinates_are_latitude_and_longitude_about_y() {
    // Y up: the poles at ±Y, longitude ½ toward +Z, growing toward +X (east, seen from +Z).
    assert!((Sphere::uv(Vec3::Z).0 - 0.5).abs() < 1e-6);
    assert!((Sphere::uv(Vec3::X).0 - 0.75).abs() < 1e-6);
    assert!((Sphere::uv(-Vec3::X).0 - 0.25).abs() < 1e-6);
    assert!(Sphere::uv(Vec3::new(-1e-7, 0.0, -1.0)).0 < 1e-6);
    assert!((Sphere::uv(Vec3::Y).1 - 1.0).abs() < 1e-6);
    assert!((Sphere::uv(-Vec3::Y).1 - 0.0).abs() < 1e-6);
    assert!((Sphere::uv(Vec3::Z).1 - 0.5).abs() < 1e-6);
}

#[test]
fn cylinder_side_and_cap_hits() {
    let c = Cylinder::new(Vec3::ZERO, Vec3::new(0.0, 0.0, 2.0), 0.5);
    // Side hit from outside, perpendicular to the axis.
    let ray = Ray::new(Vec3::new(-3.0, 0.0, 1.0), Vec3::X);
    let (t, part) = c.closest_part(&ray, 0.0, f32::INFINITY).unwrap();
    assert_eq!(part, CylinderPart::Side);
    assert!(rel(t, 2.5) < 1e-6);
    let h = c.intersect(&ray, 0.0, f32::INFINITY).unwrap();
    assert!((h.ng - Vec3::new(-1.0, 0.0, 0.0)).length() < 1e-6);
    // Axis-parallel rays hit the caps.
    let (t, part) = c.closest_part(&Ray::new(Vec3::new(0.1, 0.2, -1.0), Vec3::Z), 0.0, f32::INFINITY).unwrap();
    assert_eq!(part, CylinderPart::Cap0);
    assert!(rel(t, 1.0) < 1e-6);
    let h = c.intersect(&Ray::new(Vec3::new(0.1, 0.2, 5.0), -Vec3::Z), 0.0, f32::INFINITY).unwrap();
    assert!(rel(h.t, 3.0) < 1e-6 && (h.ng - Vec3::Z).length() < 1e-6);
    // Axis-parallel outside the radius: miss.
    assert!(c.intersect(&Ray::new(Vec3::new(0.6, 0.0, -1.0), Vec3::Z), 0.0, f32::INFINITY).is_none());
    // Beyond the ends: miss.
    assert!(c.intersect(&Ray::new(Vec3::new(-3.0, 0.0, 2.1), Vec3::X), 0.0, f32::INFINITY).is_none());
}

#[test]
fn cylinder_from_inside_and_tangent() {
    let c = Cylinder::new(Vec3::ZERO, Vec3::new(0.0, 0.0, 2.0), 0.5);
    let h = c.intersect(&Ray::new(Vec3::new(0.0, 0.0, 1.0), Vec3::Y), 0.0, f32::INFINITY).unwrap();
    assert!(rel(h.t, 0.5) < 1e-6 && h.ng.dot(Vec3::Y) > 0.999, "{h:?}");
    let (_, part) = c.closest_part(&Ray::new(Vec3::new(0.0, 0.0, 1.0), Vec3::Z), 0.0, f32::INFINITY).unwrap();
    assert_eq!(part, CylinderPart::Cap1);
    assert!(c.intersect(&Ray::new(Vec3::new(-3.0, 0.5 + 1e-5, 1.0), Vec3::X), 0.0, f32::INFINITY).is_none());
    assert!(c.intersect(&Ray::new(Vec3::new(-3.0, 0.5 - 1e-4, 1.0), Vec3::X), 0.0, f32::INFINITY).is_some());
}

#[test]
fn cylinder_arbitrary_axis_matches_rotated_frame() {
    // A cylinder along (1,1,1) hit by a ray perpendicular to it through its middle.
    let a = Vec3::new(1.0, 1.0, 1.0).normalize();
    let c = Cylinder::new(Vec3::ZERO, a * 4.0, 0.25);
    let mid = a * 2.0;
    let perp = Vec3::new(1.0, -1.0, 0.0).normalize();
    let h = c.intersect(&Ray::new(mid + perp * 3.0, -perp), 0.0, f32::INFINITY).unwrap();
    assert!(rel(h.t, 2.75) < 1e-5, "t = {}", h.t);
    assert!(h.ng.normalize().dot(perp) > 0.9999);
    let b = c.bounds();
    assert!(b.min.cmple(Vec3::splat(-0.2)).all() && b.max.cmpge(a * 4.0 + 0.2).all(), "{b:?}");
    // Ray along the axis from outside hits the near cap at distance 1.
    let h = c.intersect(&Ray::new(-a, a), 0.0, f32::INFINITY).unwrap();
    assert!(rel(h.t, 1.0) < 1e-5 && h.ng.dot(-a) > 0.9999);
}

#[test]
fn user_geometry_through_embree_gives_the_same_answers() {
    let spheres: Vec<Sphere> =
        vec![Sphere::new(Vec3::new(0.0, 0.0, 5.0), 1.0), Sphere::new(Vec3::new(3.0, 0.0, 5.0), 0.5)];
    let cylinders = vec![Cylinder::new(Vec3::new(-3.0, -1.0, 5.0), Vec3::new(-3.0, 1.0, 5.0), 0.5)];
    let geometry = vec![Geometry::Spheres(spheres.into()), Geometry::Cylinders(cylinders.into())];
    let device = Device::new().unwrap();
    let e = EmbreeAccel::new(&device, &geometry, BuildOptions::default()).unwrap();
    let n = NaiveAccel::new(&geometry);
    for (o, d, geom, prim, t) in [
        (Vec3::ZERO, Vec3::Z, 0, 0, 4.0),
        (Vec3::new(3.0, 0.0, 0.0), Vec3::Z, 0, 1, 4.5),
        (Vec3::new(-3.0, 0.0, 0.0), Vec3::Z, 1, 0, 4.5),
        (Vec3::new(-3.0, -5.0, 5.0), Vec3::Y, 1, 0, 4.0),
        (Vec3::new(0.0, 0.0, 5.0), Vec3::X, 0, 0, 1.0),
    ] {
        let ray = Ray::new(o, d);
        for accel in [&e as &dyn Accel, &n] {
            let h = accel.intersect(&ray, 0.0, f32::INFINITY).unwrap().unwrap();
            assert_eq!((h.geom, h.prim), (geom, prim), "{} {ray:?}", accel.name());
            assert!(rel(h.t, t) < 1e-6, "{}: t = {} vs {t}", accel.name(), h.t);
            assert!(accel.occluded(&ray, 0.0, f32::INFINITY).unwrap());
            assert!(!accel.occluded(&ray, 0.0, t * 0.99).unwrap(), "{}: occluded before the hit", accel.name());
        }
    }
}

#[test]
fn cylinder_is_watertight_at_its_rim() {
    // In the plane of the axis, through the rim circle of the first cap: the side test (height
    // in range) and the cap test (radius in range) can both fail by rounding there; the
    // entry must still be found at t = √2, not the far side at 2√2.
    let c = Cylinder::new(Vec3::new(-2.0, 3.0, 0.5), Vec3::new(2.0, 3.0, 0.5), 0.5);
    let ray = Ray::new(Vec3::new(-3.0, 3.0, -1.0), Vec3::new(1.0, 0.0, 1.0).normalize());
    let h = c.intersect(&ray, 0.0, f32::INFINITY).unwrap();
    assert!(rel(h.t, std::f32::consts::SQRT_2) < 1e-6, "t = {}", h.t);
    // A fan of rays through points of the rim, from outside: every one hits near the rim.
    for k in 0..64 {
        let phi = k as f32 / 64.0 * std::f32::consts::TAU;
        let rim = Vec3::new(-2.0, 3.0 + 0.5 * phi.cos(), 0.5 + 0.5 * phi.sin());
        let o = rim + Vec3::new(-1.0, 0.7 * phi.cos(), 0.7 * phi.sin());
        let h = c.intersect(&Ray::new(o, rim - o), 0.0, f32::INFINITY).unwrap_or_else(|| panic!("rim ray {k} missed"));
        assert!((h.t - 1.0).abs() < 1e-5, "rim ray {k}: t = {}", h.t);
    }
}

#[test]
fn near_tangent_hits_have_normals_facing_the_ray() {
    // Rays a few float steps from tangency, far from the origin: the normal computed from
    // the rounded hit point can face either way; an entering hit must face the ray.
    let s = Sphere::new(Vec3::new(123.4, -56.7, 89.1), 1.0);
    let c = Cylinder::new(Vec3::new(123.4, -58.7, 89.1), Vec3::new(123.4, -54.7, 89.1), 1.0);
    let (mut sphere_hits, mut cylinder_hits) = (0, 0);
    for k in -200..200 {
        let o = Vec3::new(123.4 + 1.0 + k as f32 * 2e-6, -56.7, 89.1 + 6.0);
        let ray = Ray::new(o, -Vec3::Z);
        if let Some(h) = s.intersect(&ray, 0.0, f32::INFINITY) {
            sphere_hits += 1;
            assert!(h.ng.dot(ray.d) < 0.0, "sphere, offset {k}: {h:?}");
        }
        if let Some(h) = c.intersect(&ray, 0.0, f32::INFINITY) {
            cylinder_hits += 1;
            assert!(h.ng.dot(ray.d) < 0.0, "cylinder, offset {k}: {h:?}");
        }
    }
    assert!(sphere_hits > 100 && cylinder_hits > 100, "{sphere_hits} {cylinder_hits}");
}

#[test]
fn cylinder_projection_lands_on_the_surface() {
    let c = Cylinder::new(Vec3::new(0.2, -1.0, 0.1), Vec3::new(0.3, 1.2, -0.2), 1.0);
    let a = (c.p1 - c.p0).normalize();
    let side = c.p0 + 1.1 * a + 1.0003 * a.any_orthonormal_vector();
    let (q, err) = c.project(side, side - (c.p0 + 1.1 * a));
    let r = q - c.p0 - (q - c.p0).dot(a) * a;
    assert!((r.length() - 1.0).abs() < 1e-6 && ((q - c.p0).dot(a) - 1.1).abs() < 1e-6, "{q}");
    assert!(err.max_element() > 0.0 && err.max_element() < 1e-5, "{err}");
    let cap = c.p1 + 0.5 * a.any_orthonormal_vector() + 2e-4 * a;
    let (q, _) = c.project(cap, a);
    assert!((q - c.p1).dot(a).abs() < 1e-6, "{q}");
}

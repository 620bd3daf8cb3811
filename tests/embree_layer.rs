//! The safe Embree layer: errors instead of aborts, any drop order, panics contained, and the
//! hazards listed in docs/embree-notes.md ruled out.

use ember::accel::{Accel, EmbreeAccel};
use ember::embree::{BuildOptions, Device, EmbreeError, SceneBuilder};
use ember::geometry::{Aabb, Geometry, Ray, RayPacket, Shape, ShapeHit, Sphere, TriMesh};
use glam::Vec3;
use std::sync::Arc;

fn quad() -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let v = vec![
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(-1.0, 1.0, 0.0),
    ];
    (v, vec![[0, 1, 2], [0, 2, 3]])
}

#[test]
fn invalid_device_config_is_an_error_not_an_abort() {
    let e = Device::with_config("threads=abc").unwrap_err();
    let text = e.to_string();
    assert!(matches!(e, EmbreeError::DeviceCreation { .. }), "{e:?}");
    assert!(text.contains("threads=abc") && text.contains("RTC_ERROR"), "{text}");
}

#[test]
fn valid_config_and_version() {
    let d = Device::with_config("threads=1").unwrap();
    assert!(d.version().starts_with('3') || d.version().starts_with('4'), "{}", d.version());
    assert!(d.supports_required_features());
}

#[test]
fn scene_outlives_dropped_device_handle() {
    let device = Device::new().unwrap();
    let (v, i) = quad();
    let mut b = SceneBuilder::new(&device, BuildOptions::default()).unwrap();
    b.add_triangles(&v, &i).unwrap();
    drop(device);
    let scene = b.commit().unwrap();
    let h = scene.intersect(&Ray::new(Vec3::new(0.2, 0.3, 1.0), -Vec3::Z), 0.0, f32::INFINITY).unwrap().unwrap();
    assert!((h.t - 1.0).abs() < 1e-6);
    drop(scene);
}

#[test]
fn builder_dropped_uncommitted_and_device_first_or_last() {
    let device = Device::new().unwrap();
    let (v, i) = quad();
    {
        let mut b = SceneBuilder::new(&device, BuildOptions::default()).unwrap();
        b.add_triangles(&v, &i).unwrap();
        b.add_shapes(Arc::from(vec![Sphere::new(Vec3::ZERO, 1.0)])).unwrap();
    } // dropped before commit
    let s1 = {
        let mut b = SceneBuilder::new(&device, BuildOptions::default()).unwrap();
        b.add_shapes(Arc::from(vec![Sphere::new(Vec3::ZERO, 1.0)])).unwrap();
        b.commit().unwrap()
    };
    let s2 = {
        let mut b = SceneBuilder::new(&device, BuildOptions::default()).unwrap();
        b.add_triangles(&v, &i).unwrap();
        b.commit().unwrap()
    };
    drop(s1);
    drop(device);
    assert!(s2.occluded(&Ray::new(Vec3::new(0.0, 0.0, 1.0), -Vec3::Z), 0.0, 2.0).unwrap());
}

#[test]
fn out_of_range_indices_are_refused_before_embree_sees_them() {
    let device = Device::new().unwrap();
    let mut b = SceneBuilder::new(&device, BuildOptions::default()).unwrap();
    let e = b.add_triangles(&[Vec3::ZERO, Vec3::X, Vec3::Y], &[[0, 1, 3]]).unwrap_err();
    assert!(e.to_string().contains("vertex 3"), "{e}");
    let e = b.add_triangles(&[Vec3::ZERO], &[]).unwrap_err();
    assert!(matches!(e, EmbreeError::InvalidInput(_)));
    assert!(TriMesh::new("m", vec![Vec3::ZERO], vec![[0, 0, 1]], vec![], vec![]).is_err());
}

/// A shape whose callbacks panic on demand.
struct Grenade {
    in_bounds: bool,
}

impl Shape for Grenade {
    fn bounds(&self) -> Aabb {
        if self.in_bounds {
            panic!("bounds exploded");
        }
        Aabb::new(Vec3::splat(-1.0), Vec3::splat(1.0))
    }
    fn intersect(&self, _: &Ray, _: f32, _: f32) -> Option<ShapeHit> {
        panic!("intersect exploded")
    }
}

#[test]
fn panic_in_intersect_callback_is_an_error_after_the_query() {
    let device = Device::new().unwrap();
    let mut b = SceneBuilder::new(&device, BuildOptions::default()).unwrap();
    b.add_shapes(Arc::from(vec![Grenade { in_bounds: false }])).unwrap();
    let scene = b.commit().unwrap();
    let ray = Ray::new(Vec3::new(0.0, 0.0, 5.0), -Vec3::Z);
    let e = scene.intersect(&ray, 0.0, f32::INFINITY).unwrap_err();
    assert!(matches!(&e, EmbreeError::CallbackPanic(m) if m.contains("intersect exploded")), "{e:?}");
    // occludes() defaults to intersect(): it panics too, and the error is sticky.
    assert!(scene.occluded(&ray, 0.0, f32::INFINITY).is_err());
    // A ray that misses the bounds never calls back, but the scene stays poisoned.
    assert!(scene.intersect(&Ray::new(Vec3::new(9.0, 9.0, 9.0), Vec3::X), 0.0, 1.0).is_err());
}

#[test]
fn deferred_and_packet_queries_report_a_callback_panic_afterwards() {
    // The path tracer's queries (one by one, and camera rays 8 at a time) do not check after
    // each ray; it asks `callback_failure` once per packet of paths. The panic must show there.
    let device = Device::new().unwrap();
    for packet in [false, true] {
        let mut b = SceneBuilder::new(&device, BuildOptions::default()).unwrap();
        b.add_shapes(Arc::from(vec![Grenade { in_bounds: false }])).unwrap();
        let scene = b.commit().unwrap();
        assert!(scene.callback_failure().is_ok(), "no query yet");
        let ray = Ray::new(Vec3::new(0.0, 0.0, 5.0), -Vec3::Z);
        if packet {
            let rays = RayPacket::splat(&ray);
            let active = std::array::from_fn(|i| i % 2 == 0);
            let _ = scene.intersect8_deferred(&rays, active, 0.0, f32::INFINITY);
        } else {
            let _ = scene.intersect_deferred(&ray, 0.0, f32::INFINITY);
        }
        let e = scene.callback_failure().unwrap_err();
        assert!(
            matches!(&e, EmbreeError::CallbackPanic(m) if m.contains("intersect exploded")),
            "packet {packet}: {e:?}"
        );
    }
}

#[test]
fn panic_in_bounds_callback_fails_the_commit() {
    let device = Device::new().unwrap();
    let mut b = SceneBuilder::new(&device, BuildOptions::default()).unwrap();
    b.add_shapes(Arc::from(vec![Grenade { in_bounds: true }])).unwrap();
    let e = b.commit().err().expect("commit must fail");
    assert!(matches!(&e, EmbreeError::CallbackPanic(m) if m.contains("bounds exploded")), "{e:?}");
}

#[test]
fn invalid_primitives_are_skipped_not_fatal() {
    // NaN centre, zero and negative radius: bounds are invalid, Embree skips them.
    let spheres = vec![
        Sphere::new(Vec3::new(f32::NAN, 0.0, 0.0), 1.0),
        Sphere::new(Vec3::ZERO, 0.0),
        Sphere::new(Vec3::ZERO, -1.0),
        Sphere::new(Vec3::new(0.0, 0.0, -3.0), 1.0),
    ];
    let device = Device::new().unwrap();
    let accel = EmbreeAccel::new(&device, &[Geometry::Spheres(spheres.into())], BuildOptions::default()).unwrap();
    let h = accel.intersect(&Ray::new(Vec3::new(0.0, 0.0, 5.0), -Vec3::Z), 0.0, f32::INFINITY).unwrap().unwrap();
    assert_eq!(h.prim, 3);
}

#[test]
fn queries_from_many_threads_agree() {
    use rayon::prelude::*;
    let device = Device::new().unwrap();
    let spheres: Vec<Sphere> = (0..100).map(|i| Sphere::new(Vec3::new(i as f32 * 3.0, 0.0, 0.0), 1.0)).collect();
    let accel = EmbreeAccel::new(&device, &[Geometry::Spheres(spheres.into())], BuildOptions::default()).unwrap();
    let hits: Vec<u32> = (0..100u32)
        .into_par_iter()
        .map(|i| {
            let ray = Ray::new(Vec3::new(i as f32 * 3.0, 0.0, 10.0), -Vec3::Z);
            accel.intersect(&ray, 0.0, f32::INFINITY).unwrap().unwrap().prim
        })
        .collect();
    assert_eq!(hits, (0..100).collect::<Vec<_>>());
}

/// Embree asserts on rays with a NaN or huge (beyond 1.844e18) origin or direction component,
/// or a NaN tnear/tfar: the Debian build aborts the process (exit 134). The safe layer
/// answers them itself: no hit, blocked. Run in this process: an abort would fail the test.
#[test]
fn rays_embree_refuses_are_answered_without_calling_it() {
    let device = Device::new().unwrap();
    let (v, i) = quad();
    let mut b = SceneBuilder::new(&device, BuildOptions::default()).unwrap();
    b.add_triangles(&v, &i).unwrap();
    b.add_shapes(Arc::from(vec![Sphere::new(Vec3::new(0.0, 0.0, -3.0), 1.0)])).unwrap();
    let scene = b.commit().unwrap();
    let good = Ray::new(Vec3::new(0.2, 0.3, 1.0), -Vec3::Z);
    let bad = [
        Ray::new(Vec3::new(1e19, 0.0, 1.0), -Vec3::Z),
        Ray::new(Vec3::new(0.2, -2e18, 1.0), -Vec3::Z),
        Ray::new(Vec3::new(0.2, 0.3, f32::NAN), -Vec3::Z),
        Ray::new(Vec3::new(0.2, 0.3, 1.0), Vec3::new(0.0, f32::NAN, -1.0)),
        Ray::new(Vec3::new(0.2, 0.3, 1.0), Vec3::new(0.0, 0.0, -1e19)),
    ];
    for r in &bad {
        assert_eq!(scene.intersect(r, 0.0, f32::INFINITY).unwrap(), None, "{r:?}");
        assert!(scene.occluded(r, 0.0, f32::INFINITY).unwrap(), "{r:?}");
    }
    assert_eq!(scene.intersect(&good, f32::NAN, f32::INFINITY).unwrap(), None);
    assert!(scene.occluded(&good, 0.0, f32::NAN).unwrap());
    // At the limit it is traced: 1e18 away along the axis still hits the quad.
    let far = Ray::new(Vec3::new(0.2, 0.3, 1e18), -Vec3::Z);
    assert!(scene.intersect(&far, 0.0, f32::INFINITY).unwrap().is_some());
    // In packets, refused lanes answer the same and the others are traced as usual.
    let mut rays = [good; 8];
    rays[1] = bad[0];
    rays[5] = bad[3];
    let active = [true, true, true, true, true, true, true, false];
    let rays = RayPacket::from_rays(&rays);
    let hits = scene.intersect8_deferred(&rays, active, 0.0, f32::INFINITY);
    let blocked = scene.occluded8_deferred(&rays, active, 0.0, [f32::INFINITY; 8]);
    for i in 0..8 {
        let expect_hit = active[i] && i != 1 && i != 5;
        assert_eq!(hits[i].is_some(), expect_hit, "lane {i}");
        assert_eq!(blocked[i], active[i], "lane {i}");
    }
}

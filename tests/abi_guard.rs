//! The ray-hit memory layout decided from the running library's version is the one the library
//! writes: guard words placed right after the memory survive every query, on triangles and on
//! user geometry, with either backend (`cargo test`, `cargo test --features embree4`).
//!
//! Each probe runs the production query path (same FFI call, same callbacks) in memory whose
//! words past the 80 bytes common to all layouts start as `GUARD`. A hit must change exactly
//! the layout's extra hit word: none for the 80-byte `RTCRayHit` of Embree 3 and 4.0–4.2, word
//! 20 (`instPrimID`, set to `RTC_INVALID_GEOMETRY_ID` as no instance is involved) for the
//! 96-byte one of Embree 4.3+. On an Embree 4.4 library the second case is the hazard itself:
//! the library writes 4 bytes past an 80-byte `RTCRayHit`.

mod common;

use ember::embree::{
    BuildOptions, Device, EmbreeVersion, GUARD, GuardProbe, INVALID_ID, PROBE_WORDS, RayHitLayout, Scene, SceneBuilder,
};
use ember::geometry::{Ray, RayPacket, Sphere};
use ember::sampler::Rng;
use glam::Vec3;
use std::sync::Arc;

/// Word index of `instPrimID` in ray-hit memory (ray: 12 words, then 8 common hit words).
const INST_PRIM_WORD: usize = 20;

fn quad_scene(device: &Device) -> Scene {
    let v =
        [Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, -1.0, 0.0), Vec3::new(1.0, 1.0, 0.0), Vec3::new(-1.0, 1.0, 0.0)];
    let mut b = SceneBuilder::new(device, BuildOptions::default()).unwrap();
    b.add_triangles(&v, &[[0, 1, 2], [0, 2, 3]]).unwrap();
    b.commit().unwrap()
}

fn sphere_scene(device: &Device) -> Scene {
    let mut b = SceneBuilder::new(device, BuildOptions::default()).unwrap();
    b.add_shapes(Arc::from(vec![Sphere::new(Vec3::ZERO, 1.0), Sphere::new(Vec3::new(3.0, 0.0, 0.0), 0.5)])).unwrap();
    b.commit().unwrap()
}

/// Checks what a closest-hit probe wrote past the common 80 bytes.
fn check_hit_words(p: &GuardProbe, hit: bool, what: &str) {
    let written = p.written_past_initialised();
    match (p.layout, hit) {
        (_, false) | (RayHitLayout::NoInstPrimId, true) => {
            assert!(
                written.is_empty(),
                "{what}: words {written:?} past the ray-hit memory were overwritten: {:x?}",
                p.words
            )
        }
        (RayHitLayout::WithInstPrimId, true) => {
            assert_eq!(written, vec![INST_PRIM_WORD], "{what}: {:x?}", p.words);
            assert_eq!(p.words[INST_PRIM_WORD], INVALID_ID, "{what}: instPrimID");
        }
    }
    // Whatever the layout, nothing beyond 96 bytes is ever touched.
    assert!(p.words[24..PROBE_WORDS].iter().all(|&w| w == GUARD), "{what}: {:x?}", p.words);
}

#[test]
fn the_layout_is_the_one_known_for_the_running_version() {
    let device = Device::new().unwrap();
    let v = device.embree_version();
    let major = if device.backend() == "embree4" { 4 } else { 3 };
    assert_eq!(v.major, major, "{} backend running Embree {v}", device.backend());
    assert_eq!(RayHitLayout::for_library(major, v).unwrap(), device.ray_hit_layout());
    assert_eq!(device.version(), v.to_string());
    eprintln!("Embree {v} through {} bindings: {}", device.backend(), device.ray_hit_layout());
    if v >= EmbreeVersion::new(4, 3, 0) {
        assert_eq!(device.ray_hit_layout(), RayHitLayout::WithInstPrimId);
    }
}

#[test]
fn triangle_hits_write_nothing_past_the_ray_hit_memory() {
    let device = Device::new().unwrap();
    let scene = quad_scene(&device);
    for i in 0..25 {
        let (x, y) = (-0.9 + 0.075 * i as f32, 0.8 - 0.07 * i as f32);
        let ray = Ray::new(Vec3::new(x, y, 2.0), -Vec3::Z);
        let (hit, probe) = scene.probe_intersect(&ray, 0.0, f32::INFINITY).unwrap();
        let hit = hit.expect("the quad is hit");
        assert!((hit.t - 2.0).abs() < 1e-6 && hit.geom == 0, "{hit:?}");
        assert_eq!(Some(hit), scene.intersect(&ray, 0.0, f32::INFINITY).unwrap());
        check_hit_words(&probe, true, &format!("triangle hit {i}"));
    }
    // Misses, beside the quad and beyond tmax.
    for (o, tmax) in [(Vec3::new(1.5, 0.0, 2.0), f32::INFINITY), (Vec3::new(0.0, 0.0, 2.0), 1.0)] {
        let (hit, probe) = scene.probe_intersect(&Ray::new(o, -Vec3::Z), 0.0, tmax).unwrap();
        assert!(hit.is_none());
        check_hit_words(&probe, false, "triangle miss");
    }
}

#[test]
fn user_geometry_hits_write_nothing_past_the_ray_hit_memory() {
    let device = Device::new().unwrap();
    let scene = sphere_scene(&device);
    for (i, (o, prim, t)) in
        [(Vec3::new(0.0, 0.0, 5.0), 0, 4.0), (Vec3::new(3.0, 0.0, 5.0), 1, 4.5), (Vec3::new(0.3, 0.2, 5.0), 0, 0.0)]
            .into_iter()
            .enumerate()
    {
        let ray = Ray::new(o, -Vec3::Z);
        let (hit, probe) = scene.probe_intersect(&ray, 0.0, f32::INFINITY).unwrap();
        let hit = hit.expect("a sphere is hit");
        assert_eq!((hit.geom, hit.prim), (0, prim));
        if t > 0.0 {
            assert!((hit.t - t).abs() < 1e-5, "{hit:?}");
        }
        assert_eq!(Some(hit), scene.intersect(&ray, 0.0, f32::INFINITY).unwrap());
        check_hit_words(&probe, true, &format!("sphere hit {i}"));
    }
    // Through the bounding box of sphere 0 but outside the sphere: the callback runs and misses.
    let corner = Ray::new(Vec3::new(0.9, 0.9, 5.0), -Vec3::Z);
    let (hit, probe) = scene.probe_intersect(&corner, 0.0, f32::INFINITY).unwrap();
    assert!(hit.is_none());
    check_hit_words(&probe, false, "sphere miss");
}

#[test]
fn occlusion_queries_write_only_the_ray() {
    let device = Device::new().unwrap();
    for (name, scene) in [("quad", quad_scene(&device)), ("spheres", sphere_scene(&device))] {
        for (o, expected) in [
            (Vec3::new(0.0, 0.0, 5.0), true),
            (Vec3::new(0.9, 0.9, 5.0), name == "quad"), // inside the sphere's box, outside the sphere
            (Vec3::new(7.0, 7.0, 5.0), false),
        ] {
            let ray = Ray::new(o, -Vec3::Z);
            let (occluded, probe) = scene.probe_occluded(&ray, 0.0, f32::INFINITY).unwrap();
            assert_eq!(occluded, expected, "{name} from {o}");
            assert_eq!(occluded, scene.occluded(&ray, 0.0, f32::INFINITY).unwrap());
            assert!(probe.written_past_initialised().is_empty(), "{name}: {:x?}", probe.words);
        }
    }
}

#[test]
fn random_rays_on_a_mixed_scene_keep_the_guards() {
    let device = Device::new().unwrap();
    let geometry = common::teapot_spheres_cylinders();
    let accel = ember::accel::EmbreeAccel::new(&device, &geometry, BuildOptions::default()).unwrap();
    let scene = accel.scene();
    let mut rng = Rng::new(8, 4);
    let (mut hits, mut user_hits) = (0, 0);
    for i in 0..3000 {
        let o = Vec3::new(rng.next_f32() * 12.0 - 6.0, rng.next_f32() * 8.0 - 2.0, rng.next_f32() * 10.0 - 5.0);
        let ray = Ray::new(o, common::unit_vector(&mut rng));
        let (hit, probe) = scene.probe_intersect(&ray, 0.0, f32::INFINITY).unwrap();
        assert_eq!(hit, scene.intersect(&ray, 0.0, f32::INFINITY).unwrap(), "ray {i}");
        check_hit_words(&probe, hit.is_some(), &format!("ray {i}"));
        let (occluded, probe) = scene.probe_occluded(&ray, 0.0, f32::INFINITY).unwrap();
        assert_eq!(occluded, hit.is_some(), "ray {i}");
        assert!(probe.written_past_initialised().is_empty(), "ray {i}: {:x?}", probe.words);
        if let Some(h) = hit {
            hits += 1;
            user_hits += usize::from(h.geom as usize >= geometry.len() - 2);
        }
    }
    // Both kinds of geometry were exercised.
    assert!(hits > 300 && user_hits > 30, "{hits} hits, {user_hits} on user geometry");
}

/// Checks what a packet probe wrote past the common 640 bytes: nothing for the 80-byte
/// layout; for the 96-byte one, exactly the `instPrimID` lanes of the lanes that hit (set to
/// `RTC_INVALID_GEOMETRY_ID`); beyond 672 bytes, nothing ever.
fn check_packet_words(p: &ember::embree::PacketProbe, hits: &[bool; 8], what: &str) {
    use ember::embree::PACKET_COMMON_WORDS;
    let written = p.written_past_common();
    let expected: Vec<usize> = match p.layout {
        RayHitLayout::NoInstPrimId => vec![],
        RayHitLayout::WithInstPrimId => (0..8).filter(|&i| hits[i]).map(|i| PACKET_COMMON_WORDS + i).collect(),
    };
    assert_eq!(written, expected, "{what}: {:x?}", &p.words[PACKET_COMMON_WORDS..]);
    for &w in &expected {
        assert_eq!(p.words[w], INVALID_ID, "{what}: instPrimID lane {}", w - PACKET_COMMON_WORDS);
    }
}

#[test]
fn packets_answer_as_single_rays_and_keep_the_guards() {
    let device = Device::new().unwrap();
    let geometry = common::teapot_spheres_cylinders();
    let accel = ember::accel::EmbreeAccel::new(&device, &geometry, BuildOptions::default()).unwrap();
    let scene = accel.scene();
    let mut rng = Rng::new(8, 5);
    let (mut hits, mut user_hits) = (0, 0);
    for k in 0..400 {
        // Coherent packets (one origin, nearby directions) as the path tracer sends them, and
        // every 4th one with idle lanes.
        let o = Vec3::new(rng.next_f32() * 12.0 - 6.0, rng.next_f32() * 8.0 - 2.0, rng.next_f32() * 10.0 - 5.0);
        let d = common::unit_vector(&mut rng);
        let rays: [Ray; 8] = std::array::from_fn(|_| {
            let jitter = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 0.02 - Vec3::splat(0.01);
            Ray::new(o, (d + jitter).normalize())
        });
        let active: [bool; 8] = std::array::from_fn(|i| k % 4 != 0 || i % 3 != 1);
        let mut rays = RayPacket::from_rays(&rays);
        // Half of them hinted coherent, as the camera's are: the hint changes how Embree
        // traverses, not what it answers.
        rays.coherent = k % 2 == 0;
        let (packet, probe) = scene.probe_intersect8(&rays, active, 0.0, f32::INFINITY).unwrap();
        assert_eq!(packet, scene.intersect8_deferred(&rays, active, 0.0, f32::INFINITY), "packet {k}");
        for i in 0..8 {
            let single = if active[i] { scene.intersect(&rays.ray(i), 0.0, f32::INFINITY).unwrap() } else { None };
            match (packet[i], single) {
                (None, None) => {}
                (Some(a), Some(b)) => {
                    // Same primitive; distances and coordinates as close as SIMD and scalar
                    // arithmetic allow.
                    assert_eq!((a.geom, a.prim), (b.geom, b.prim), "packet {k} lane {i}");
                    assert!((a.t - b.t).abs() <= 1e-5 * a.t.max(1.0), "packet {k} lane {i}: {a:?} {b:?}");
                    assert!((a.u - b.u).abs() < 1e-4 && (a.v - b.v).abs() < 1e-4, "packet {k} lane {i}: {a:?} {b:?}");
                    hits += 1;
                    user_hits += usize::from(a.geom as usize >= geometry.len() - 2);
                }
                (a, b) => panic!("packet {k} lane {i}: packet {a:?}, single ray {b:?}"),
            }
        }
        let hit_lanes = std::array::from_fn(|i| packet[i].is_some());
        check_packet_words(&probe, &hit_lanes, &format!("packet {k}"));
    }
    assert!(hits > 300 && user_hits > 30, "{hits} hits, {user_hits} on user geometry");
}

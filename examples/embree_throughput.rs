//! Closest-hit throughput of the Embree layer on the teapot and the bunny, for comparing the
//! Embree 3 and Embree 4 builds (`scripts/embree3-vs-4.sh` runs it under both).
//!
//!     cargo run --release --example embree_throughput [-- SIDE REPEATS]
//!
//! Rays: SIDE² pinhole camera rays framing the mesh, and SIDE² random rays (origin uniform in
//! the bounds, direction uniform on the sphere). Each set is traced REPEATS times on 1 thread
//! and on all of rayon's threads; the best time is reported, in Mrays/s.

use ember::accel::{Accel, EmbreeAccel};
use ember::camera::Camera;
use ember::embree::{BuildOptions, Device};
use ember::geometry::{Aabb, Geometry, Ray, bounds_of};
use ember::sampler::Rng;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::sync::Arc;
use std::time::Instant;

fn mesh(name: &str) -> Vec<Geometry> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name);
    let obj =
        ember::scene::mesh_file::load(&path, &ember::memory::LoadBudget::unlimited()).unwrap_or_else(|e| panic!("{e}"));
    obj.meshes.into_iter().map(|m| Geometry::Mesh(Arc::new(m.mesh))).collect()
}

fn camera_rays(b: &Aabb, side: u32) -> Vec<Ray> {
    let cam = Camera::framing(b, 30.0, 1.0);
    let s = side as f32;
    (0..side * side)
        .map(|i| cam.ray(Vec2::new(((i % side) as f32 + 0.5) / s, ((i / side) as f32 + 0.5) / s), Vec2::ZERO))
        .collect()
}

fn random_rays(b: &Aabb, n: u32) -> Vec<Ray> {
    let mut rng = Rng::new(2024, 0);
    (0..n)
        .map(|_| {
            let o = b.min + (b.max - b.min) * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            let z = 1.0 - 2.0 * rng.next_f32();
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = std::f32::consts::TAU * rng.next_f32();
            Ray::new(o, Vec3::new(r * phi.cos(), r * phi.sin(), z))
        })
        .collect()
}

/// Best Mrays/s over `repeats` passes; also returns the hit count (to check both builds agree).
fn measure(accel: &EmbreeAccel, rays: &[Ray], repeats: u32, parallel: bool) -> (f64, usize) {
    let mut best = f64::INFINITY;
    let mut hits = 0;
    for _ in 0..repeats {
        let t = Instant::now();
        hits = if parallel {
            rays.par_iter()
                .with_min_len(1024)
                .filter(|r| accel.intersect(r, 0.0, f32::INFINITY).unwrap().is_some())
                .count()
        } else {
            rays.iter().filter(|r| accel.intersect(r, 0.0, f32::INFINITY).unwrap().is_some()).count()
        };
        best = best.min(t.elapsed().as_secs_f64());
    }
    (rays.len() as f64 / best / 1e6, hits)
}

fn main() {
    let mut args = std::env::args().skip(1);
    let side: u32 = args.next().map_or(1024, |s| s.parse().expect("SIDE is a number"));
    let repeats: u32 = args.next().map_or(5, |s| s.parse().expect("REPEATS is a number"));
    let device = Device::new().unwrap();
    // Warm-up: the first commit in a process starts Embree's threads.
    drop(EmbreeAccel::new(&device, &[], BuildOptions::default()).unwrap());
    let threads = rayon::current_num_threads();
    println!(
        "Embree {} ({} bindings, {}); {side}x{side} rays, best of {repeats}, 1 and {threads} threads",
        device.version(),
        device.backend(),
        device.ray_hit_layout()
    );
    println!("| mesh | rays | hits | Mrays/s, 1 thread | Mrays/s, {threads} threads |");
    println!("|---|---|---:|---:|---:|");
    for name in ["teapot.obj", "bunny.obj"] {
        let geometry = mesh(name);
        let b = bounds_of(&geometry);
        let accel = EmbreeAccel::new(&device, &geometry, BuildOptions::default()).unwrap();
        for (kind, rays) in [("camera", camera_rays(&b, side)), ("random", random_rays(&b, side * side))] {
            let (one, hits) = measure(&accel, &rays, repeats, false);
            let (all, hits_all) = measure(&accel, &rays, repeats, true);
            assert_eq!(hits, hits_all);
            println!("| {name} | {kind} | {hits} | {one:.1} | {all:.1} |");
        }
    }
}

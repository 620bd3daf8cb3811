//! Core intersection measurements (a small, quick set; `ember bench` has the full table):
//! Embree vs the naive loop on the teapot, closest-hit and occlusion, camera rays.

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use ember::accel::{Accel, EmbreeAccel, NaiveAccel};
use ember::camera::Camera;
use ember::embree::{BuildOptions, Device};
use ember::geometry::{Geometry, Ray};
use std::hint::black_box;
use std::sync::Arc;

fn teapot() -> Vec<Geometry> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/teapot.obj");
    let obj = ember::scene::mesh_file::load(&path, &ember::memory::LoadBudget::unlimited()).unwrap();
    obj.meshes.into_iter().map(|m| Geometry::Mesh(Arc::new(m.mesh))).collect()
}

fn camera_rays(geometry: &[Geometry], n: u32) -> Vec<Ray> {
    let b = geometry.iter().fold(ember::geometry::Aabb::EMPTY, |b, g| b.union(&g.bounds()));
    let cam = Camera::framing(&b, 30.0, 1.0);
    (0..n * n)
        .map(|i| {
            cam.ray(
                glam::Vec2::new(((i % n) as f32 + 0.5) / n as f32, ((i / n) as f32 + 0.5) / n as f32),
                glam::Vec2::ZERO,
            )
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let geometry = teapot();
    let device = Device::new().unwrap();
    let embree = EmbreeAccel::new(&device, &geometry, BuildOptions::default()).unwrap();
    let naive = NaiveAccel::new(&geometry);
    let rays = camera_rays(&geometry, 128);
    let few: Vec<Ray> = rays.iter().step_by(256).copied().collect();

    let mut g = c.benchmark_group("teapot_camera_rays");
    g.throughput(Throughput::Elements(rays.len() as u64));
    g.bench_function("embree_intersect", |b| {
        b.iter(|| rays.iter().filter(|r| embree.intersect(r, 0.0, f32::INFINITY).unwrap().is_some()).count())
    });
    g.bench_function("embree_occluded", |b| {
        b.iter(|| rays.iter().filter(|r| embree.occluded(r, 0.0, f32::INFINITY).unwrap()).count())
    });
    g.throughput(Throughput::Elements(few.len() as u64));
    g.sample_size(10);
    g.bench_function("naive_intersect", |b| {
        b.iter(|| few.iter().filter(|r| naive.intersect(r, 0.0, f32::INFINITY).unwrap().is_some()).count())
    });
    g.finish();

    c.bench_function("teapot_bvh_build_medium", |b| {
        b.iter(|| black_box(EmbreeAccel::new(&device, &geometry, BuildOptions::default()).unwrap()))
    });
}

// No HTML plots: plotters is built without system fonts here (see src/tools/report/plot.rs), and
// criterion's plot backend would panic looking for one.
criterion_group! { name = benches; config = Criterion::default().without_plots(); targets = bench }
criterion_main!(benches);

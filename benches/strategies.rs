//! The core measurements of `ember bench`, small and quick, under criterion: the three ray
//! workloads through Embree (medium) on the teapot and a 100k-triangle blob, BVH builds at
//! each quality, the robust flag, and spheres/cylinders as user geometry vs tessellated.
//! Rays and scenes come from `ember::tools::bench`, so they are the ones the table measures (fewer).
//! Ray passes run on rayon's global pool, as in `ember bench`.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use ember::accel::Accel;
use ember::embree::{BuildQuality, Device};
use ember::geometry::{Aabb, Geometry};
use ember::tools::bench::measure::{Batch, pass};
use ember::tools::bench::rays::{self, Query, RayKind};
use ember::tools::bench::scenes::{BenchScene, default_scenes_dir};
use ember::tools::bench::strategy::Strategy;
use std::hint::black_box;
use std::time::Duration;

fn load(name: &str) -> BenchScene {
    BenchScene::load(name, &default_scenes_dir()).expect("bench scene loads")
}

fn bounds(g: &[Geometry]) -> Aabb {
    g.iter().fold(Aabb::EMPTY, |b, g| b.union(&g.bounds()))
}

fn medium() -> Strategy {
    Strategy::Embree { quality: BuildQuality::Medium, robust: false, tessellated: false, packets: false }
}

/// 128² camera rays, 16,384 random rays, and the shadow rays of the camera hits.
fn workloads(device: &Device, g: &[Geometry]) -> Vec<(RayKind, Vec<Query>)> {
    let b = bounds(g);
    let camera = rays::coherent(&b, 128);
    let (reference, _) = medium().build(device, g).unwrap();
    let shadow = rays::occlusion(reference.as_ref(), &b, &camera, 7).unwrap();
    vec![
        (RayKind::Coherent, camera),
        (RayKind::Incoherent, rays::incoherent(&b, 16_384, 7)),
        (RayKind::Occlusion, shadow),
    ]
}

fn trace(c: &mut Criterion, group: &str, id: &str, accel: &dyn Accel, kind: RayKind, q: &[Query]) {
    let mut g = c.benchmark_group(group);
    g.throughput(Throughput::Elements(q.len() as u64));
    g.bench_function(BenchmarkId::new(id, kind.name()), |b| {
        b.iter(|| pass(accel, q, kind.closest(), Batch::Single).unwrap())
    });
    g.finish();
}

fn rays_per_workload(c: &mut Criterion) {
    let device = Device::new().unwrap();
    for name in ["teapot", "blob-100k"] {
        let s = load(name);
        let (accel, _) = medium().build(&device, &s.geometry).unwrap();
        for (kind, q) in workloads(&device, &s.geometry) {
            trace(c, &format!("{name}_rays"), "embree-medium", accel.as_ref(), kind, &q);
        }
    }
}

fn robust_flag(c: &mut Criterion) {
    let device = Device::new().unwrap();
    let s = load("teapot");
    let q = rays::incoherent(&bounds(&s.geometry), 16_384, 7);
    for robust in [false, true] {
        let st = Strategy::Embree { quality: BuildQuality::Medium, robust, tessellated: false, packets: false };
        let (accel, _) = st.build(&device, &s.geometry).unwrap();
        trace(c, "teapot_robust", st.name(), accel.as_ref(), RayKind::Incoherent, &q);
    }
}

fn user_geometry_vs_tessellated(c: &mut Criterion) {
    let device = Device::new().unwrap();
    let s = load("shapes-100");
    let tess = s.tessellated().unwrap();
    let work = workloads(&device, &s.geometry);
    for (st, g) in [
        (medium(), &s.geometry),
        (Strategy::Embree { quality: BuildQuality::Medium, robust: false, tessellated: true, packets: false }, &tess),
    ] {
        let (accel, _) = st.build(&device, g).unwrap();
        for (kind, q) in &work {
            trace(c, "shapes-100_rays", st.name(), accel.as_ref(), *kind, q);
        }
    }
}

fn naive_loop(c: &mut Criterion) {
    let device = Device::new().unwrap();
    let s = load("teapot");
    let (naive, _) = Strategy::Naive.build(&device, &s.geometry).unwrap();
    let q = rays::subsample(&rays::coherent(&bounds(&s.geometry), 128), 256);
    trace(c, "teapot_rays", "naive", naive.as_ref(), RayKind::Coherent, &q);
}

fn builds(c: &mut Criterion) {
    let device = Device::new().unwrap();
    // The first commit starts Embree's threads: keep it out of the measurements.
    drop(medium().build(&device, &load("blob-1k").geometry).unwrap());
    let s = load("blob-100k");
    let mut g = c.benchmark_group("blob-100k_build");
    for quality in [BuildQuality::Low, BuildQuality::Medium, BuildQuality::High] {
        let st = Strategy::Embree { quality, robust: false, tessellated: false, packets: false };
        g.bench_function(st.name(), |b| b.iter(|| black_box(st.build(&device, &s.geometry).unwrap())));
    }
    g.finish();
}

/// Small and quick; no HTML plots (plotters has no system fonts here, see benches/intersect.rs).
fn config() -> Criterion {
    Criterion::default()
        .without_plots()
        .sample_size(10)
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(1))
}

criterion_group! { name = benches; config = config(); targets = rays_per_workload, robust_flag, user_geometry_vs_tessellated, naive_loop, builds }
criterion_main!(benches);

//! Where Embree's time per ray goes as a mesh grows: the bench's three workloads on one blob
//! of `ember bench`'s scaling family, traced on one thread, so that callgrind can count the
//! instructions and simulated cache misses of the tracing alone.
//!
//!     cargo run --release --example scaling_counts -- SCENE KIND [REPEATS]
//!     valgrind --tool=callgrind --cache-sim=yes --collect-atstart=no \
//!         --toggle-collect='scaling_counts::measured' target/release/examples/scaling_counts SCENE KIND 1
//!
//! SCENE is a bench scene (blob-1k … blob-1m), KIND coherent, incoherent or occlusion; the rays
//! are the bench's own (`ember::tools::bench::rays`, full-size set: 512² camera rays, 262,144 random
//! rays, shadow rays from the camera rays' hits), the BVH the bench's "embree-medium" row
//! (medium quality, not robust). After one warm-up pass it prints the best wall time per ray of
//! REPEATS passes (default 5). `scripts/scaling-counts.sh` runs both for 1k and 1M triangles.

use ember::accel::{Accel, EmbreeAccel};
use ember::embree::{BuildOptions, BuildQuality, Device};
use ember::geometry::bounds_of;
use ember::tools::bench::rays::{self, Query};
use ember::tools::bench::scenes::BenchScene;
use std::time::Instant;

/// Traces every query; returns how many hit (so the work cannot be optimised away).
#[inline(never)]
fn trace(accel: &EmbreeAccel, queries: &[Query], closest: bool) -> usize {
    let mut hits = 0;
    for q in queries {
        let hit = if closest {
            accel.intersect(&q.ray, 0.0, q.tmax).expect("intersect").is_some()
        } else {
            accel.occluded(&q.ray, 0.0, q.tmax).expect("occluded")
        };
        hits += hit as usize;
    }
    hits
}

/// The timed passes (what `--toggle-collect` selects): the best wall time of `repeats`.
#[inline(never)]
fn measured(accel: &EmbreeAccel, queries: &[Query], closest: bool, repeats: usize) -> (f64, usize) {
    let mut best = f64::INFINITY;
    let mut hits = 0;
    for _ in 0..repeats {
        let t = Instant::now();
        hits = trace(accel, queries, closest);
        best = best.min(t.elapsed().as_secs_f64());
    }
    (best, hits)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (Some(scene), Some(kind)) = (args.first(), args.get(1)) else {
        eprintln!("usage: scaling_counts SCENE KIND [REPEATS]");
        std::process::exit(2);
    };
    let repeats: usize = args.get(2).map_or(5, |r| r.parse().expect("REPEATS: a number"));
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let scene = BenchScene::load(scene, &dir).unwrap_or_else(|e| panic!("{e}"));
    let device = Device::new().expect("Embree device");
    let options = BuildOptions { quality: BuildQuality::Medium, robust: false, ..BuildOptions::default() };
    let accel = EmbreeAccel::new(&device, &scene.geometry, options).expect("BVH build");
    let bounds = bounds_of(&scene.geometry);
    let camera = rays::coherent(&bounds, 512);
    let (queries, closest) = match kind.as_str() {
        "coherent" => (camera, true),
        "incoherent" => (rays::incoherent(&bounds, 512 * 512, 2024), true),
        "occlusion" => (rays::occlusion(&accel, &bounds, &camera, 2024).expect("shadow rays"), false),
        _ => panic!("KIND: coherent, incoherent or occlusion"),
    };
    // A warm-up pass, outside what callgrind collects: the caches then hold what a pass leaves
    // in them, as they do for the timed passes of the bench.
    trace(&accel, &queries, closest);
    let (best, hits) = measured(&accel, &queries, closest, repeats);
    println!(
        "{} {kind}: {} triangles, {} rays, {} hit, best of {repeats}: {:.1} ns/ray",
        scene.name,
        scene.triangles(),
        queries.len(),
        hits,
        best * 1e9 / queries.len() as f64
    );
}

//! Time and determinism of the denoiser (`ember::oidn`) on a synthetic noisy image.
//!
//!     cargo run --release --example denoise_timing [-- SIDE REPEATS]
//!
//! The image is `tests/denoise_images`' lit sphere, SIDE x SIDE (default 512), at 4 "samples
//! per pixel" of multiplicative exponential noise; its albedo and normal images are exact. Prints
//! the time to load the library and create the device, then for colour alone and with the aux
//! images in each `Aux` mode: the median wall and CPU time (all threads, `ember::bench::cputime`;
//! less sensitive than wall time to other work on a shared machine) of REPEATS (default 5) calls
//! after one warm-up, and the MSE against the clean image. An 8x8 image gives the fixed cost of
//! a call (filters are created and committed per call). Then whether outputs are bit-identical
//! across repeated calls, new devices, OIDN thread counts 1, 2, 3 and automatic, and with
//! thread pinning off.

#[path = "../tests/denoise_images/mod.rs"]
mod denoise_images;

use ember::oidn::{Aux, Denoiser, DenoiserOptions};
use ember::tools::bench::cputime::cpu_of;
use glam::Vec3;
use std::time::Instant;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn bits(img: &[Vec3]) -> Vec<u32> {
    img.iter().flat_map(|p| p.to_array().map(f32::to_bits)).collect()
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let side: u32 = args.get(1).map_or(512, |s| s.parse().expect("SIDE"));
    let repeats: usize = args.get(2).map_or(5, |s| s.parse().expect("REPEATS"));

    let t = Instant::now();
    let dn = Denoiser::new().unwrap_or_else(|e| panic!("{e}"));
    println!(
        "load + device: {:.1} ms (Open Image Denoise {}, {}, numThreads {})",
        t.elapsed().as_secs_f64() * 1e3,
        dn.version(),
        dn.library(),
        dn.threads()
    );

    let tiny = denoise_images::scene(8, 8);
    let tiny_noisy = denoise_images::noisy(&tiny.clean, 4, 1);
    let mut fixed: Vec<(f64, f64)> = (0..repeats + 1)
        .map(|_| {
            let t = Instant::now();
            let (_, cpu) = cpu_of(|| dn.denoise(8, 8, &tiny_noisy, None, None, Aux::Noisy).unwrap());
            (t.elapsed().as_secs_f64() * 1e3, cpu.map_or(f64::NAN, |c| c.as_secs_f64() * 1e3))
        })
        .collect();
    let first = fixed.remove(0);
    println!(
        "8x8 colour only: first {:.1} ms, median {:.1} ms wall, {:.1} ms CPU",
        first.0,
        median(fixed.iter().map(|f| f.0).collect()),
        median(fixed.iter().map(|f| f.1).collect())
    );

    let s = denoise_images::scene(side, side);
    let noisy = denoise_images::noisy(&s.clean, 4, 1);
    println!("{side}x{side}, noisy MSE {:.3e}", denoise_images::mse(&noisy, &s.clean));
    // (label, albedo, normal, mode); the aux images are exact, so Aux::Clean is their mode.
    let configs: [(&str, bool, bool, Aux); 5] = [
        ("colour only", false, false, Aux::Noisy),
        ("+ albedo + normal, Noisy", true, true, Aux::Noisy),
        ("+ albedo + normal, Clean", true, true, Aux::Clean),
        ("+ albedo + normal, Prefilter", true, true, Aux::Prefilter),
        ("+ albedo, Prefilter", true, false, Aux::Prefilter),
    ];
    let run = |dn: &Denoiser, albedo: bool, normal: bool, mode: Aux| {
        let a = albedo.then_some(&s.albedo[..]);
        let n = normal.then_some(&s.normal[..]);
        dn.denoise(side, side, &noisy, a, n, mode).unwrap_or_else(|e| panic!("{e}"))
    };
    for (name, albedo, normal, mode) in configs {
        let t = Instant::now();
        let first = run(&dn, albedo, normal, mode);
        let first_ms = t.elapsed().as_secs_f64() * 1e3;
        let (wall, cpu): (Vec<f64>, Vec<f64>) = (0..repeats)
            .map(|_| {
                let t = Instant::now();
                let (_, cpu) = cpu_of(|| std::hint::black_box(run(&dn, albedo, normal, mode)));
                (t.elapsed().as_secs_f64() * 1e3, cpu.map_or(f64::NAN, |c| c.as_secs_f64() * 1e3))
            })
            .unzip();
        println!(
            "{name:30} first {first_ms:7.1} ms; median of {repeats}: {:7.1} ms wall (min {:.1}), {:7.1} ms CPU; MSE {:.3e}",
            median(wall.clone()),
            wall.iter().copied().fold(f64::INFINITY, f64::min),
            median(cpu),
            denoise_images::mse(&first, &s.clean)
        );
    }

    // Determinism.
    let reference = bits(&run(&dn, true, true, Aux::Prefilter));
    let same = |label: &str, out: Vec<Vec3>| {
        let b = bits(&out);
        let differ = b.iter().zip(&reference).filter(|(x, y)| x != y).count();
        let max = out
            .iter()
            .flat_map(|p| p.to_array())
            .zip(reference.iter().map(|&r| f32::from_bits(r)))
            .map(|(x, y)| (x - y).abs())
            .fold(0.0f32, f32::max);
        println!(
            "{label:40} {} ({differ} of {} values differ, max |diff| {max:.3e})",
            if differ == 0 { "bit-identical" } else { "DIFFERS" },
            b.len()
        );
    };
    for i in 0..3 {
        same(&format!("same device, call {}", i + 2), run(&dn, true, true, Aux::Prefilter));
    }
    let variants: [(&str, Option<u32>, Option<bool>); 5] = [
        ("new device, automatic threads", None, None),
        ("new device, numThreads 1", Some(1), None),
        ("new device, numThreads 2", Some(2), None),
        ("new device, numThreads 3 (> cores)", Some(3), None),
        ("new device, setAffinity false", None, Some(false)),
    ];
    for (label, threads, set_affinity) in variants {
        let d = Denoiser::with_options(&DenoiserOptions { threads, set_affinity, ..Default::default() })
            .unwrap_or_else(|e| panic!("{e}"));
        let t = Instant::now();
        let out = run(&d, true, true, Aux::Prefilter);
        let ms = t.elapsed().as_secs_f64() * 1e3;
        same(&format!("{label} (reports {}, {ms:.0} ms)", d.threads()), out);
    }
}

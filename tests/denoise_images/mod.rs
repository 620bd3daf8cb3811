//! Synthetic images for the denoiser: a lit sphere on a grey backdrop, with its clean colour,
//! albedo and normal, and a noisy colour that looks like a path tracer's at a few samples per
//! pixel. Shared by `tests/denoiser.rs` and `examples/denoise_timing.rs` (through `#[path]`).
#![allow(dead_code)]

use ember::sampler::Rng;
use glam::Vec3;

pub struct Scene {
    pub w: u32,
    pub h: u32,
    pub clean: Vec<Vec3>,
    pub albedo: Vec<Vec3>,
    pub normal: Vec<Vec3>,
}

/// A `w` x `h` image: a sphere (albedo (0.8, 0.3, 0.2)) in the middle, lit from the upper left
/// by a soft light, on a backdrop (albedo 0.5 grey) lit by a smooth gradient; HDR values up to
/// about 1.3.
pub fn scene(w: u32, h: u32) -> Scene {
    let light = Vec3::new(-0.5, 0.6, 0.62).normalize();
    let (mut clean, mut albedo, mut normal) = (Vec::new(), Vec::new(), Vec::new());
    let r = 0.35 * w.min(h) as f32;
    for y in 0..h {
        for x in 0..w {
            let dx = (x as f32 + 0.5 - w as f32 / 2.0) / r;
            let dy = (h as f32 / 2.0 - y as f32 - 0.5) / r;
            let d2 = dx * dx + dy * dy;
            let (a, n, shade) = if d2 < 1.0 {
                let n = Vec3::new(dx, dy, (1.0 - d2).sqrt());
                (Vec3::new(0.8, 0.3, 0.2), n, 0.1 + 1.5 * n.dot(light).max(0.0))
            } else {
                let g = 0.4 + 0.6 * (x as f32 / w as f32) * (1.0 - 0.5 * y as f32 / h as f32);
                (Vec3::splat(0.5), Vec3::Z, g)
            };
            albedo.push(a);
            normal.push(n);
            clean.push(a * shade);
        }
    }
    Scene { w, h, clean, albedo, normal }
}

/// Monte Carlo-like noise: each channel of each pixel is the clean value times the mean of
/// `spp` exponential(1) samples (unbiased, non-negative, relative standard deviation
/// 1/sqrt(spp)), from a stream keyed by `seed` and the pixel.
pub fn noisy(clean: &[Vec3], spp: u32, seed: u64) -> Vec<Vec3> {
    clean
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let mut rng = Rng::new(seed, i as u64);
            let mut f = || (0..spp).map(|_| -(1.0 - rng.next_f32()).ln()).sum::<f32>() / spp as f32;
            Vec3::new(c.x * f(), c.y * f(), c.z * f())
        })
        .collect()
}

/// Mean squared error per channel value.
pub fn mse(a: &[Vec3], b: &[Vec3]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).map(|(p, q)| ((*p - *q).length_squared()) as f64).sum::<f64>() / (3 * a.len()) as f64
}

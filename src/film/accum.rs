//! Per-pixel sample accumulation: sums in double precision, sample counts, and the second
//! moment of luminance for a per-pixel error estimate. Samples of a pixel are always added in
//! sample-index order, so the sums — and an image made from them — are the same however the
//! work was split into rounds, tiles, threads or interrupted sessions.

use super::Film;
use glam::{DVec3, Vec3};

/// Luminance weights (Rec. 709).
pub(super) const LUMINANCE: DVec3 = DVec3::new(0.2126, 0.7152, 0.0722);

/// Below this mean luminance a pixel's error is judged in absolute terms (as if its mean were
/// this), so near-black pixels do not demand unbounded samples.
pub const RELATIVE_ERROR_FLOOR: f64 = 0.01;

/// ε of ember's relative mean squared error, (x − r)² / (r² + ε) for each colour channel
/// (`ember converge`'s measure, which adaptive sampling minimises): radiance below about
/// √ε = 0.1 is compared more and more in absolute rather than relative terms.
pub const REL_MSE_EPSILON: f64 = 1e-2;

/// The running state of one pixel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelState {
    /// Sum of the sample values (non-finite samples count as zero).
    pub sum: DVec3,
    /// Sum of squared sample luminances.
    pub sum_lum_sq: f64,
    /// Samples taken.
    pub count: u32,
}

impl PixelState {
    #[inline]
    pub fn add(&mut self, v: Vec3) {
        let v = v.as_dvec3();
        self.sum += v;
        let l = v.dot(LUMINANCE);
        self.sum_lum_sq += l * l;
        self.count += 1;
    }

    pub fn mean(&self) -> Vec3 {
        if self.count == 0 { Vec3::ZERO } else { (self.sum / self.count as f64).as_vec3() }
    }

    /// Estimated relative standard error of the pixel's mean luminance: the sample standard
    /// deviation over √n, divided by max(mean, [`RELATIVE_ERROR_FLOOR`]). Infinite with fewer
    /// than two samples.
    pub fn relative_error(&self) -> f64 {
        if self.count < 2 {
            return f64::INFINITY;
        }
        let n = self.count as f64;
        let mean = self.sum.dot(LUMINANCE) / n;
        let var = ((self.sum_lum_sq / n - mean * mean) * n / (n - 1.0)).max(0.0);
        (var / n).sqrt() / mean.max(RELATIVE_ERROR_FLOOR)
    }
}

/// The sums of a pixel's auxiliary samples (for a denoiser): the albedo and the shading normal
/// of the first non-specular surface each sample's camera path reached. They have one sample
/// per sample of the pixel's [`PixelState`] (its `count`), added in the same order.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AuxSums {
    /// Sum of the albedos, each in [0, 1].
    pub albedo: DVec3,
    /// Sum of the unit shading normals (zero where the path found no surface).
    pub normal: DVec3,
}

impl AuxSums {
    #[inline]
    pub fn add(&mut self, albedo: Vec3, normal: Vec3) {
        self.albedo += albedo.as_dvec3();
        self.normal += normal.as_dvec3();
    }

    /// The mean albedo and normal over `count` samples (zero without samples). The mean
    /// normal is not renormalised: it stays in [-1, 1], as OIDN asks.
    pub fn mean(&self, count: u32) -> (Vec3, Vec3) {
        if count == 0 {
            return (Vec3::ZERO, Vec3::ZERO);
        }
        let n = count as f64;
        ((self.albedo / n).as_vec3(), (self.normal / n).as_vec3())
    }
}

/// Accumulated samples of a whole image.
#[derive(Clone, Debug, PartialEq)]
pub struct Accumulator {
    pub width: u32,
    pub height: u32,
    /// Row-major, top row first.
    pub pixels: Vec<PixelState>,
    /// The auxiliary images' sums, pixel by pixel as `pixels`, when the render takes them
    /// ([`crate::integrator::RenderSettings::aux`]).
    pub aux: Option<Vec<AuxSums>>,
    /// In an adaptive render ([`crate::integrator::RenderSettings::adaptive`]), what each
    /// pixel's first round cost and how many samples it takes in all, pixel by pixel as
    /// `pixels`.
    pub adaptive: Option<Vec<AdaptivePixel>>,
    /// What light paths traced from the lights add to each pixel's mean (the caustics of
    /// `crate::integrator::caustic`), when the render traces them.
    pub light: Option<LightSums>,
}

/// What light paths add to each pixel's mean, pixel by pixel as [`Accumulator::pixels`],
/// r, g, b in 32.32 fixed point: integers add in any order to the same sum, so the light paths
/// of any thread, and of any shard, add up to the same bits.
#[derive(Clone, Debug, PartialEq)]
pub struct LightSums(pub Vec<[i64; 3]>);

impl LightSums {
    /// Steps per unit: 2³².
    pub const ONE: f64 = 4_294_967_296.0;

    /// Nothing added yet, for `pixels` pixels.
    pub fn new(pixels: usize) -> LightSums {
        LightSums(vec![[0; 3]; pixels])
    }

    /// Pixel `i`'s value.
    #[inline]
    pub fn value(&self, i: usize) -> Vec3 {
        Vec3::from_array(self.0[i].map(|s| (s as f64 / Self::ONE) as f32))
    }

    /// Adds `sums` to pixel `i`'s (wrapping, so that any order of additions gives the same
    /// sums: a merge adds the shards' in any order).
    pub fn add_at(&mut self, i: usize, sums: &[i64; 3]) {
        let a = &mut self.0[i];
        *a = std::array::from_fn(|c| a[c].wrapping_add(sums[c]));
    }
}

/// A pixel's part in an adaptive render's plan ([`crate::integrator::adaptive`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AdaptivePixel {
    /// Rays its first-round samples traced (their cost).
    pub rays: u32,
    /// The samples it takes in all, once the first round is done everywhere (0 before).
    pub target: u32,
    /// The sums of its first-round samples' squares, channel by channel (non-finite samples
    /// count as zero, as in [`PixelState::sum`]).
    pub sum_sq: DVec3,
}

impl Accumulator {
    pub fn new(width: u32, height: u32) -> Accumulator {
        Accumulator {
            width,
            height,
            pixels: vec![PixelState::default(); width as usize * height as usize],
            aux: None,
            adaptive: None,
            light: None,
        }
    }

    /// The same accumulator with an adaptive render's plan, empty.
    pub fn adaptive(self) -> Accumulator {
        let n = self.pixels.len();
        Accumulator { adaptive: Some(vec![AdaptivePixel::default(); n]), ..self }
    }

    /// An empty accumulator that also takes the auxiliary images.
    pub fn with_aux(width: u32, height: u32) -> Accumulator {
        let n = width as usize * height as usize;
        Accumulator { aux: Some(vec![AuxSums::default(); n]), ..Accumulator::new(width, height) }
    }

    /// An empty accumulator for a render that takes the auxiliary images if `aux` and keeps an
    /// adaptive render's plan if `adaptive`.
    pub fn empty(width: u32, height: u32, aux: bool, adaptive: bool) -> Accumulator {
        let a = if aux { Accumulator::with_aux(width, height) } else { Accumulator::new(width, height) };
        if adaptive { a.adaptive() } else { a }
    }

    /// The mean albedo image, if the auxiliary images were taken.
    pub fn albedo(&self) -> Option<Film> {
        self.aux_film(|a, n| a.mean(n).0)
    }

    /// The mean shading-normal image (world space, components in [-1, 1]), if the auxiliary
    /// images were taken.
    pub fn normal(&self) -> Option<Film> {
        self.aux_film(|a, n| a.mean(n).1)
    }

    fn aux_film(&self, f: impl Fn(&AuxSums, u32) -> Vec3) -> Option<Film> {
        let aux = self.aux.as_ref()?;
        let pixels = aux.iter().zip(&self.pixels).map(|(a, p)| f(a, p.count)).collect();
        Some(Film { width: self.width, height: self.height, pixels })
    }

    /// Samples taken by each pixel, row-major.
    pub fn sample_counts(&self) -> Vec<u32> {
        self.pixels.iter().map(|p| p.count).collect()
    }

    /// The image: each pixel's mean, and what light paths add to it.
    pub fn film(&self) -> Film {
        let mut pixels: Vec<Vec3> = self.pixels.iter().map(PixelState::mean).collect();
        if let Some(light) = &self.light {
            for (i, p) in pixels.iter_mut().enumerate() {
                *p += light.value(i);
            }
        }
        Film { width: self.width, height: self.height, pixels }
    }

    /// Total samples taken.
    pub fn samples(&self) -> u64 {
        self.samples_of(|_| true)
    }

    /// (min, mean, max) samples per pixel.
    pub fn spp_range(&self) -> (u32, f64, u32) {
        self.spp_range_of(|_| true)
    }

    /// (mean, max) of the pixels' estimated relative errors.
    pub fn error_estimate(&self) -> (f64, f64) {
        self.error_estimate_of(|_| true)
    }

    /// The pixels (row-major index) for which `keep` holds: a shard's.
    fn pixels_of(&self, keep: impl Fn(usize) -> bool) -> impl Iterator<Item = &PixelState> {
        self.pixels.iter().enumerate().filter(move |(i, _)| keep(*i)).map(|(_, p)| p)
    }

    /// [`Accumulator::samples`] of the pixels for which `keep` holds.
    pub fn samples_of(&self, keep: impl Fn(usize) -> bool) -> u64 {
        self.pixels_of(keep).map(|p| p.count as u64).sum()
    }

    /// [`Accumulator::spp_range`] of the pixels for which `keep` holds.
    pub fn spp_range_of(&self, keep: impl Fn(usize) -> bool + Copy) -> (u32, f64, u32) {
        let (mut min, mut max, mut n, mut sum) = (u32::MAX, 0, 0u64, 0u64);
        for p in self.pixels_of(keep) {
            (min, max, n, sum) = (min.min(p.count), max.max(p.count), n + 1, sum + p.count as u64);
        }
        if n == 0 { (0, 0.0, 0) } else { (min, sum as f64 / n as f64, max) }
    }

    /// [`Accumulator::error_estimate`] of the pixels for which `keep` holds.
    pub fn error_estimate_of(&self, keep: impl Fn(usize) -> bool) -> (f64, f64) {
        let (mut sum, mut max, mut n) = (0.0, 0.0f64, 0usize);
        for e in self.pixels_of(keep).map(PixelState::relative_error) {
            (sum, max, n) = (sum + e, max.max(e), n + 1);
        }
        (sum / n.max(1) as f64, max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relative_error_is_the_standard_error_over_the_mean() {
        let mut p = PixelState::default();
        // Luminance alternates 0.5 and 1.5: mean 1, sample variance 0.25·n/(n−1).
        for i in 0..100 {
            p.add(Vec3::splat(if i % 2 == 0 { 0.5 } else { 1.5 }));
        }
        let expected = (0.25f64 * 100.0 / 99.0 / 100.0).sqrt();
        assert!((p.relative_error() - expected).abs() < 1e-9, "{} vs {expected}", p.relative_error());
        assert_eq!(p.mean(), Vec3::ONE);
    }

    #[test]
    fn black_pixels_are_judged_against_the_floor() {
        let mut p = PixelState::default();
        for _ in 0..4 {
            p.add(Vec3::ZERO);
        }
        assert_eq!(p.relative_error(), 0.0);
        assert_eq!(PixelState::default().relative_error(), f64::INFINITY);
    }
}

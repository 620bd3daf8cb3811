//! An environment image: an equirectangular (latitude-longitude) image of the radiance arriving
//! from every direction, rotated about +Y and scaled by a strength, and how next-event
//! estimation samples it — in proportion to its luminance, so that a small bright sun in a dim
//! sky is found by a fraction of the samples, not by the one in ten thousand that a uniform
//! direction gives it.
//!
//! **Mapping.** Direction d (unit, Y up) ↔ image (u, v) in [0, 1]²: θ = acos d.y from +Y, φ =
//! atan2(d.x, −d.z), u = ½ + φ/2π, v = 1 − θ/π (v = 1 is the top row). The image's centre is −Z,
//! its left and right edges +Z, its top row +Y. `rotate = α` turns the image α degrees about +Y
//! (as a mesh's `rotate = [0, α, 0]`): what the image shows at direction d is seen at R_y(α) d,
//! so at 90° its centre is seen at −X. Radiance is looked up bilinearly.
//!
//! **Sampling** (after pbrt-v4's `ImageInfiniteLight` and pbrt-v3's `InfiniteAreaLight`: a
//! piecewise-constant 2D distribution over the image, a marginal over rows and a conditional per
//! row). Each pixel's cell (the texel's rectangle in (u, v)) gets the value f, the *largest*
//! luminance the bilinear lookup takes in the cell: the maximum of the texel, its averages with
//! its 4 neighbours (the cell's edge midpoints) and with each 2×2 block around its corners (the
//! cell's corners) — a bilinear function's maximum over a rectangle is at one of its corners, and
//! each quarter of the cell is such a rectangle. So radiance ≤ f × strength everywhere, and
//! radiance / density is bounded: a bright texel spreads into its neighbours' cells through the
//! bilinear lookup, and those cells are sampled for it.
//!
//! Rows are equal steps of θ, so they subtend different solid angles; instead of weighting a row
//! by sin θ at its centre, a row is sampled in z = cos θ, which makes the density exact: the cell
//! of texel (x, y) spans Δφ = 2π/W and z from cos(πy/H) to cos(π(y+1)/H), solid angle
//! Ω = 2π/W · Δz (the integral of sin θ over the row). A cell is chosen with probability
//! f·Ω / T, T = Σ f·Ω = ∫ f dω (rows by Σₓ f·Δz, then a column in the row by f), and a direction
//! uniformly in its (φ, z) rectangle — uniform in solid angle within the cell. The density in
//! solid angle is then f / T, constant over each cell; the same in `pdf`, which MIS weighs a
//! BSDF-sampled ray that escapes against. An image of one value is sampled exactly uniformly
//! over the sphere.
//!
//! Memory: the density per cell and the cumulative sums per row (8 bytes per pixel, f32), the
//! marginal and the row boundaries (8 bytes per row).

use super::distribution::{normalized_cdf, pick};
use super::{LightSample, luminance, uniform_sphere};
use crate::hash::Fingerprint;
use crate::texture::Image;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;
use std::sync::Arc;

/// An environment image with its rotation, strength and sampling distribution.
#[derive(Clone)]
pub struct Environment {
    image: Arc<Image>,
    strength: f32,
    /// Degrees about +Y, as given; `cos`, `sin` of it.
    rotate: f32,
    cos: f32,
    sin: f32,
    /// The image's mean over the sphere of directions (texels weighted by the solid angle of
    /// their cells), before the strength.
    mean: Vec3,
    /// `None`: directions uniform over the sphere ([`Environment::uniformly_sampled`]).
    sampling: Option<Arc<Distribution>>,
}

impl Environment {
    /// `image` seen from every direction, rotated `rotate` degrees about +Y and multiplied by
    /// `strength`, sampled by luminance. Builds the distribution: see
    /// [`crate::memory::environment_sampling_bytes`] for its memory.
    pub fn new(image: Arc<Image>, strength: f32, rotate: f32) -> Environment {
        let sampling = Distribution::new(&image).map(Arc::new);
        let (sin, cos) = (rotate as f64).to_radians().sin_cos();
        let mean = solid_angle_mean(&image);
        Environment { image, strength, rotate, cos: cos as f32, sin: sin as f32, mean, sampling }
    }

    /// The same environment with next-event estimation sampling directions uniformly over
    /// the sphere instead of by luminance: for measuring what importance sampling gains
    /// (`ember converge`'s `/env-uniform` variants).
    pub fn uniformly_sampled(&self) -> Environment {
        Environment { sampling: None, ..self.clone() }
    }

    /// Whether next-event estimation samples it by luminance.
    pub fn importance_sampled(&self) -> bool {
        self.sampling.is_some()
    }

    pub fn image(&self) -> &Arc<Image> {
        &self.image
    }

    pub fn strength(&self) -> f32 {
        self.strength
    }

    /// Degrees about +Y.
    pub fn rotation(&self) -> f32 {
        self.rotate
    }

    /// Bytes its sampling distribution keeps.
    pub fn sampling_bytes(&self) -> u64 {
        self.sampling.as_ref().map_or(0, |d| d.bytes())
    }

    /// Mean radiance over the sphere of directions.
    pub fn average(&self) -> Vec3 {
        self.mean * self.strength
    }

    /// The image's direction for the world direction `d`.
    #[inline]
    fn to_image(&self, d: Vec3) -> Vec3 {
        Vec3::new(self.cos * d.x - self.sin * d.z, d.y, self.sin * d.x + self.cos * d.z)
    }

    /// The world direction of the image's direction `l`.
    #[inline]
    fn to_world(&self, l: Vec3) -> Vec3 {
        Vec3::new(self.cos * l.x + self.sin * l.z, l.y, -self.sin * l.x + self.cos * l.z)
    }

    /// Radiance arriving from the world direction `d` (any length).
    #[inline]
    pub fn radiance(&self, d: Vec3) -> Vec3 {
        self.radiance_image(self.to_image(d.normalize()))
    }

    /// Radiance from the image's unit direction `l`.
    #[inline]
    fn radiance_image(&self, l: Vec3) -> Vec3 {
        self.image.bilinear(image_uv(l)) * self.strength
    }

    /// A direction toward the environment (by luminance, or uniform over the sphere); the
    /// background was chosen with probability `sel`.
    pub(super) fn sample(&self, sel: f32, u: Vec2) -> Option<LightSample> {
        let (l, pdf) = match &self.sampling {
            Some(d) => d.sample(u),
            None => (uniform_sphere(u), 1.0 / (4.0 * PI)),
        };
        if !(pdf > 0.0) {
            return None;
        }
        Some(LightSample {
            wi: self.to_world(l),
            point: None,
            normal: Vec3::ZERO,
            radiance: self.radiance_image(l),
            pdf: sel * pdf,
            delta: false,
            light: 0,
        })
    }

    /// Solid-angle density with which [`Environment::sample`] picks the world direction `d`
    /// (any length; the background's choice not included).
    #[inline]
    pub fn pdf(&self, d: Vec3) -> f32 {
        match &self.sampling {
            Some(dist) => dist.pdf(self.to_image(d.normalize())),
            None => 1.0 / (4.0 * PI),
        }
    }

    pub fn fingerprint(&self, h: &mut Fingerprint) {
        self.image.fingerprint(h);
        h.f32s(&[self.strength, self.rotate]);
        h.u32(self.sampling.is_some() as u32);
    }
}

impl PartialEq for Environment {
    fn eq(&self, other: &Environment) -> bool {
        (Arc::ptr_eq(&self.image, &other.image) || self.image == other.image)
            && self.strength == other.strength
            && self.rotate == other.rotate
            && self.sampling.is_some() == other.sampling.is_some()
    }
}

impl std::fmt::Debug for Environment {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "Environment({}x{} image, strength {}, rotate {}°, {})",
            self.image.width,
            self.image.height,
            self.strength,
            self.rotate,
            if self.sampling.is_some() { "sampled by luminance" } else { "sampled uniformly" }
        )
    }
}

/// (u, v) of the image's unit direction `l` (see the module documentation).
#[inline]
fn image_uv(l: Vec3) -> Vec2 {
    let u = 0.5 + l.x.atan2(-l.z) / (2.0 * PI);
    let v = 1.0 - l.y.clamp(-1.0, 1.0).acos() / PI;
    Vec2::new(u, v)
}

/// z = cos θ at the boundaries of the image's `height` rows, from 1 (top) to −1 (bottom).
fn row_boundaries(height: usize) -> Vec<f64> {
    (0..=height)
        .map(|i| match i {
            0 => 1.0,
            i if i == height => -1.0,
            i => (std::f64::consts::PI * i as f64 / height as f64).cos(),
        })
        .collect()
}

/// The image's mean over the sphere: each texel weighted by its cell's solid angle.
fn solid_angle_mean(image: &Image) -> Vec3 {
    let (w, h) = (image.width as usize, image.height as usize);
    let z = row_boundaries(h);
    let mut sum = [0.0f64; 3];
    for y in 0..h {
        // The row's share of the sphere, Δz / 2, split over its w texels.
        let weight = (z[y] - z[y + 1]) / 2.0 / w as f64;
        for p in &image.pixels[y * w..(y + 1) * w] {
            for c in 0..3 {
                sum[c] += p[c] as f64 * weight;
            }
        }
    }
    Vec3::new(sum[0] as f32, sum[1] as f32, sum[2] as f32)
}

/// The piecewise-constant distribution over an environment image's cells (see the module
/// documentation).
#[derive(Debug)]
struct Distribution {
    width: usize,
    height: usize,
    /// Per cell (row-major, top row first): f, the largest luminance in the cell.
    func: Vec<f32>,
    /// Per row, the cumulative sums of f along it, divided by the row's sum (so the last entry
    /// is 1; a row of zeros, never chosen, is uniform).
    row_cdf: Vec<f32>,
    /// The cumulative sums over rows of Σₓ f · Δz, normalised to end at 1.
    marginal_cdf: Vec<f32>,
    /// z = cos θ at the row boundaries (height + 1, from 1 down to −1).
    z: Vec<f32>,
    /// 1 / ∫ f dω.
    inv_total: f32,
}

impl Distribution {
    /// `None` if the image is black (nothing to sample).
    fn new(image: &Image) -> Option<Distribution> {
        let (w, h) = (image.width as usize, image.height as usize);
        if w == 0 || h == 0 {
            return None;
        }
        let lum: Vec<f32> = image.pixels.iter().map(|&p| luminance(p).max(0.0)).collect();
        let mut func = Vec::with_capacity(w * h);
        for y in 0..h {
            // v is clamped at the poles; u wraps around.
            let row = |y: usize| &lum[y * w..(y + 1) * w];
            let (up, mid, down) = (row(y.saturating_sub(1)), row(y), row((y + 1).min(h - 1)));
            for x in 0..w {
                let (l, r) = (if x == 0 { w - 1 } else { x - 1 }, if x + 1 == w { 0 } else { x + 1 });
                let c = mid[x];
                let (cl, cr, cu, cd) = (c + mid[l], c + mid[r], c + up[x], c + down[x]);
                let edges = cl.max(cr).max(cu).max(cd);
                let corners = (cl + up[x] + up[l])
                    .max(cr + up[x] + up[r])
                    .max(cl + down[x] + down[l])
                    .max(cr + down[x] + down[r]);
                func.push(c.max(0.5 * edges).max(0.25 * corners));
            }
        }
        drop(lum);
        let z = row_boundaries(h);
        let mut row_cdf = Vec::with_capacity(w * h);
        let mut row_weight = Vec::with_capacity(h);
        for y in 0..h {
            let row = || func[y * w..(y + 1) * w].iter().map(|&f| f as f64);
            let sum: f64 = row().sum();
            match normalized_cdf(row(), sum) {
                Some(cdf) => row_cdf.extend(cdf),
                None => row_cdf.extend((0..w).map(|x| (x + 1) as f32 / w as f32)),
            }
            row_weight.push(sum * (z[y] - z[y + 1]));
        }
        let total: f64 = row_weight.iter().sum();
        let marginal_cdf = normalized_cdf(row_weight.iter().copied(), total)?;
        // ∫ f dω = Σ_rows Σₓ f · 2π/W · Δz.
        let integral = total * std::f64::consts::TAU / w as f64;
        Some(Distribution {
            width: w,
            height: h,
            func,
            row_cdf,
            marginal_cdf,
            z: z.iter().map(|&z| z as f32).collect(),
            inv_total: (1.0 / integral) as f32,
        })
    }

    fn bytes(&self) -> u64 {
        ((self.func.len() + self.row_cdf.len() + self.marginal_cdf.len() + self.z.len()) * size_of::<f32>()) as u64
    }

    /// A unit direction (in the image's frame) and its solid-angle density.
    #[inline]
    fn sample(&self, u: Vec2) -> (Vec3, f32) {
        let w = self.width;
        let (y, fy) = pick(&self.marginal_cdf, u.y);
        let (x, fx) = pick(&self.row_cdf[y * w..(y + 1) * w], u.x);
        // Uniform in z across the row and in φ across the column: uniform in solid angle.
        let z = self.z[y] + fy * (self.z[y + 1] - self.z[y]);
        let r = (1.0 - z * z).max(0.0).sqrt();
        // φ = 2π t − π, t = u: sin φ = −sin 2πt, cos φ = −cos 2πt.
        let t = (x as f32 + fx) / w as f32;
        let (s, c) = crate::fastmath::sin_cos_turns(t);
        (Vec3::new(-r * s, z, r * c), self.func[y * w + x] * self.inv_total)
    }

    /// Solid-angle density of [`Distribution::sample`] at the unit direction `l` (image frame).
    #[inline]
    fn pdf(&self, l: Vec3) -> f32 {
        let uv = image_uv(l);
        if !uv.is_finite() {
            return 0.0;
        }
        let x = ((uv.x * self.width as f32) as usize).min(self.width - 1);
        let y = (((1.0 - uv.y) * self.height as f32) as usize).min(self.height - 1);
        self.func[y * self.width + x] * self.inv_total
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Rng;

    fn image(width: u32, height: u32, f: impl Fn(u32, u32) -> Vec3) -> Arc<Image> {
        let pixels = (0..height).flat_map(|y| (0..width).map(move |x| (x, y))).map(|(x, y)| f(x, y)).collect();
        Arc::new(Image { width, height, pixels })
    }

    /// A dim sky with a bright 2×2-texel sun above the horizon, and a bluish gradient.
    fn sun_sky() -> Arc<Image> {
        image(64, 32, |x, y| {
            if (40..42).contains(&x) && (9..11).contains(&y) {
                Vec3::new(5000.0, 4000.0, 3000.0)
            } else {
                Vec3::new(0.2, 0.3, 0.5) * (1.0 + y as f32 / 32.0)
            }
        })
    }

    /// Unit direction at the centre of cell (i, j) of an n × m grid uniform in (φ, z).
    fn grid_direction(i: usize, j: usize, n: usize, m: usize) -> Vec3 {
        let z = 1.0 - 2.0 * (j as f64 + 0.5) / m as f64;
        let phi = std::f64::consts::TAU * (i as f64 + 0.5) / n as f64;
        let r = (1.0 - z * z).sqrt();
        Vec3::new((r * phi.cos()) as f32, z as f32, (r * phi.sin()) as f32)
    }

    #[test]
    fn the_density_integrates_to_one_over_the_sphere() {
        // Midpoint rule in (φ, z), in which the sphere's measure is uniform: 4π / (n m) each.
        for env in [
            Environment::new(sun_sky(), 1.0, 0.0),
            Environment::new(sun_sky(), 3.0, 37.0),
            Environment::new(image(7, 5, |x, y| Vec3::splat((x * y) as f32)), 1.0, -90.0),
            Environment::new(sun_sky(), 1.0, 0.0).uniformly_sampled(),
        ] {
            let (n, m) = (1024, 1024);
            let mut sum = 0.0f64;
            for j in 0..m {
                for i in 0..n {
                    sum += env.pdf(grid_direction(i, j, n, m)) as f64;
                }
            }
            let integral = sum * 4.0 * std::f64::consts::PI / (n * m) as f64;
            assert!((integral - 1.0).abs() < 2e-3, "{env:?}: ∫ pdf dω = {integral}");
        }
    }

    #[test]
    fn sampled_directions_follow_the_density() {
        // Histogram of 2,000,000 sampled directions over the image's own cells (64 × 32 bins,
        // in the image's frame: the environment is rotated 30°) against the density at each
        // cell's centre times its solid angle 2π/W · Δz. Every bin that expects ≥ 100 samples
        // within 5 standard deviations, and the total variation distance below 1%.
        let env = Environment::new(sun_sky(), 1.0, 30.0);
        let (w, h) = (64usize, 32usize);
        let z = row_boundaries(h);
        let mut expected = vec![0.0f64; w * h];
        for y in 0..h {
            for x in 0..w {
                let zc = 0.5 * (z[y] + z[y + 1]);
                let t = (x as f64 + 0.5) / w as f64;
                let (s, c) = (std::f64::consts::TAU * t).sin_cos();
                let r = (1.0 - zc * zc).sqrt();
                let centre = env.to_world(Vec3::new((-r * s) as f32, zc as f32, (r * c) as f32));
                let solid_angle = std::f64::consts::TAU / w as f64 * (z[y] - z[y + 1]);
                expected[y * w + x] = env.pdf(centre) as f64 * solid_angle;
            }
        }
        let sum: f64 = expected.iter().sum();
        assert!((sum - 1.0).abs() < 1e-5, "cell probabilities sum to {sum}");
        let samples = 2_000_000;
        let mut counts = vec![0u64; w * h];
        let mut rng = Rng::new(7, 0);
        let mut on_edges = 0;
        for _ in 0..samples {
            let s = env.sample(1.0, rng.next_2d()).unwrap();
            assert!((s.wi.length() - 1.0).abs() < 1e-5);
            // The sample's own density is the one `pdf` gives for its direction, but for
            // directions on a cell's edge, which rounding (of the rotation, the arctangent) can
            // put in the next cell: measured 3 in 2,000,000 here.
            let p = env.pdf(s.wi);
            on_edges += ((s.pdf - p).abs() > 1e-3 * p) as u32;
            let uv = image_uv(env.to_image(s.wi));
            let x = ((uv.x * w as f32) as usize).min(w - 1);
            let y = (((1.0 - uv.y) * h as f32) as usize).min(h - 1);
            counts[y * w + x] += 1;
        }
        let mut tv = 0.0f64;
        for (k, (&c, &e)) in counts.iter().zip(&expected).enumerate() {
            let (got, want) = (c as f64, e * samples as f64);
            tv += (got - want).abs() / samples as f64 / 2.0;
            if want >= 100.0 {
                assert!((got - want).abs() <= 5.0 * want.sqrt(), "cell {k}: {got} samples, expected {want:.1}");
            }
        }
        assert!(tv < 0.01, "total variation distance {tv}");
        assert!(on_edges <= samples / 10_000, "{on_edges} samples whose pdf is that of another cell");
        // Most samples go to the sun's cells and their neighbours (a 4 × 4 block of 2048).
        let sunward = (0..20_000).filter(|_| env.sample(1.0, rng.next_2d()).unwrap().radiance.x > 100.0).count();
        assert!(sunward > 10_000, "{sunward} of 20000 samples toward the sun");
    }

    /// ∫ f(ω) dω over the sphere by the midpoint rule on an n × n grid uniform in (φ, z), in
    /// which the sphere's measure is uniform (4π / n² per point).
    fn sphere_integral(n: usize, f: impl Fn(Vec3) -> f64) -> f64 {
        let mut sum = 0.0f64;
        for j in 0..n {
            for i in 0..n {
                sum += f(grid_direction(i, j, n, n));
            }
        }
        sum * 4.0 * std::f64::consts::PI / (n * n) as f64
    }

    /// Mean and standard error of the mean of `samples` draws of `f(sample)`.
    fn estimate(env: &Environment, seed: u64, samples: usize, f: impl Fn(&LightSample) -> f64) -> (f64, f64) {
        let mut rng = Rng::new(seed, 0);
        let (mut s1, mut s2) = (0.0f64, 0.0f64);
        for _ in 0..samples {
            let x = env.sample(1.0, rng.next_2d()).map_or(0.0, |s| f(&s));
            (s1, s2) = (s1 + x, s2 + x * x);
        }
        let mean = s1 / samples as f64;
        let var = (s2 / samples as f64 - mean * mean).max(0.0);
        (mean, (var / samples as f64).sqrt())
    }

    #[test]
    fn radiance_over_density_averages_to_the_integral() {
        // The estimator next-event estimation uses, L(ω)/p(ω) for ω drawn by `sample`, is
        // unbiased: its mean is ∫ L dω, and with a cosine ∫ L cos⁺ dω (irradiance on a
        // surface facing up, and on one facing −X, away from the sun). The integrals come
        // from a 2048 × 2048 midpoint quadrature of `radiance` itself (the bilinear lookup,
        // independent of the distribution; the sun spans about 6 × 16 grid points). For the
        // sun sky rotated 30°, sampled by luminance and uniformly; 400,000 samples with a
        // fixed seed. Each mean within 4 standard errors of the integral; by luminance, facing
        // up or with no cosine, also within 0.3% of it (measured: 0.05% and 0.08%). Facing
        // away from the sun most samples go to it and count 0, so that estimate is the noisy
        // one (standard error 1.9%, measured 1.2% off).
        for env in [Environment::new(sun_sky(), 1.0, 30.0), Environment::new(sun_sky(), 1.0, 30.0).uniformly_sampled()]
        {
            for normal in [None, Some(Vec3::Y), Some(Vec3::NEG_X)] {
                let cos = |d: Vec3| normal.map_or(1.0, |n: Vec3| n.dot(d).max(0.0) as f64);
                let integral = sphere_integral(2048, |d| luminance(env.radiance(d)) as f64 * cos(d));
                let (mean, se) =
                    estimate(&env, 11, 400_000, |s| luminance(s.radiance) as f64 * cos(s.wi) / s.pdf as f64);
                let rel = (mean - integral).abs() / integral;
                eprintln!("{env:?}, normal {normal:?}: {mean:.5} ± {se:.5}, integral {integral:.5} ({rel:.2e})");
                assert!((mean - integral).abs() <= 4.0 * se, "{env:?}, {normal:?}: {mean} ± {se} vs {integral}");
                if env.importance_sampled() && normal != Some(Vec3::NEG_X) {
                    assert!(rel < 3e-3, "{env:?}, {normal:?}: {mean} vs {integral}");
                }
            }
        }
    }

    #[test]
    fn a_small_sun_needs_far_fewer_samples_by_luminance_than_uniformly() {
        // Irradiance on a surface facing up under the sun sky (the sun 2×2 of 64×32 texels,
        // 0.25% of the sphere, about 97% of the light): the relative MSE of an n-sample
        // estimate is Var/(n E²), so the ratio of the per-sample variances is the ratio of
        // the samples each needs to reach the same relMSE. 200,000 samples each, fixed
        // seeds; measured: relMSE per sample 0.75 by luminance, 258 uniformly, ratio 342.
        // (Not more: the cells around the sun get the largest value the bilinear lookup
        // takes in them, half or a quarter of the sun's, so their density sum is 9 sun texels'
        // worth against the 4 the radiance has — the price of radiance / density staying
        // bounded.) Asserted: above 150.
        let env = Environment::new(sun_sky(), 1.0, 0.0);
        let uniform = env.uniformly_sampled();
        let f = |s: &LightSample| luminance(s.radiance) as f64 * s.wi.y.max(0.0) as f64 / s.pdf as f64;
        let n = 200_000;
        let (m1, se1) = estimate(&env, 5, n, f);
        let (m2, se2) = estimate(&uniform, 6, n, f);
        let (rel1, rel2) = (se1 * se1 * n as f64 / (m1 * m1), se2 * se2 * n as f64 / (m2 * m2));
        eprintln!("relMSE per sample: by luminance {rel1:.4}, uniform {rel2:.4}, ratio {:.0}", rel2 / rel1);
        assert!(rel2 > 150.0 * rel1, "by luminance {rel1}, uniform {rel2}");
    }

    #[test]
    fn radiance_never_exceeds_the_cells_bound() {
        // radiance / density ≤ ∫ f dω · strength in every direction (f bounds the bilinear
        // lookup), so next-event estimation has no fireflies of its own.
        let env = Environment::new(sun_sky(), 2.0, 10.0);
        let dist = env.sampling.as_ref().unwrap();
        let bound = 2.0 / dist.inv_total;
        let mut rng = Rng::new(3, 0);
        for _ in 0..200_000 {
            let d = crate::light::uniform_sphere(rng.next_2d());
            let ratio = luminance(env.radiance(d)) / env.pdf(d);
            assert!(ratio <= bound * 1.0001, "{ratio} > {bound} at {d}");
        }
    }

    #[test]
    fn an_image_of_one_value_is_sampled_uniformly() {
        let env = Environment::new(image(16, 8, |_, _| Vec3::splat(0.7)), 1.0, 0.0);
        let mut rng = Rng::new(1, 0);
        let n = 100_000;
        let (mut z1, mut z2) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let s = env.sample(1.0, rng.next_2d()).unwrap();
            assert!((s.pdf * 4.0 * PI - 1.0).abs() < 1e-5, "{}", s.pdf);
            assert!((s.radiance - Vec3::splat(0.7)).abs().max_element() < 1e-6);
            (z1, z2) = (z1 + s.wi.y as f64, z2 + (s.wi.y * s.wi.y) as f64);
        }
        // Uniform over the sphere, also within the cells: z is uniform on [−1, 1] (mean 0,
        // mean square 1/3; standard errors 0.0018 and 0.0009).
        assert!((z1 / n as f64).abs() < 0.01 && (z2 / n as f64 - 1.0 / 3.0).abs() < 0.005, "{z1} {z2}");
        assert!((env.average() - Vec3::splat(0.7)).abs().max_element() < 1e-6);
    }

    #[test]
    fn the_image_centre_is_minus_z_and_rotation_turns_it_about_y() {
        // A bright texel block at the image's centre: seen at −Z, and at −X after 90°.
        let img = image(8, 4, |x, y| if (3..5).contains(&x) && (1..3).contains(&y) { Vec3::ONE } else { Vec3::ZERO });
        let plain = Environment::new(img.clone(), 1.0, 0.0);
        assert_eq!(plain.radiance(Vec3::NEG_Z), Vec3::ONE);
        assert_eq!(plain.radiance(Vec3::NEG_X), Vec3::ZERO);
        let turned = Environment::new(img, 1.0, 90.0);
        assert!((turned.radiance(Vec3::NEG_X) - Vec3::ONE).abs().max_element() < 1e-5);
        assert_eq!(turned.radiance(Vec3::NEG_Z), Vec3::ZERO);
        // Samples come from where it shines (and the cells around, where the bilinear lookup
        // spreads it): toward −X on average, most of them lit.
        let mut rng = Rng::new(2, 0);
        let (mut x, mut lit) = (0.0, 0);
        for _ in 0..1000 {
            let s = turned.sample(1.0, rng.next_2d()).unwrap();
            x += s.wi.x / 1000.0;
            lit += (s.radiance != Vec3::ZERO) as u32;
        }
        assert!(x < -0.5 && lit > 700, "mean x {x}, {lit} of 1000 lit");
    }

    #[test]
    fn the_mean_weighs_texels_by_solid_angle() {
        // Top half 1, bottom half 0: half the sphere either way, whatever the rows' count.
        let env = Environment::new(image(4, 6, |_, y| Vec3::splat((y < 3) as u32 as f32)), 2.0, 0.0);
        assert!((env.average() - Vec3::ONE).abs().max_element() < 1e-6, "{}", env.average());
        // A single bright row at a pole counts for less than one at the equator.
        let pole = Environment::new(image(4, 8, |_, y| Vec3::splat((y == 0) as u32 as f32)), 1.0, 0.0);
        let equator = Environment::new(image(4, 8, |_, y| Vec3::splat((y == 4) as u32 as f32)), 1.0, 0.0);
        assert!(pole.average().x < 0.3 * equator.average().x);
    }

    #[test]
    fn a_black_image_has_no_distribution() {
        let env = Environment::new(image(4, 2, |_, _| Vec3::ZERO), 1.0, 0.0);
        assert!(!env.importance_sampled());
        assert_eq!(env.average(), Vec3::ZERO);
    }
}

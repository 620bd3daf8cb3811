//! The pixel reconstruction filter, by filter importance sampling: each sample's film
//! position is drawn from the filter's distribution around the pixel centre, and every sample
//! counts with weight 1, so a pixel is the plain mean of its own samples. Nothing is splatted
//! into neighbouring pixels: a pixel's value depends only on its own random streams, so the
//! image stays bit-identical for any thread count, tile order or interruption, and the
//! per-pixel error estimate stays that of independent samples.
//!
//! - `box`: uniform over the pixel (the default): the position is exactly `x + u`, the same
//!   bits as a film position drawn without any filter;
//! - `gaussian`: a Gaussian of standard deviation 0.5 pixel truncated at radius 1.5 (3σ, the
//!   defaults of pbrt-v4's Gaussian filter), sampled exactly by inverting its distribution
//!   function in each axis (the filter is separable): `σ√2 · erf⁻¹((2u - 1) · erf(r / σ√2))`.
//!   pbrt-v4 subtracts the Gaussian's value at the radius so that the filter reaches zero
//!   there, and samples that shape from a table with weight f/pdf; the plain truncated
//!   Gaussian has an exact inverse, so its weight is exactly 1 (the step at 3σ is 1.1% of the
//!   peak).

use glam::Vec2;

/// How a pixel's samples are placed (see the module documentation).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PixelFilter {
    /// Uniform over the pixel's square.
    #[default]
    Box,
    /// A truncated Gaussian around the pixel centre (σ = 0.5, radius 1.5 pixels).
    Gaussian,
}

/// The Gaussian filter's standard deviation, in pixels.
pub const GAUSSIAN_SIGMA: f32 = 0.5;
/// The Gaussian filter's radius, in pixels: 3σ.
pub const GAUSSIAN_RADIUS: f32 = 1.5;
/// erf(r / (σ√2)) = erf(3 / √2): the probability that a normal variable lies within 3σ.
const ERF_RADIUS: f32 = 0.997_300_2;

impl PixelFilter {
    pub const ALL: [PixelFilter; 2] = [PixelFilter::Box, PixelFilter::Gaussian];

    /// The name used on the command line, in scene files and in checkpoint keys.
    pub fn name(self) -> &'static str {
        match self {
            PixelFilter::Box => "box",
            PixelFilter::Gaussian => "gaussian",
        }
    }

    /// How far from the pixel centre a sample may land, in pixels.
    pub fn radius(self) -> f32 {
        match self {
            PixelFilter::Box => 0.5,
            PixelFilter::Gaussian => GAUSSIAN_RADIUS,
        }
    }

    /// Where a sample of pixel (x, y) lands on the film, in pixels (the pixel's square is
    /// [x, x + 1) × [y, y + 1)), for two uniform numbers `u` in [0, 1). Inlined at every
    /// camera ray; the Gaussian's inverse CDF stays out of line.
    #[inline(always)]
    pub fn film_position(self, x: u32, y: u32, u: Vec2) -> Vec2 {
        match self {
            // Exactly the arithmetic of the box-only renderer: bit-identical positions.
            PixelFilter::Box => Vec2::new(x as f32 + u.x, y as f32 + u.y),
            PixelFilter::Gaussian => {
                Vec2::new(x as f32 + 0.5 + gaussian_offset(u.x), y as f32 + 0.5 + gaussian_offset(u.y))
            }
        }
    }

    /// The pixels a value seen at film position `p` (in pixels) counts in, each with the
    /// filter's density there (per pixel²): what [`PixelFilter::film_position`] draws around
    /// that pixel, so that light splatted onto the film from elsewhere (a path from a light)
    /// counts in a pixel's mean as a sample of the pixel would. Calls `add(x, y, weight)` for
    /// each pixel inside the `width` × `height` film.
    pub fn splat(self, p: Vec2, (width, height): (u32, u32), mut add: impl FnMut(u32, u32, f32)) {
        let inside = |x: f32, y: f32| x >= 0.0 && y >= 0.0 && x < width as f32 && y < height as f32;
        match self {
            PixelFilter::Box => {
                if inside(p.x, p.y) {
                    add((p.x as u32).min(width - 1), (p.y as u32).min(height - 1), 1.0);
                }
            }
            PixelFilter::Gaussian => {
                let r = GAUSSIAN_RADIUS;
                // The truncated Gaussian's density along one axis.
                let norm = 1.0 / (GAUSSIAN_SIGMA * (2.0 * std::f32::consts::PI).sqrt() * ERF_RADIUS);
                let density = |t: f32| {
                    if t.abs() <= r { norm * (-0.5 * (t / GAUSSIAN_SIGMA).powi(2)).exp() } else { 0.0 }
                };
                let (x0, x1) = ((p.x - 0.5 - r).ceil().max(0.0), (p.x - 0.5 + r).floor().min(width as f32 - 1.0));
                let (y0, y1) = ((p.y - 0.5 - r).ceil().max(0.0), (p.y - 0.5 + r).floor().min(height as f32 - 1.0));
                let mut y = y0;
                while y <= y1 {
                    let wy = density(p.y - (y + 0.5));
                    let mut x = x0;
                    while x <= x1 {
                        let w = density(p.x - (x + 0.5)) * wy;
                        if w > 0.0 {
                            add(x as u32, y as u32, w);
                        }
                        x += 1.0;
                    }
                    y += 1.0;
                }
            }
        }
    }
}

crate::choice::named_choice!(PixelFilter, "pixel filter");

/// An offset from the pixel centre distributed as the truncated Gaussian, for `u` in [0, 1):
/// the inverse of its distribution function.
#[inline(never)]
fn gaussian_offset(u: f32) -> f32 {
    let offset = GAUSSIAN_SIGMA * std::f32::consts::SQRT_2 * erf_inv((2.0 * u - 1.0) * ERF_RADIUS);
    // Rounding must not carry a sample past the radius.
    offset.clamp(-GAUSSIAN_RADIUS, GAUSSIAN_RADIUS)
}

/// The inverse error function on (-1, 1): Mike Giles's single-precision approximation
/// ("Approximating the erfinv function", GPU Computing Gems Jade Edition, 2011), a polynomial
/// in w = -ln(1 - x²) on each of two ranges; relative error below 4e-7 in f32. The
/// coefficients are written as published (more digits than an f32 holds).
#[inline]
#[allow(clippy::excessive_precision)]
fn erf_inv(x: f32) -> f32 {
    let w = -((1.0 - x) * (1.0 + x)).ln();
    let p = if w < 5.0 {
        let w = w - 2.5;
        [
            2.810_226_36e-8,
            3.432_739_39e-7,
            -3.523_387_7e-6,
            -4.391_506_54e-6,
            2.185_808_7e-4,
            -1.253_725_03e-3,
            -4.177_681_64e-3,
            2.466_407_27e-1,
            1.501_409_41,
        ]
        .into_iter()
        .fold(0.0, |p, c| p * w + c)
    } else {
        let w = w.sqrt() - 3.0;
        [
            -2.002_142_57e-4,
            1.009_505_58e-4,
            1.349_343_22e-3,
            -3.673_428_44e-3,
            5.739_507_73e-3,
            -7.622_461_3e-3,
            9.438_870_47e-3,
            1.001_674_06,
            2.832_976_82,
        ]
        .into_iter()
        .fold(0.0, |p, c| p * w + c)
    };
    p * x
}

#[cfg(test)]
mod tests {
    use super::*;

    /// erf by Simpson's rule in double precision.
    fn erf(x: f64) -> f64 {
        let n = 2000;
        let h = x / n as f64;
        let f = |t: f64| (-t * t).exp();
        let s: f64 = (0..=n)
            .map(|i| {
                let w = if i == 0 || i == n {
                    1.0
                } else if i % 2 == 1 {
                    4.0
                } else {
                    2.0
                };
                w * f(i as f64 * h)
            })
            .sum();
        s * h / 3.0 * 2.0 / std::f64::consts::PI.sqrt()
    }

    #[test]
    fn names_parse_and_print() {
        for f in PixelFilter::ALL {
            assert_eq!(f.name().parse::<PixelFilter>(), Ok(f));
            assert_eq!(f.to_string(), f.name());
        }
        assert!("tent".parse::<PixelFilter>().unwrap_err().contains("expected box or gaussian"));
    }

    #[test]
    fn erf_inv_inverts_erf() {
        assert!((ERF_RADIUS as f64 - erf(3.0 / 2f64.sqrt())).abs() < 1e-7);
        assert_eq!(erf_inv(0.0), 0.0);
        // Published values: erf⁻¹(0.5) = 0.4769362762, erf⁻¹(0.9) = 1.1630871537,
        // erf⁻¹(0.99) = 1.8213863677.
        for (x, want) in [(0.5f32, 0.476_936_276_2f64), (0.9, 1.163_087_153_7), (0.99, 1.821_386_367_7)] {
            assert!((erf_inv(x) as f64 - want).abs() < 1e-6 * want, "erf_inv({x}) = {}", erf_inv(x));
            assert_eq!(erf_inv(-x), -erf_inv(x));
        }
        // Rounding x = erf(y) to f32 moves it by up to 6e-8, which erf⁻¹ magnifies by its
        // slope √π/2 · exp(y²).
        for i in 1..140 {
            let y = i as f64 * 0.015;
            let x = erf(y);
            let tolerance = 1e-6 * y + 6e-8 * 0.9 * (y * y).exp();
            assert!((erf_inv(x as f32) as f64 - y).abs() < tolerance, "erf_inv(erf({y}))");
        }
    }

    #[test]
    fn a_splat_spreads_over_the_pixels_as_their_samples_do() {
        let splats = |f: PixelFilter, p: Vec2| {
            let mut v = Vec::new();
            f.splat(p, (20, 10), |x, y, w| v.push((x, y, w)));
            v
        };
        assert_eq!(splats(PixelFilter::Box, Vec2::new(7.25, 3.999)), vec![(7, 3, 1.0)]);
        assert!(splats(PixelFilter::Box, Vec2::new(20.0, 3.0)).is_empty());
        assert!(splats(PixelFilter::Box, Vec2::new(-0.1, 3.0)).is_empty());
        // Inside the film, the Gaussian's weights sum to 1 (a density per pixel², summed over
        // unit pixels), and the nearest centre weighs most.
        let g = splats(PixelFilter::Gaussian, Vec2::new(7.3, 4.6));
        let total: f32 = g.iter().map(|s| s.2).sum();
        assert!((total - 1.0).abs() < 0.03, "{total}");
        let best = g.iter().max_by(|a, b| a.2.total_cmp(&b.2)).unwrap();
        assert_eq!((best.0, best.1), (7, 4));
        assert!(g.iter().all(|s| (5..=9).contains(&s.0) && (3..=6).contains(&s.1)));
        // At the film's corner only the pixels on it.
        assert!(splats(PixelFilter::Gaussian, Vec2::new(0.2, 0.2)).iter().all(|s| s.0 <= 1 && s.1 <= 1));
    }

    #[test]
    fn box_positions_are_the_pixel_plus_the_uniforms() {
        for u in [Vec2::ZERO, Vec2::new(0.25, 0.999_999_9), Vec2::new(0.123_456_7, 0.5)] {
            let p = PixelFilter::Box.film_position(7, 3, u);
            assert_eq!(p, Vec2::new(7.0 + u.x, 3.0 + u.y));
        }
    }

    #[test]
    fn gaussian_positions_follow_the_truncated_gaussian() {
        // The stratified quantiles of [0, 1) give the distribution's moments closely.
        let n = 100_000;
        let offsets: Vec<f64> = (0..n)
            .map(|i| {
                let u = (i as f32 + 0.5) / n as f32;
                (PixelFilter::Gaussian.film_position(10, 0, Vec2::new(u, 0.5)).x - 10.5) as f64
            })
            .collect();
        assert!(offsets.iter().all(|o| o.abs() <= 1.5));
        assert!(offsets.windows(2).all(|w| w[0] <= w[1]), "the inverse distribution function rises");
        let mean = offsets.iter().sum::<f64>() / n as f64;
        let var = offsets.iter().map(|o| o * o).sum::<f64>() / n as f64;
        // A normal variable truncated at ±3σ: variance σ² (1 - 2·3·φ(3) / (2Φ(3) - 1)).
        let phi3 = (-4.5f64).exp() / (2.0 * std::f64::consts::PI).sqrt();
        let want = 0.25 * (1.0 - 6.0 * phi3 / erf(3.0 / 2f64.sqrt()));
        assert!(mean.abs() < 1e-5, "mean {mean}");
        assert!((var - want).abs() < 1e-4, "variance {var}, expected {want}");
        // Within the pixel (±0.5 = ±σ): erf(1/√2) / erf(3/√2) = 68.45% of the samples.
        let inside = offsets.iter().filter(|o| o.abs() < 0.5).count() as f64 / n as f64;
        assert!((inside - erf(0.5f64.sqrt()) / erf(3.0 / 2f64.sqrt())).abs() < 1e-3, "{inside}");
        // The centre sample lands on the pixel centre; u and 1 - u are symmetric.
        assert_eq!(PixelFilter::Gaussian.film_position(4, 9, Vec2::splat(0.5)), Vec2::new(4.5, 9.5));
        let (a, b) = (gaussian_offset(0.1), gaussian_offset(0.9));
        assert!((a + b).abs() < 1e-6, "{a} {b}");
    }
}

//! What each pixel should hold when the answer is known in closed form.
//!
//! The renderer averages samples jittered uniformly over each pixel, so a pixel's expected
//! value is the average of the closed-form radiance over the pixel's area. [`Reference`]
//! approximates that average on an n × n grid of sub-pixel positions and also records how
//! much the radiance varies inside the pixel (its standard deviation and range): that is
//! the jitter noise a render with a finite sample count shows at edges and shadow
//! boundaries, and the grid's own error there is at most about range / n.

use crate::film::Film;
use glam::Vec2;
use rayon::prelude::*;

/// One pixel's reference: mean over the pixel, standard deviation and range inside it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelReference {
    pub mean: f64,
    pub sd: f64,
    pub range: f64,
}

/// Per-pixel references for a `width` × `height` image.
#[derive(Clone, Debug)]
pub struct Reference {
    pub width: u32,
    pub height: u32,
    /// Sub-pixel grid size per axis.
    pub grid: u32,
    pub pixels: Vec<PixelReference>,
}

impl Reference {
    /// `value(film)` is the closed-form value at film position `film` in [0, 1]² (x right, y
    /// down), the same convention as [`crate::camera::Camera::ray`].
    pub fn new(width: u32, height: u32, grid: u32, value: impl Fn(Vec2) -> f64 + Sync) -> Reference {
        let at = |x: u32, y: u32, fx: f32, fy: f32| {
            Vec2::new((x as f32 + fx) / width as f32, (y as f32 + fy) / height as f32)
        };
        let pixels = (0..width * height)
            .into_par_iter()
            .map(|i| {
                let (x, y) = (i % width, i / width);
                let (mut sum, mut sum2, mut lo, mut hi) = (0.0, 0.0, f64::INFINITY, f64::NEG_INFINITY);
                for j in 0..grid {
                    for k in 0..grid {
                        let v = value(at(x, y, (k as f32 + 0.5) / grid as f32, (j as f32 + 0.5) / grid as f32));
                        sum += v;
                        sum2 += v * v;
                        lo = lo.min(v);
                        hi = hi.max(v);
                    }
                }
                // The border at four times the density: an edge that only clips the pixel
                // between grid points still shows in the range.
                let m = 4 * grid;
                for k in 0..=m {
                    let s = k as f32 / m as f32;
                    for (fx, fy) in [(s, 0.0), (s, 1.0), (0.0, s), (1.0, s)] {
                        let v = value(at(x, y, fx, fy));
                        lo = lo.min(v);
                        hi = hi.max(v);
                    }
                }
                let n = (grid * grid) as f64;
                let mean = sum / n;
                PixelReference { mean, sd: (sum2 / n - mean * mean).max(0.0).sqrt(), range: hi - lo }
            })
            .collect();
        Reference { width, height, grid, pixels }
    }

    /// Whether pixel `index`'s value is the same over its whole area (no edge inside it).
    pub fn is_flat(&self, index: usize) -> bool {
        self.pixels[index].range <= 1e-9 * self.pixels[index].mean.abs()
    }
}

/// How a render compares with a [`Reference`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Comparison {
    /// Pixels whose error exceeds `rel` × expected plus what jitter explains.
    pub off: usize,
    pub total: usize,
    /// Largest relative error |got − expected| / expected over pixels with no edge inside.
    pub worst_flat: f64,
    /// Largest error in units of the allowance (≤ 1 means within tolerance everywhere).
    pub worst_ratio: f64,
}

impl Comparison {
    pub fn off_fraction(&self) -> f64 {
        self.off as f64 / self.total.max(1) as f64
    }
}

/// Compares the grey value (mean of the channels) of each pixel of `film`, rendered with
/// `spp` samples per pixel, with `reference`. A pixel is off when
/// |got − mean| > rel·mean + jitter + range/grid + 1e-5·mean (float rounding),
/// i.e. by more than `rel` beyond the jitter noise and the grid's own error. `jitter` is
/// Bernstein's bound √(2 sd'² L / spp) + range·L / (3 spp), L = ln(2/δ): the mean of `spp`
/// independent samples of variance sd'², spread over at most `range`, strays further from
/// its expectation with probability at most `delta` (δ), whatever their distribution, where
/// sd' = max(sd, range·√(q(1 − q))), q = 1/grid, allows for an edge the grid missed. A pixel
/// that an edge cuts has two-valued samples: a binomial count whose tails at 16 spp are far
/// heavier than a normal's, so a normal allowance (4σ/√spp) fails correct renders: with it,
/// 3 of 40 seeds had a pixel off in `glass-ior-1` or `inside-glass-tir` (one of them 12 of 16
/// jittered positions in the escaping quarter of a pixel, which the render then counted
/// exactly). Pixels without an edge have no jitter noise and keep the full sensitivity.
pub fn compare(film: &Film, reference: &Reference, spp: u32, rel: f64, delta: f64) -> Comparison {
    assert_eq!((film.width, film.height), (reference.width, reference.height), "reference size");
    let (mut off, mut worst_flat, mut worst_ratio) = (0, 0.0f64, 0.0f64);
    let l = (2.0 / delta).ln();
    let n = spp as f64;
    for (i, (p, e)) in film.pixels.iter().zip(&reference.pixels).enumerate() {
        let got = grey(*p);
        let err = (got - e.mean).abs();
        // An edge can hide between grid points in up to about 1/grid of the pixel: the jitter
        // spread is at least that of a pixel split 1/grid : (grid − 1)/grid.
        let q = 1.0 / reference.grid as f64;
        let sd = e.sd.max(e.range * (q * (1.0 - q)).sqrt());
        let jitter = (2.0 * sd * sd * l / n).sqrt() + e.range * l / (3.0 * n);
        let allow = rel * e.mean + jitter + e.range / reference.grid as f64 + 1e-5 * e.mean + 1e-30;
        if !(err <= allow) {
            off += 1;
        }
        worst_ratio = worst_ratio.max(if err.is_nan() { f64::INFINITY } else { err / allow });
        if reference.is_flat(i) {
            let rel_err = if e.mean > 0.0 { err / e.mean } else { err };
            worst_flat = worst_flat.max(if rel_err.is_nan() { f64::INFINITY } else { rel_err });
        }
    }
    Comparison { off, total: film.pixels.len(), worst_flat, worst_ratio }
}

/// The `side` × `side` pixel blocks of a `width` × `height` image (narrower at the right and
/// lower edges), row by row from the top left: each block's top-left pixel and the indices of
/// its pixels, row by row.
pub fn blocks(width: u32, height: u32, side: u32) -> impl Iterator<Item = ((u32, u32), Vec<usize>)> {
    let step = side.max(1) as usize;
    (0..height).step_by(step).flat_map(move |by| {
        (0..width).step_by(step).map(move |bx| {
            let pixels = (by..(by + side).min(height))
                .flat_map(|y| (bx..(bx + side).min(width)).map(move |x| (y * width + x) as usize))
                .collect();
            ((bx, by), pixels)
        })
    })
}

/// Grey value of a pixel: the mean of its channels.
pub fn grey(pixel: glam::Vec3) -> f64 {
    (pixel.x as f64 + pixel.y as f64 + pixel.z as f64) / 3.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn blocks_cover_the_image_once_narrower_at_the_edges() {
        let b: Vec<_> = blocks(5, 3, 2).collect();
        assert_eq!(
            b,
            vec![
                ((0, 0), vec![0, 1, 5, 6]),
                ((2, 0), vec![2, 3, 7, 8]),
                ((4, 0), vec![4, 9]),
                ((0, 2), vec![10, 11]),
                ((2, 2), vec![12, 13]),
                ((4, 2), vec![14]),
            ]
        );
    }

    fn film(w: u32, h: u32, f: impl Fn(u32, u32) -> f32) -> Film {
        let mut film = Film::new(w, h);
        for y in 0..h {
            for x in 0..w {
                film.pixels[(y * w + x) as usize] = Vec3::splat(f(x, y));
            }
        }
        film
    }

    #[test]
    fn an_edge_is_seen_and_an_error_is_caught() {
        // Left half 1, right half 0, the edge at x = 0.5 + 0.01 (inside pixel 4 of 8).
        let r = Reference::new(8, 2, 8, |p| if p.x < 0.51 { 1.0 } else { 0.0 });
        assert!(r.is_flat(0) && !r.is_flat(4) && r.is_flat(7));
        assert!((r.pixels[4].mean - 0.125).abs() < 1e-9, "{:?}", r.pixels[4]);
        let exact = film(8, 2, |x, _| [1.0, 1.0, 1.0, 1.0, 0.125, 0.0, 0.0, 0.0][x as usize]);
        assert_eq!(compare(&exact, &r, 16, 0.01, 1e-6).off, 0);
        // 2% too bright in one flat pixel: caught at 1%, not at 5%.
        let bright = film(8, 2, |x, y| if (x, y) == (1, 1) { 1.02 } else { exact.get(x, y).x });
        assert_eq!(compare(&bright, &r, 16, 0.01, 1e-6).off, 1);
        assert_eq!(compare(&bright, &r, 16, 0.05, 1e-6).off, 0);
        // A NaN is always off.
        let nan = film(8, 2, |x, _| if x == 6 { f32::NAN } else { exact.get(x, 0).x });
        assert_eq!(compare(&nan, &r, 16, 0.05, 1e-6).off, 2);
    }

    #[test]
    fn an_edge_pixels_binomial_tail_is_jitter_but_a_wrong_pixel_is_not() {
        // 1/16 of the pixel dark (0.2), the rest 0.8: 1 of 16 samples dark on average.
        let r = Reference::new(1, 1, 16, |p| if p.x < 1.0 / 16.0 { 0.2 } else { 0.8 });
        assert!((r.pixels[0].mean - 0.7625).abs() < 1e-9);
        let with_dark = |k: f32| film(1, 1, |_, _| 0.8 - 0.6 * k / 16.0);
        // 6 of 16 dark (probability 2.5e-4): a normal 4σ allowance called this off.
        assert_eq!(compare(&with_dark(6.0), &r, 16, 1e-3, 1e-6).off, 0);
        // Every sample dark: the pixel shows the wrong surface.
        assert_eq!(compare(&with_dark(16.0), &r, 16, 1e-3, 1e-6).off, 1);
        // With 256 samples the same fraction (6/16) is far outside the noise.
        assert_eq!(compare(&with_dark(6.0), &r, 256, 1e-3, 1e-6).off, 1);
    }

    #[test]
    fn an_edge_clipping_the_border_counts_as_an_edge() {
        // The edge lies within 1/64 of pixel 1's left border, between its interior grid points.
        let r = Reference::new(4, 1, 8, |p| if p.x < 0.25 + 0.004 { 1.0 } else { 0.0 });
        assert!(!r.is_flat(1), "{:?}", r.pixels[1]);
    }
}

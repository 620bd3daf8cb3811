//! How far an image is from a reference image: relative mean squared error and mean absolute
//! error, both over every pixel and every colour channel.
//!
//! relMSE = (1 / 3P) Σ_pixels Σ_channels (x − r)² / (r² + ε), with ε = [`REL_MSE_EPSILON`].
//!
//! Every pixel weighs the same whatever its brightness, so noise on a dim wall counts as much
//! as noise on a bright one; the ratio of sums Σ(x − r)² / Σr² would instead be dominated by
//! the brightest pixels (a visible light source, whose pixels are exact, would hide the noise
//! everywhere else). ε keeps near-black pixels, where a relative error means nothing, from
//! dominating: below r ≈ √ε = 0.1 the error is measured more and more in absolute terms.
//! For an unbiased estimator with independent samples, E[relMSE] falls exactly as 1/spp.
//!
//! MAE = (1 / 3P) Σ_pixels Σ_channels |x − r|, in radiance units; it falls as 1/√spp.
//!
//! FLIP is NVIDIA's perceptual difference (Andersson et al. 2020, "FLIP: A Difference
//! Evaluator for Alternating Images"), through the `nv-flip` crate (which compiles NVIDIA's
//! C++ implementation; nothing is downloaded at build time): the mean over pixels of its error
//! map, in [0, 1], of the images as a PNG shows them — 8-bit sRGB, clamped to [0, 1], the LDR
//! form of FLIP — seen at [`FLIP_PIXELS_PER_DEGREE`] (a 0.7 m viewing distance from a 24"
//! 4K monitor, FLIP's default). It weighs what a viewer notices: colour and edge and point
//! differences after the eye's contrast sensitivity, rather than squared radiance. At that
//! distance pixel-scale noise is damped and smooth, blotchy differences are not: a ±0.1
//! one-pixel checkerboard scores 0.013, a uniform shift of 0.02 scores 0.077 (the test below).

use crate::film::Film;

pub use crate::film::REL_MSE_EPSILON;

/// FLIP's observer: 67 pixels per degree of visual angle (`nv_flip::DEFAULT_PIXELS_PER_DEGREE`).
pub const FLIP_PIXELS_PER_DEGREE: f32 = nv_flip::DEFAULT_PIXELS_PER_DEGREE;

/// How far an image is from a reference: a measurement, not a failure.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ImageDifference {
    /// Relative mean squared error (see the module documentation).
    pub rel_mse: f64,
    /// Mean absolute error, in radiance units.
    pub mae: f64,
    /// Mean FLIP error of the 8-bit sRGB images, in [0, 1] (see the module documentation).
    pub flip: f64,
}

/// The two images do not have the same size.
#[derive(Debug, thiserror::Error)]
#[error("image is {0}x{1} but the reference is {2}x{3}")]
pub struct SizeMismatch(pub u32, pub u32, pub u32, pub u32);

/// relMSE, MAE (sums in f64) and mean FLIP of `image` against `reference`.
pub fn image_difference(image: &Film, reference: &Film) -> Result<ImageDifference, SizeMismatch> {
    if (image.width, image.height) != (reference.width, reference.height) {
        return Err(SizeMismatch(image.width, image.height, reference.width, reference.height));
    }
    let (mut rel, mut abs) = (0.0f64, 0.0f64);
    for (x, r) in image.pixels.iter().zip(&reference.pixels) {
        for c in 0..3 {
            let (x, r) = (x[c] as f64, r[c] as f64);
            let d = x - r;
            rel += d * d / (r * r + REL_MSE_EPSILON);
            abs += d.abs();
        }
    }
    let n = (3 * image.pixels.len()).max(1) as f64;
    Ok(ImageDifference { rel_mse: rel / n, mae: abs / n, flip: flip_error(image, reference) })
}

/// The mean FLIP error of `image` against `reference` (same size), both as 8-bit sRGB.
pub fn flip_error(image: &Film, reference: &Film) -> f64 {
    assert_eq!((image.width, image.height), (reference.width, reference.height));
    if image.pixels.is_empty() {
        return 0.0;
    }
    let rgb8 = |f: &Film| nv_flip::FlipImageRgb8::with_data(f.width, f.height, &f.to_rgb8());
    let map = nv_flip::flip(rgb8(reference), rgb8(image), FLIP_PIXELS_PER_DEGREE);
    let values = map.to_vec();
    values.iter().map(|&v| v as f64).sum::<f64>() / values.len() as f64
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn film(pixels: &[Vec3]) -> Film {
        Film { width: pixels.len() as u32, height: 1, pixels: pixels.to_vec() }
    }

    #[test]
    fn identical_images_have_zero_error() {
        let a = film(&[Vec3::new(0.2, 3.0, 0.0), Vec3::ONE]);
        assert_eq!(image_difference(&a, &a).unwrap(), ImageDifference { rel_mse: 0.0, mae: 0.0, flip: 0.0 });
    }

    #[test]
    fn matches_the_definition_by_hand() {
        // Reference (1, 0, 2) and (0.5, 0.5, 0.5); image off by (+0.1, +0.3, −0.2) and
        // (0, −0.5, +0.5).
        let r = film(&[Vec3::new(1.0, 0.0, 2.0), Vec3::splat(0.5)]);
        let x = film(&[Vec3::new(1.1, 0.3, 1.8), Vec3::new(0.5, 0.0, 1.0)]);
        let e = REL_MSE_EPSILON;
        let rel = (0.01 / (1.0 + e) + 0.09 / e + 0.04 / (4.0 + e) + 0.0 + 0.25 / (0.25 + e) + 0.25 / (0.25 + e)) / 6.0;
        let mae = (0.1 + 0.3 + 0.2 + 0.0 + 0.5 + 0.5) / 6.0;
        let got = image_difference(&x, &r).unwrap();
        assert!((got.rel_mse - rel).abs() < 1e-6 * rel, "{} vs {rel}", got.rel_mse);
        assert!((got.mae - mae).abs() < 1e-6, "{} vs {mae}", got.mae);
    }

    #[test]
    fn relative_error_does_not_depend_on_brightness_far_above_epsilon() {
        // The same 10% error on a bright and on a 100× brighter image: relMSE ≈ 0.01 both times.
        for scale in [10.0f32, 1000.0] {
            let r = film(&[Vec3::splat(scale); 4]);
            let x = film(&[Vec3::splat(scale * 1.1); 4]);
            let got = image_difference(&x, &r).unwrap().rel_mse;
            assert!((got - 0.01).abs() < 1e-4, "scale {scale}: {got}");
        }
    }

    #[test]
    fn flip_grows_with_the_difference_and_sees_coarse_patterns_more_than_pixel_noise() {
        // A 64×64 grey image (0.3); copies with a uniform shift, and with ±0.1 checkerboards
        // of 1-pixel and of 8-pixel squares (the same MAE, 0.1). FLIP's observer (67 pixels per
        // degree) barely resolves a 1-pixel pattern: its contrast sensitivity falls off there.
        // Measured: shift 0.02 → 0.077, shift 0.1 → 0.245; checker 1 px → 0.013, 8 px → 0.316.
        let (w, h) = (64u32, 64u32);
        let r = Film { width: w, height: h, pixels: vec![Vec3::splat(0.3); (w * h) as usize] };
        let shifted = |d: f32| Film { pixels: vec![Vec3::splat(0.3 + d); (w * h) as usize], ..r.clone() };
        let checker = |size: u32| {
            let mut f = r.clone();
            for (i, p) in f.pixels.iter_mut().enumerate() {
                let (x, y) = (i as u32 % w / size, i as u32 / w / size);
                *p += Vec3::splat(if (x + y) % 2 == 0 { 0.1 } else { -0.1 });
            }
            f
        };
        let (small, large) = (flip_error(&shifted(0.02), &r), flip_error(&shifted(0.1), &r));
        let (fine, coarse) = (flip_error(&checker(1), &r), flip_error(&checker(8), &r));
        eprintln!("shift 0.02: {small}, 0.1: {large}; checker 1 px: {fine}, 8 px: {coarse}");
        assert_eq!(flip_error(&r, &r), 0.0);
        assert!(0.0 < small && small < large && large <= 1.0, "{small} {large}");
        assert!(0.0 < fine && 2.0 * fine < coarse && coarse <= 1.0, "{fine} {coarse}");
    }

    #[test]
    fn refuses_images_of_different_sizes() {
        let a = film(&[Vec3::ONE; 4]);
        let b = Film::new(2, 2);
        assert_eq!(image_difference(&a, &b).unwrap_err().to_string(), "image is 4x1 but the reference is 2x2");
    }
}

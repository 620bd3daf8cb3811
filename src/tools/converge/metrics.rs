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

use crate::film::Film;

/// ε in the relMSE denominator (r² + ε): radiance below about √ε = 0.1 is compared more and
/// more in absolute rather than relative terms.
pub const REL_MSE_EPSILON: f64 = 1e-2;

/// How far an image is from a reference: a measurement, not a failure.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ImageDifference {
    /// Relative mean squared error (see the module documentation).
    pub rel_mse: f64,
    /// Mean absolute error, in radiance units.
    pub mae: f64,
}

/// The two images do not have the same size.
#[derive(Debug, thiserror::Error)]
#[error("image is {0}x{1} but the reference is {2}x{3}")]
pub struct SizeMismatch(pub u32, pub u32, pub u32, pub u32);

/// relMSE and MAE of `image` against `reference` (sums in f64).
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
    Ok(ImageDifference { rel_mse: rel / n, mae: abs / n })
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
        assert_eq!(image_difference(&a, &a).unwrap(), ImageDifference { rel_mse: 0.0, mae: 0.0 });
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
    fn refuses_images_of_different_sizes() {
        let a = film(&[Vec3::ONE; 4]);
        let b = Film::new(2, 2);
        assert_eq!(image_difference(&a, &b).unwrap_err().to_string(), "image is 4x1 but the reference is 2x2");
    }
}

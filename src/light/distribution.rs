//! Piecewise-constant distributions over a list of cells, as cumulative sums: the one search
//! every light that samples by weight uses (the choice of a light by power, the rows and
//! columns of an environment image, the cells of an emission texture on a triangle).

use super::choice::ONE_BELOW;

/// The cumulative sums of `weights` (not negative) divided by `total`, their sum (which the
/// callers need themselves, so they pass it), so that the last is 1; `None` if the total is
/// not positive and finite. Accumulated in f64.
pub(super) fn normalized_cdf(weights: impl Iterator<Item = f64>, total: f64) -> Option<Vec<f32>> {
    if !(total > 0.0 && total.is_finite()) {
        return None;
    }
    let mut acc = 0.0f64;
    Some(
        weights
            .map(|w| {
                acc += w;
                (acc / total) as f32
            })
            .collect(),
    )
}

/// The entry of the cumulative distribution `cdf` (non-decreasing) that `u` falls in: the
/// first whose sum exceeds `u` (the last if none does). Entries of zero probability are never
/// picked.
#[inline]
pub(super) fn pick_index(cdf: &[f32], u: f32) -> usize {
    cdf.partition_point(|&c| c <= u).min(cdf.len() - 1)
}

/// [`pick_index`] for `u` in [0, 1) over a `cdf` ending at 1, and where in the entry `u` fell,
/// rescaled to [0, 1): a fresh uniform number for the choice inside the entry.
#[inline]
pub(super) fn pick(cdf: &[f32], u: f32) -> (usize, f32) {
    let i = pick_index(cdf, u);
    let lo = if i == 0 { 0.0 } else { cdf[i - 1] };
    let width = cdf[i] - lo;
    let f = if width > 0.0 { ((u - lo) / width).clamp(0.0, ONE_BELOW) } else { 0.5 };
    (i, f)
}

/// The probability of entry `i` of a `cdf` ending at 1.
#[inline]
pub(super) fn probability(cdf: &[f32], i: usize) -> f32 {
    cdf[i] - if i == 0 { 0.0 } else { cdf[i - 1] }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn picks_in_proportion_to_the_weights_and_never_a_zero_weight() {
        let cdf = normalized_cdf([1.0, 0.0, 3.0].into_iter(), 4.0).unwrap();
        assert_eq!(cdf, vec![0.25, 0.25, 1.0]);
        assert_eq!(pick(&cdf, 0.0), (0, 0.0));
        assert_eq!(pick(&cdf, 0.125), (0, 0.5));
        assert_eq!(pick(&cdf, 0.25).0, 2); // not the empty entry
        assert_eq!(pick(&cdf, 0.625), (2, 0.5));
        assert_eq!(pick(&cdf, ONE_BELOW).0, 2);
        assert_eq!([0, 1, 2].map(|i| probability(&cdf, i)), [0.25, 0.0, 0.75]);
        assert!(normalized_cdf([0.0, 0.0].into_iter(), 0.0).is_none());
        assert!(normalized_cdf([1.0, f64::INFINITY].into_iter(), f64::INFINITY).is_none());
    }
}

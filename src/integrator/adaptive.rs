//! Adaptive sample allocation at a fixed budget (`ember render`'s default above 8 spp): `spp`
//! becomes the budget, the time of `spp` samples in every pixel, and the render spends it
//! where the image is noisy.
//!
//! The render takes two rounds. In the first every pixel takes [`first_round_spp`] samples
//! (a quarter of the budget). Then [`allocate`] shares out the rest: pixel `i` gets a number
//! of samples proportional to the square root of its estimated relative variance per sample
//! (over its cost, below), which minimises the sum over pixels of relative variance / samples
//! for the total. Relative variance is meant as ember's relMSE measures error (`ember
//! converge`): per colour channel, over mean² + [`REL_MSE_EPSILON`], averaged over the
//! channels, so the allocation minimises the expected relMSE itself. (Measured on luminance
//! over max(mean, 0.01)² instead, as `--target-error` judges a pixel, it gave dim and
//! saturated pixels, a red wall, several times the weight relMSE gives them.) The estimate of pixel `i` is taken from its 24
//! neighbours' first-round samples (the 5×5 around it, [`REACH`]), **never from its own**: its sample count is then
//! independent of its own samples, each of which is an unbiased estimate of the pixel, so the
//! mean of however many it takes stays unbiased. (A pixel that decides from its own samples,
//! as `--target-error` does, stops more often after a run of samples that happen to agree,
//! which biases its mean slightly.) Variance is smooth across an image almost everywhere: a
//! pixel's neighbours are a good guide to it, and where they are not (a pixel-wide feature) the
//! pixel keeps at least its first-round samples.
//!
//! The allocation is a function of the first round's pixel states only, so the image is the
//! same for any thread count and tile order; it is saved in checkpoints, so a resumed render
//! ends in the same image too.

use crate::accel::LANES;
use crate::film::{AdaptivePixel, PixelState, REL_MSE_EPSILON};
use glam::DVec3;

/// The cost of a sample besides the rays after its camera ray, in units of such a ray: its
/// camera ray (traced in a packet of [`LANES`], coherent), its random numbers and its film
/// update. A fit of render time against samples and rays (the peers' teapot at 512², adaptive
/// and `--uniform`) gives 0.015; 0.1 keeps some samples in pixels that trace nothing more.
const SAMPLE_COST: f64 = 0.1;

/// How far a pixel's neighbourhood reaches: the (2 · REACH + 1)² pixels around it, less
/// itself (24). Noise is spread over a few pixels wherever it is (a soft shadow, an indirectly
/// lit crease), and one pixel's first round is a few samples: more neighbours estimate it
/// better. Against 3×3, on the peers' scenes at 512²: teapot relMSE 7.475e-5 → 6.385e-5,
/// Cornell box 0.007781 → 0.007709; at 256² −8.7% and −0.8%. At 64×64 it does not pay
/// (teapot 3.04e-5 → 3.31e-5): a 5×5 block is then a large part of a feature.
const REACH: usize = 2;

/// The most samples one pixel may take, as a multiple of the mean `spp`.
pub const MAX_FACTOR: u32 = 16;

/// Samples every pixel takes in the first round: a quarter of `spp`, rounded up to whole
/// packets of [`LANES`] (at least one), and never more than `spp`.
pub fn first_round_spp(spp: u32) -> u32 {
    (spp / 4).div_ceil(LANES as u32).max(1).saturating_mul(LANES as u32).min(spp)
}

/// Whether `ember render` samples adaptively at `spp` unless told otherwise (`--uniform`, a
/// target error): whenever the first round is not all of it, i.e. above [`LANES`] samples.
pub fn by_default(spp: u32) -> bool {
    first_round_spp(spp) < spp
}

/// The most samples a pixel may take in an adaptive render of mean `spp`.
pub fn max_spp(spp: u32) -> u32 {
    spp.saturating_mul(MAX_FACTOR)
}

/// The cost of a sample of a pixel whose `count` first-round samples traced `rays`, as the
/// budget counts it: the rays it traced after its camera ray, plus [`SAMPLE_COST`].
fn budget_cost(count: u32, rays: u32) -> f64 {
    SAMPLE_COST + (rays as f64 / count.max(1) as f64 - 1.0).max(0.0)
}

/// The cost of one sample of each pixel after the first round of an adaptive render, in
/// units of the mean first-round sample of the pixels `owned` (all, or a shard's): the pixel's
/// first-round rays per sample over their mean (1 where nothing was traced). A sample's time
/// follows the rays it traces, so this is how a progress report weighs the second round's
/// samples ([`work`]); a first-round sample counts 1 (the first round is the same everywhere
/// and taken in a shuffled order of tiles, so its samples take the mean time).
pub fn sample_costs(plan: &[AdaptivePixel], first_round: u32, owned: impl Fn(usize) -> bool) -> Vec<f64> {
    let per_sample = |a: &AdaptivePixel| a.rays as f64 / first_round.max(1) as f64;
    let (sum, n) = plan
        .iter()
        .enumerate()
        .filter(|&(i, _)| owned(i))
        .fold((0.0, 0usize), |(s, n), (_, a)| (s + per_sample(a), n + 1));
    let mean = sum / n.max(1) as f64;
    plan.iter().map(|a| if mean > 0.0 { per_sample(a) / mean } else { 1.0 }).collect()
}

/// The work of a pixel holding `count` samples in an adaptive render whose first round is
/// `first_round` samples, when a later sample of it costs `cost` ([`sample_costs`]): one per
/// first-round sample, `cost` per later one.
pub fn work(count: u32, first_round: u32, cost: f64) -> f64 {
    count.min(first_round) as f64 + count.saturating_sub(first_round) as f64 * cost
}

/// The mean cost of the samples the plan added after the first round, over the mean cost of a
/// sample of the pixels `owned`, as the budget counts costs: above 1 when they went to pixels
/// whose samples cost more than the mean (more bounces), so that fewer of them fit in the
/// budget and the mean spp falls below `spp`. `None` when the plan added none.
pub fn added_sample_cost(plan: &[AdaptivePixel], first_round: u32, owned: impl Fn(usize) -> bool) -> Option<f64> {
    let (mut pixels, mut mean, mut samples, mut added_cost) = (0usize, 0.0, 0u64, 0.0);
    for a in plan.iter().enumerate().filter(|&(i, _)| owned(i)).map(|(_, a)| a) {
        let cost = budget_cost(first_round, a.rays);
        let added = a.target.saturating_sub(first_round) as u64;
        (pixels, mean) = (pixels + 1, mean + cost);
        (samples, added_cost) = (samples + added, added_cost + added as f64 * cost);
    }
    (samples > 0 && mean > 0.0).then(|| added_cost / samples as f64 / (mean / pixels as f64))
}

/// Estimated relative variance of one sample of pixel state `p`, whose samples' squares sum to
/// `sum_sq`: per channel c, the sample variance s²_c over m_c² + [`REL_MSE_EPSILON`] (m_c the
/// mean), averaged over the channels: the expected relMSE of one sample. Zero with fewer than
/// two samples.
fn relative_variance(p: &PixelState, sum_sq: DVec3) -> f64 {
    if p.count < 2 {
        return 0.0;
    }
    let n = p.count as f64;
    let mean = p.sum / n;
    let var = ((sum_sq / n - mean * mean) * (n / (n - 1.0))).max(DVec3::ZERO);
    let rv = (var / (mean * mean + DVec3::splat(REL_MSE_EPSILON))).element_sum() / 3.0;
    if rv.is_finite() { rv } else { 0.0 }
}

/// The mean of `of` over pixel `i`'s neighbours in a `w`×`h` image (those inside it).
fn ring_mean(i: usize, of: &[f64], w: usize, h: usize) -> f64 {
    let (x, y) = (i % w, i / w);
    let (mut sum, mut n) = (0.0, 0u32);
    for ny in y.saturating_sub(REACH)..(y + REACH + 1).min(h) {
        for nx in x.saturating_sub(REACH)..(x + REACH + 1).min(w) {
            if (nx, ny) != (x, y) {
                sum += of[ny * w + nx];
                n += 1;
            }
        }
    }
    if n == 0 { 0.0 } else { sum / n as f64 }
}

/// Each pixel's neighbours' mean cost of a sample (its own for a one-pixel image), from the
/// first round's sample counts and the rays recorded in `plan`: a sample's cost is the rays it
/// traced after its camera ray, plus [`SAMPLE_COST`].
fn near_costs(counts: &[u32], plan: &[AdaptivePixel], w: usize, h: usize) -> Vec<f64> {
    let cost: Vec<f64> = counts.iter().zip(plan).map(|(&n, a)| budget_cost(n, a.rays)).collect();
    (0..w * h).map(|i| if w * h == 1 { cost[i] } else { ring_mean(i, &cost, w, h) }).collect()
}

/// Why the plan `plan` stored with pixel states `pixels` (a checkpoint's, or the first rounds
/// `--plan-from` reads) could not have come from a `w`×`h` render of mean `spp` whose samples
/// trace at most `rays_per_sample` rays each, if it could not: a pixel whose first round
/// recorded more rays than its samples can trace (which would make the plan send samples
/// elsewhere: a render many times longer), a target outside the first round to [`max_spp`]
/// or off the packets [`allocate`] gives, a plan made before every first round was done, or
/// targets that spend more than the budget [`allocate`] shares out. The error names the pixel
/// where there is one (and gives its index).
pub fn stored_plan_problem(
    pixels: &[PixelState],
    plan: &[AdaptivePixel],
    w: u32,
    h: u32,
    spp: u32,
    rays_per_sample: u64,
) -> Option<(Option<usize>, String)> {
    let (w, h) = (w as usize, h as usize);
    let first = first_round_spp(spp);
    let planned = plan.iter().any(|a| a.target != 0);
    let at = |i: usize| format!("pixel ({}, {})", i % w, i / w);
    for (i, (p, a)) in pixels.iter().zip(plan).enumerate() {
        let most = (p.count.min(first) as u64).saturating_mul(rays_per_sample).min(u32::MAX as u64);
        if a.rays as u64 > most {
            return Some((
                Some(i),
                format!(
                    "{}: {} rays in a first round of {} samples, more than the {most} they can trace",
                    at(i),
                    a.rays,
                    p.count.min(first)
                ),
            ));
        }
        // Whole packets above the first round, or the mean itself (when nothing is shared out).
        let off_packets = a.target != spp && a.target >= first && !(a.target - first).is_multiple_of(LANES as u32);
        if planned && (a.target < first || a.target > max_spp(spp) || off_packets || p.count < first) {
            return Some((
                Some(i),
                format!(
                    "{}: a plan of {} samples (with {} taken) is not one this render makes: every pixel's plan is \
                     its first round of {first} and whole packets of {LANES} more, up to {}",
                    at(i),
                    a.target,
                    p.count,
                    max_spp(spp)
                ),
            ));
        }
        if !planned && p.count > first {
            let why = format!("{}: {} samples before the plan, more than the first round's {first}", at(i), p.count);
            return Some((Some(i), why));
        }
    }
    if planned {
        // What `allocate` spends, in cost, is within its budget (and half a packet a pixel of
        // rounding).
        let near_cost = near_costs(&vec![first; w * h], plan, w, h);
        let spent: f64 = plan.iter().zip(&near_cost).map(|(a, c)| (a.target - first) as f64 * c).sum();
        let budget: f64 = near_cost.iter().map(|c| c * (spp.saturating_sub(first) as f64 + LANES as f64 / 2.0)).sum();
        if spent > budget * (1.0 + 1e-9) {
            return Some((
                None,
                format!(
                    "its plan spends {spent:.0} units of cost where this render's budget is {budget:.0}: more \
                     samples than --spp {spp} gives"
                ),
            ));
        }
    }
    None
}

/// The samples each pixel of a `w`×`h` image should have at the end of the render, given the
/// first round's states `first` (every pixel at [`first_round_spp`]) and what the first round
/// recorded in `plan` (rays and sums of squares), so that the image takes
/// about `spp` samples per pixel in all. Each target is at least the pixel's first-round count,
/// at most [`max_spp`], and a multiple of [`LANES`] above the first round. Pixel `i`'s target
/// depends on its neighbours' states and on the image's total, never on its own state alone
/// (see the module's text).
pub fn allocate(first: &[PixelState], plan: &[AdaptivePixel], w: u32, h: u32, spp: u32) -> Vec<u32> {
    let (w, h) = (w as usize, h as usize);
    assert_eq!(first.len(), w * h);
    assert_eq!(plan.len(), w * h);
    let rv: Vec<f64> = first.iter().zip(plan).map(|(p, a)| relative_variance(p, a.sum_sq)).collect();
    let ring = |i: usize, of: &[f64]| ring_mean(i, of, w, h);
    let near_cost = near_costs(&first.iter().map(|p| p.count).collect::<Vec<_>>(), plan, w, h);
    // Samples ∝ √(variance / cost) minimise Σ variance / samples for a given Σ cost × samples.
    let weight: Vec<f64> = (0..w * h).map(|i| (ring(i, &rv) / near_cost[i]).sqrt()).collect();
    // The budget, in cost: what every pixel taking `spp` would cost, less the first round.
    let budget: f64 = first.iter().zip(&near_cost).map(|(p, c)| c * spp.saturating_sub(p.count) as f64).sum();
    let cap = max_spp(spp);
    let room: Vec<u64> = first.iter().map(|p| cap.saturating_sub(p.count) as u64).collect();
    // Extra samples for scale `s`: each pixel's weight × s, capped by its room.
    let extra = |s: f64, i: usize| -> u64 { ((weight[i] * s) as u64).min(room[i]) };
    let total = |s: f64| -> f64 { (0..w * h).map(|i| extra(s, i) as f64 * near_cost[i]).sum() };
    let sum_w: f64 = weight.iter().sum();
    let mut targets: Vec<u32> = first.iter().map(|p| p.count).collect();
    if budget <= 0.0 || sum_w <= 0.0 {
        // Nothing to share out, or no pixel's neighbours are noisy: every pixel takes the
        // mean, as a render without `--adaptive` would.
        for t in &mut targets {
            *t = (*t).max(spp);
        }
        return targets;
    }
    // The largest scale whose cost stays within the budget (bisection on a monotone sum;
    // deterministic).
    // The scale grows until the budget is spent or every pixel with a weight is at its cap
    // (the most the allocation can spend). Totals of small scales may repeat (weights so small
    // that no pixel gets a sample yet): only the cap ends the search early.
    let most: f64 = (0..w * h).filter(|&i| weight[i] > 0.0).map(|i| room[i] as f64 * near_cost[i]).sum();
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    while total(hi) < budget.min(most) && hi < 1e30 {
        hi *= 2.0;
    }
    for _ in 0..64 {
        let mid = 0.5 * (lo + hi);
        if total(mid) <= budget { lo = mid } else { hi = mid }
    }
    let lanes = LANES as u64;
    for (i, t) in targets.iter_mut().enumerate() {
        // Whole packets, rounded to nearest, within the room.
        let e = ((extra(lo, i) + lanes / 2) / lanes * lanes).min(room[i] / lanes * lanes);
        *t += e as u32;
    }
    targets
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// A pixel's first round of these samples, as the render loop records it (4 rays in all).
    fn colours(values: &[Vec3]) -> (PixelState, AdaptivePixel) {
        let mut p = PixelState::default();
        let mut a = AdaptivePixel { rays: 4, ..AdaptivePixel::default() };
        for &v in values {
            p.add(v);
            a.sum_sq += v.as_dvec3() * v.as_dvec3();
        }
        (p, a)
    }

    fn state(values: &[f32]) -> (PixelState, AdaptivePixel) {
        colours(&values.iter().map(|&v| Vec3::splat(v)).collect::<Vec<_>>())
    }

    /// A `w`×`h` image whose pixels have 16 first-round samples spread by `noise(x, y)`.
    fn image_of(w: usize, h: usize, noise: impl Fn(usize, usize) -> f32) -> (Vec<PixelState>, Vec<AdaptivePixel>) {
        (0..w * h)
            .map(|i| {
                let n = noise(i % w, i / w);
                state(&(0..16).map(|k| 0.5 + if k % 2 == 0 { n } else { -n }).collect::<Vec<_>>())
            })
            .unzip()
    }

    fn image(noise: impl Fn(usize, usize) -> f32) -> (Vec<PixelState>, Vec<AdaptivePixel>) {
        image_of(6, 5, noise)
    }

    #[test]
    fn relative_variance_is_the_expected_relmse_of_one_sample() {
        // Red 0.2 ± 0.1, green and blue exact: s² = 0.01 · 16/15 on red only.
        let (p, a) =
            colours(&(0..16).map(|k| Vec3::new(if k % 2 == 0 { 0.3 } else { 0.1 }, 0.5, 0.5)).collect::<Vec<_>>());
        let expected = 0.01 * 16.0 / 15.0 / (0.04 + REL_MSE_EPSILON) / 3.0;
        assert!((relative_variance(&p, a.sum_sq) - expected).abs() < 1e-5 * expected);
        // Noise a luminance estimate hardly sees: red and blue trade places; luminance (0.128
        // or 0.043) varies a seventh as much as the channels.
        let (p, a) = colours(
            &(0..16)
                .map(|k| if k % 2 == 0 { Vec3::new(0.6, 0.0, 0.0) } else { Vec3::new(0.0, 0.0, 0.6) })
                .collect::<Vec<_>>(),
        );
        let expected = 2.0 * 0.09 * 16.0 / 15.0 / (0.09 + REL_MSE_EPSILON) / 3.0;
        assert!((relative_variance(&p, a.sum_sq) - expected).abs() < 1e-5 * expected);
        // One sample has no variance to estimate.
        let (p, a) = state(&[0.5]);
        assert_eq!(relative_variance(&p, a.sum_sq), 0.0);
    }

    #[test]
    fn dim_pixels_weigh_as_relmse_weighs_them() {
        // The same absolute noise on a dim (0.05) and a bright (0.5) pixel: relMSE weighs the
        // dim one by (0.25 + ε) / (0.0025 + ε) = 20.8 times, not by (0.5 / 0.05)² = 100.
        let dim = state(&(0..16).map(|k| if k % 2 == 0 { 0.06 } else { 0.04 }).collect::<Vec<_>>());
        let bright = state(&(0..16).map(|k| if k % 2 == 0 { 0.51 } else { 0.49 }).collect::<Vec<_>>());
        let ratio = relative_variance(&dim.0, dim.1.sum_sq) / relative_variance(&bright.0, bright.1.sum_sq);
        // (The samples are f32: 0.06 and 0.04 to 1e-8 or so.)
        assert!((ratio - 0.26 / 0.0125).abs() < 1e-4, "{ratio}");
    }

    #[test]
    fn first_round_is_a_quarter_in_whole_packets() {
        assert_eq!(first_round_spp(64), 16);
        assert_eq!(first_round_spp(100), 32);
        assert_eq!(first_round_spp(16), 8);
        assert_eq!(first_round_spp(4), 4);
        assert_eq!(first_round_spp(1), 1);
    }

    #[test]
    fn a_pixels_own_samples_do_not_change_its_target() {
        // Large enough that most pixels are out of reach of the one made noisy below.
        let (w, h) = (14, 12);
        let base = image_of(w, h, |x, y| 0.01 * (x + y) as f32);
        let t0 = allocate(&base.0, &base.1, w as u32, h as u32, 64);
        // Pixel (6, 5) made far noisier: its own target stays, its neighbours' rise.
        let i = 5 * w + 6;
        let mut changed = base.clone();
        let noisy = state(&(0..16).map(|k| if k % 2 == 0 { 0.0 } else { 1.0 }).collect::<Vec<_>>());
        (changed.0[i], changed.1[i]) = noisy;
        let t1 = allocate(&changed.0, &changed.1, w as u32, h as u32, 64);
        assert!(t1[i + 1] > t0[i + 1] && t1[i - w] > t0[i - w], "{t0:?} {t1:?}");
        assert!(t1[i + REACH] > t0[i + REACH], "the neighbourhood reaches {REACH} pixels: {t0:?} {t1:?}");
        // The total stays within the budget, so the others give up samples: the pixel's
        // target may only fall, never follow its own noise up.
        assert!(t1[i] <= t0[i], "{} -> {}: {t0:?} {t1:?}", t0[i], t1[i]);
    }

    #[test]
    fn the_budget_is_kept_and_goes_where_the_noise_is() {
        // Noisy on the left (x < 3), exact on the right.
        let first = image(|x, _| if x < 3 { 0.3 } else { 0.0 });
        let t = allocate(&first.0, &first.1, 6, 5, 64);
        let total: u32 = t.iter().sum();
        // Every sample costs the same here: the budget is 64 samples a pixel, give or take
        // the rounding to whole packets.
        assert!(total.abs_diff(64 * 30) <= 4 * 30, "total {total}");
        for y in 0..5 {
            // Far from the noise (x = 5), only the first round; in it (x = 0), many more.
            assert_eq!(t[y * 6 + 5], 16);
            assert!(t[y * 6] > 64, "{t:?}");
        }
        assert!(t.iter().all(|&n| n >= 16 && n <= max_spp(64) && (n - 16) % 8 == 0), "{t:?}");
    }

    #[test]
    fn a_noiseless_image_takes_the_mean_everywhere() {
        let first = image(|_, _| 0.0);
        assert!(allocate(&first.0, &first.1, 6, 5, 64).iter().all(|&n| n == 64));
    }

    #[test]
    fn a_quiet_image_still_spends_its_budget() {
        // Weights so small that no pixel gets a sample at scales 1 or 2: the search for the
        // scale must go on (stopping there would leave every pixel at its first round).
        let first = image(|x, _| 0.001 * (1 + x) as f32);
        let t = allocate(&first.0, &first.1, 6, 5, 64);
        let total: u32 = t.iter().sum();
        assert!(total.abs_diff(64 * 30) <= 4 * 30, "total {total}: {t:?}");
        assert!(t[5] > t[0], "{t:?}");
    }

    #[test]
    fn later_samples_weigh_as_their_pixels_rays() {
        // Pixel 0 traced 3 rays a sample in its first round of 8, pixel 1 one: the mean is 2.
        let mut plan = vec![AdaptivePixel { rays: 24, ..AdaptivePixel::default() }; 2];
        plan[1].rays = 8;
        assert_eq!(sample_costs(&plan, 8, |_| true), vec![1.5, 0.5]);
        assert_eq!(work(20, 8, 1.5), 8.0 + 12.0 * 1.5);
        assert_eq!(work(5, 8, 1.5), 5.0);
        // The plan adds 16 samples to pixel 0 and none to pixel 1. The budget counts the rays
        // after the camera ray, plus 0.1: 2.1 and 0.1, mean 1.1.
        (plan[0].target, plan[1].target) = (24, 8);
        let c = added_sample_cost(&plan, 8, |_| true).unwrap();
        assert!((c - 2.1 / 1.1).abs() < 1e-12, "{c}");
        // Of pixel 1 alone (a shard), nothing was added.
        assert_eq!(added_sample_cost(&plan, 8, |i| i == 1), None);
    }

    #[test]
    fn no_pixel_exceeds_the_cap() {
        // One noisy corner: its neighbours would take everything without the cap.
        let first = image_of(20, 20, |x, y| if (x, y) == (0, 0) { 0.4 } else { 0.0 });
        let t = allocate(&first.0, &first.1, 20, 20, 64);
        assert_eq!(t[1], max_spp(64));
        assert_eq!(t[20], max_spp(64));
        assert_eq!(t[0], 16, "the noisy pixel's own neighbours are exact");
    }
}

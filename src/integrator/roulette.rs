//! Where Russian roulette starts when the user leaves it to the scene (`--rr-depth auto`).
//!
//! After each bounce from the start depth on, roulette ends a path with probability 1 − p,
//! p = min(max β, 0.95) with β the path's throughput, and scales the survivors by 1/p: the
//! image stays unbiased, and the work of paths that could add little is saved. Each path it
//! ends is light a surviving path must carry at 1/p its weight, so it adds noise wherever
//! that light is a visible part of the image; it pays only once the rest of a path costs
//! much and carries little.
//!
//! A path's throughput after k bounces is about a^k at best, a the largest albedo of the
//! materials the scene uses ([`crate::scene::Effects::albedo`], each material's at normal
//! incidence). The automatic start is the first depth k ≥ 1 at which a^k ≤
//! [`RR_THROUGHPUT`] = 1/10: a path bouncing only off the brightest material has kept at
//! most a tenth of its light. So a dark scene (a = 0.3) starts at depth 2, a = 0.5 at 4,
//! a = 0.7 at 7, a typical one (a = 0.75) at 9, a bright one later (0.95: 45), and one with
//! a white surface or clear glass (a = 1) never. docs/rendering.md gives the measurements
//! behind 1/10.
//!
//! The start must come before the path depth the scene uses; if it does not, roulette could
//! at most spare a path's last ray, and it is off. That depth is the scene's own
//! ([`crate::scene::DepthLimit::apply`] of the user's bound), whichever kernel runs, so the
//! specialised and the general kernel (`--no-specialize`) use the same start and give the
//! same image: the start is a setting of the estimator, not a kernel switch.

use crate::scene::Effects;

/// The best-case throughput at which the automatic Russian roulette starts (see the module
/// documentation).
pub const RR_THROUGHPUT: f32 = 0.1;

/// The first depth k ≥ 1 at which `albedo`^k ≤ [`RR_THROUGHPUT`]; `None` if there is none
/// (albedo ≥ 1).
pub fn throughput_depth(albedo: f32) -> Option<u32> {
    if albedo.is_nan() || albedo >= 1.0 {
        return None;
    }
    if albedo <= RR_THROUGHPUT {
        return Some(1);
    }
    // albedo in (1/10, 1): k = ⌈ln(1/10) / ln albedo⌉ ≥ 2.
    let k = ((RR_THROUGHPUT as f64).ln() / (albedo as f64).ln()).ceil();
    Some(if k >= u32::MAX as f64 { u32::MAX } else { k as u32 })
}

/// The automatic start for a scene with `effects` rendered with at most `max_depth` bounces:
/// where the best-case throughput falls to ½ ([`throughput_depth`] of [`Effects::albedo`]),
/// or `None` (off) if that is never, or not before the path depth the scene uses.
pub fn auto_start(effects: &Effects, max_depth: u32) -> Option<u32> {
    let depth = effects.depth_limit().apply(max_depth);
    throughput_depth(effects.albedo).filter(|&k| k < depth)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scattering(albedo: f32) -> Effects {
        Effects { scattering: true, indirect: true, albedo, ..Effects::default() }
    }

    #[test]
    fn the_start_is_where_the_best_throughput_falls_to_a_tenth() {
        assert_eq!(throughput_depth(0.0), Some(1));
        assert_eq!(throughput_depth(0.1), Some(1));
        assert_eq!(throughput_depth(0.3), Some(2)); // 0.09
        assert_eq!(throughput_depth(0.5), Some(4)); // 0.125, 0.0625
        assert_eq!(throughput_depth(0.7), Some(7)); // 0.118, 0.082
        assert_eq!(throughput_depth(0.75), Some(9)); // 0.1001, 0.075
        assert_eq!(throughput_depth(0.8), Some(11)); // 0.107, 0.086
        assert_eq!(throughput_depth(0.95), Some(45)); // 0.105, 0.099
        assert_eq!(throughput_depth(1.0), None);
        assert_eq!(throughput_depth(1.2), None);
        assert_eq!(throughput_depth(f32::NAN), None);
        // Right below 1 it is far, but finite.
        assert!(throughput_depth(1.0 - f32::EPSILON).unwrap() > 1_000_000);
    }

    #[test]
    fn dark_scenes_start_early_and_bright_ones_late_or_never() {
        assert_eq!(auto_start(&scattering(0.05), 8), Some(1));
        assert_eq!(auto_start(&scattering(0.5), 8), Some(4));
        assert_eq!(auto_start(&scattering(0.7), 8), Some(7));
        // A start at or past the path depth is off: a = 0.75 would start at 9.
        assert_eq!(auto_start(&scattering(0.75), 8), None);
        assert_eq!(auto_start(&scattering(0.75), 9), None);
        assert_eq!(auto_start(&scattering(0.75), 10), Some(9));
        assert_eq!(auto_start(&scattering(0.95), 32), None);
        assert_eq!(auto_start(&scattering(0.95), 64), Some(45));
        // Albedo 1 (a white box, clear glass): never.
        assert_eq!(auto_start(&scattering(1.0), u32::MAX), None);
    }

    #[test]
    fn the_path_depth_counted_is_the_scenes_whatever_the_kernel() {
        // Direct light only: the path depth is 1, so even a dark scene has no roulette.
        let direct = Effects { indirect: false, ..scattering(0.2) };
        assert_eq!(auto_start(&direct, 8), None);
        assert_eq!(auto_start(&Effects::default(), 8), None);
    }
}

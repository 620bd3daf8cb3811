//! Where Russian roulette starts, chosen from the scene unless the user says.
//!
//! After each bounce from the start depth on, roulette ends a path with probability 1 − p,
//! p = min(max β, 0.95) with β the path's throughput, and scales the survivors by 1/p: the
//! image stays unbiased, and the work of paths that could add little is saved. While β is
//! near 1 it ends few paths (5 % at β = 1) but still adds noise; it pays once β is small.
//!
//! A path's throughput after k bounces is about a^k at best, a the largest albedo of the
//! materials the scene uses ([`material_albedo`], at normal incidence). The automatic start
//! is the first depth k ≥ 1 at which a^k ≤ [`RR_THROUGHPUT`] = ½: from there on every
//! roulette ends at least half of the paths that reach it. So a dark scene (a ≤ ½) starts at
//! depth 1, a typical one (a ≈ 0.75) at 3 (the former fixed default), a bright one later
//! (a = 0.8: 4; 0.95: 14), and one with a white surface or clear glass (a = 1) never.
//!
//! The start must come before the path depth the scene uses; if it does not, roulette could
//! at most spare a path's last ray, and it is off. That depth is the scene's own
//! ([`super::DepthLimit::apply`] of the user's bound), whichever kernel runs, so the
//! specialised and the general kernel (`--no-specialize`) use the same start and give the
//! same image: the start is a setting of the estimator, not a kernel switch.

use super::{Effects, MaterialKind};
use std::fmt;
use std::str::FromStr;

/// The best-case throughput at which the automatic Russian roulette starts (see the module
/// documentation).
pub const RR_THROUGHPUT: f32 = 0.5;

/// Reflectance at normal incidence of a dielectric coating of IOR 1.5 (plastic).
const COATING_F0: f32 = 0.04;

/// When Russian roulette starts, as asked for (`--rr-depth`, `[render] rr_depth`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum RrDepth {
    /// Chosen from the scene: [`Effects::rr_start`].
    #[default]
    Auto,
    /// After this many bounces.
    After(u32),
    /// Never.
    Off,
}

impl RrDepth {
    /// The depth from which roulette runs in a render of a scene with `effects` at bounce
    /// limit `max_depth` (`None`: never). It does not depend on the kernel.
    pub fn resolve(self, effects: &Effects, max_depth: u32) -> Option<u32> {
        match self {
            RrDepth::Auto => effects.rr_start(max_depth),
            RrDepth::After(n) => Some(n),
            RrDepth::Off => None,
        }
    }
}

impl FromStr for RrDepth {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "auto" => Ok(RrDepth::Auto),
            "off" => Ok(RrDepth::Off),
            _ => s
                .parse()
                .map(RrDepth::After)
                .map_err(|_| format!("expected a number, \"off\" or \"auto\", found {s:?}")),
        }
    }
}

/// `auto`, `off` or the number, as on the command line.
impl fmt::Display for RrDepth {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RrDepth::Auto => f.write_str("auto"),
            RrDepth::After(n) => write!(f, "{n}"),
            RrDepth::Off => f.write_str("off"),
        }
    }
}

/// The largest fraction of light a material sends on in one bounce, for the best colour
/// channel and where its colour is brightest (a texture's largest texel), at normal incidence
/// (a guide rather than a bound: towards grazing angles metals and coatings reflect more):
///
/// - diffuse: its colour;
/// - metal: its colour (the reflectance at normal incidence; only towards grazing angles does
///   it rise to 1);
/// - plastic: the coating's 4 % plus the base colour times the 96 % that passes the coating;
/// - glass: the reflected fraction F0 = ((η − 1)/(η + 1))² plus the tint times the rest;
/// - purely emissive: 0.
pub(super) fn material_albedo(kind: &MaterialKind) -> f32 {
    let coated = |f0: f32, c: f32| f0 + (1.0 - f0) * c;
    match kind {
        MaterialKind::Diffuse { color } | MaterialKind::Metal { color, .. } => color.max().max_element(),
        MaterialKind::Plastic { color, .. } => coated(COATING_F0, color.max().max_element()),
        MaterialKind::Glass { ior, tint } => coated(((ior - 1.0) / (ior + 1.0)).powi(2), tint.max_element()),
        MaterialKind::Emissive => 0.0,
    }
}

/// The first depth k ≥ 1 at which `albedo`^k ≤ [`RR_THROUGHPUT`]; `None` if there is none
/// (albedo ≥ 1).
pub fn throughput_depth(albedo: f32) -> Option<u32> {
    if albedo.is_nan() || albedo >= 1.0 {
        return None;
    }
    if albedo <= RR_THROUGHPUT {
        return Some(1);
    }
    // albedo in (½, 1): k = ⌈ln ½ / ln albedo⌉ ≥ 2.
    let k = ((RR_THROUGHPUT as f64).ln() / (albedo as f64).ln()).ceil();
    Some(if k >= u32::MAX as f64 { u32::MAX } else { k as u32 })
}

impl Effects {
    /// The automatic Russian-roulette start for a render at bounce limit `max_depth`: the
    /// depth at which the best-case throughput falls to ½ ([`throughput_depth`] of
    /// [`Effects::albedo`]), or `None` (off) if that is never, or not before the path depth
    /// the scene uses.
    pub fn rr_start(&self, max_depth: u32) -> Option<u32> {
        let depth = self.depth_limit().apply(max_depth);
        throughput_depth(self.albedo).filter(|&k| k < depth)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::texture::Texture;
    use glam::Vec3;

    fn scattering(albedo: f32) -> Effects {
        Effects { scattering: true, indirect: true, albedo, ..Effects::default() }
    }

    #[test]
    fn the_start_is_where_the_best_throughput_halves() {
        assert_eq!(throughput_depth(0.0), Some(1));
        assert_eq!(throughput_depth(0.3), Some(1));
        assert_eq!(throughput_depth(0.5), Some(1));
        assert_eq!(throughput_depth(0.7), Some(2)); // 0.49
        assert_eq!(throughput_depth(0.75), Some(3)); // 0.5625, 0.42
        assert_eq!(throughput_depth(0.8), Some(4)); // 0.512, 0.41
        assert_eq!(throughput_depth(0.85), Some(5)); // 0.522, 0.44
        assert_eq!(throughput_depth(0.95), Some(14)); // 0.513, 0.488
        assert_eq!(throughput_depth(1.0), None);
        assert_eq!(throughput_depth(1.2), None);
        assert_eq!(throughput_depth(f32::NAN), None);
        // Right below 1 it is far, but finite.
        assert!(throughput_depth(1.0 - f32::EPSILON).unwrap() > 1_000_000);
    }

    #[test]
    fn dark_scenes_start_early_and_bright_ones_late_or_never() {
        assert_eq!(scattering(0.2).rr_start(8), Some(1));
        assert_eq!(scattering(0.75).rr_start(8), Some(3));
        assert_eq!(scattering(0.85).rr_start(8), Some(5));
        // A start at or past the path depth is off.
        assert_eq!(scattering(0.85).rr_start(5), None);
        assert_eq!(scattering(0.85).rr_start(6), Some(5));
        assert_eq!(scattering(0.95).rr_start(10), None);
        assert_eq!(scattering(0.95).rr_start(64), Some(14));
        // Albedo 1 (a white box, clear glass): never.
        assert_eq!(scattering(1.0).rr_start(u32::MAX), None);
    }

    #[test]
    fn the_path_depth_counted_is_the_scenes_whatever_the_kernel() {
        // Direct light only: the path depth is 1, so even a dark scene has no roulette.
        let direct = Effects { indirect: false, ..scattering(0.2) };
        assert_eq!(direct.rr_start(8), None);
        let nothing = Effects::default();
        assert_eq!(nothing.rr_start(8), None);
    }

    #[test]
    fn the_users_choice_wins() {
        let dark = scattering(0.2);
        assert_eq!(RrDepth::Auto.resolve(&dark, 8), Some(1));
        assert_eq!(RrDepth::After(3).resolve(&dark, 8), Some(3));
        assert_eq!(RrDepth::Off.resolve(&dark, 8), None);
        let white = scattering(1.0);
        assert_eq!(RrDepth::Auto.resolve(&white, 8), None);
        assert_eq!(RrDepth::After(2).resolve(&white, 8), Some(2));
    }

    #[test]
    fn rr_depth_parses_and_prints_as_on_the_command_line() {
        for (s, v) in
            [("auto", RrDepth::Auto), ("off", RrDepth::Off), ("0", RrDepth::After(0)), ("7", RrDepth::After(7))]
        {
            assert_eq!(s.parse::<RrDepth>(), Ok(v));
            assert_eq!(v.to_string(), s);
        }
        assert_eq!("banana".parse::<RrDepth>(), Err("expected a number, \"off\" or \"auto\", found \"banana\"".into()));
        assert!("-1".parse::<RrDepth>().is_err());
    }

    #[test]
    fn material_albedos() {
        let c = |v: f32| Texture::Constant(Vec3::new(0.1, v, 0.2));
        assert_eq!(material_albedo(&MaterialKind::Diffuse { color: c(0.6) }), 0.6);
        assert_eq!(material_albedo(&MaterialKind::Metal { color: c(0.9), roughness: 0.0 }), 0.9);
        let checker = Texture::Checker { a: Vec3::splat(0.2), b: Vec3::new(0.1, 0.7, 0.3), scale: 4.0 };
        assert_eq!(material_albedo(&MaterialKind::Diffuse { color: checker }), 0.7);
        assert!((material_albedo(&MaterialKind::Plastic { color: c(0.5), roughness: 0.3 }) - 0.52).abs() < 1e-6);
        assert_eq!(material_albedo(&MaterialKind::Glass { ior: 1.5, tint: Vec3::ONE }), 1.0);
        assert!((material_albedo(&MaterialKind::Glass { ior: 1.5, tint: Vec3::splat(0.5) }) - 0.52).abs() < 1e-6);
        assert_eq!(material_albedo(&MaterialKind::Emissive), 0.0);
    }
}

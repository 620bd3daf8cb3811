//! The estimator variants a study compares, and the syntax that names them
//! (`ESTIMATOR[/no-rr][/depth=D][/sobol|/independent][/env-uniform][/adaptive][/light-vertices=on|off]`
//! `[/light-tree=off][/clamp=X][/denoise[=MODE]]` and the groups `estimators`, `no-rr`, `depth`, `samplers`,
//! `adaptive`, `light-vertices`, `light-tree`, `denoise`, `all`).

use crate::film::AuxMode;
use crate::integrator::Estimator;
use crate::sampler::SamplerKind;
use crate::settings::{LightTreeMode, LightVertices};

/// The depths of the `depth` variant group: each compared to the full-depth reference, so
/// their curves flatten at the bias of cutting paths short.
pub const DEPTH_GROUP: std::ops::RangeInclusive<u32> = 1..=10;

/// One way of estimating the image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Variant {
    pub estimator: Estimator,
    /// Russian roulette on (after the study's `rr_depth` bounces) or off.
    pub russian_roulette: bool,
    /// Bounce limit; `None`: the study's full depth (that of the reference).
    pub max_depth: Option<u32>,
    /// Next-event estimation samples an environment image uniformly over the sphere instead
    /// of by luminance (no effect on other backgrounds): what importance sampling gains.
    pub uniform_environment: bool,
    /// Adaptive sampling (`ember render`'s default): the spp of a rung is the mean, spent
    /// where the image is noisy; off: every pixel takes the rung's spp (`--uniform`).
    pub adaptive: bool,
    /// Where samples get their numbers; `None`: the default sampler.
    pub sampler: Option<SamplerKind>,
    /// Light vertices on or off; `None`: as the scene analysis decides (`auto`).
    pub light_vertices: Option<LightVertices>,
    /// `--light-tree`; `None`: the default (`auto`).
    pub light_tree: Option<LightTreeMode>,
    /// `--clamp X`: samples scaled down to a largest channel of X (biased); `None`: no clamp.
    pub clamp: Option<Clamp>,
    /// Denoised with Open Image Denoise, given the auxiliary images as this says; `None`: the
    /// render's own (noisy) estimate.
    pub denoise: Option<AuxMode>,
}

/// A sample clamp's limit (a positive, finite radiance), comparable for equality.
#[derive(Clone, Copy, Debug)]
pub struct Clamp(pub f32);

impl PartialEq for Clamp {
    fn eq(&self, other: &Clamp) -> bool {
        self.0.to_bits() == other.0.to_bits()
    }
}

impl Eq for Clamp {}

impl Variant {
    pub const fn new(estimator: Estimator) -> Variant {
        Variant {
            estimator,
            russian_roulette: true,
            max_depth: None,
            sampler: None,
            light_vertices: None,
            light_tree: None,
            uniform_environment: false,
            adaptive: false,
            clamp: None,
            denoise: None,
        }
    }

    /// `ESTIMATOR[/no-rr][/depth=D][/SAMPLER][/env-uniform][/denoise=MODE]`, e.g. `nee-mis`,
    /// `bsdf/no-rr`, `nee-mis/depth=3`, `nee-mis/sobol`, `nee-mis/env-uniform`,
    /// `nee-mis/denoise=prefilter`; the same syntax is accepted by [`parse_variants`] (where
    /// `/denoise` alone is the default mode).
    pub fn name(&self) -> String {
        let mut s = self.estimator.name().to_string();
        if !self.russian_roulette {
            s.push_str("/no-rr");
        }
        if let Some(d) = self.max_depth {
            s.push_str(&format!("/depth={d}"));
        }
        if let Some(k) = self.sampler {
            s.push_str(&format!("/{k}"));
        }
        if self.uniform_environment {
            s.push_str("/env-uniform");
        }
        if self.adaptive {
            s.push_str("/adaptive");
        }
        if let Some(lv) = self.light_vertices {
            s.push_str(&format!("/light-vertices={lv}"));
        }
        if let Some(t) = self.light_tree {
            s.push_str(&format!("/light-tree={t}"));
        }
        if let Some(Clamp(c)) = self.clamp {
            s.push_str(&format!("/clamp={c}"));
        }
        if let Some(m) = self.denoise {
            s.push_str(&format!("/denoise={m}"));
        }
        s
    }

    /// Why its images do not converge to the reference, if they do not: a depth limit cuts
    /// light off, a clamp scales bright samples down, a denoiser smooths (its error stops
    /// falling as 1/spp and keeps a bias).
    pub fn bias(&self) -> Option<String> {
        let why: Vec<String> = [
            self.max_depth.map(|_| "depth limit".to_string()),
            self.clamp.map(|Clamp(c)| format!("clamped at {c}")),
            self.denoise.map(|_| "denoised".to_string()),
        ]
        .into_iter()
        .flatten()
        .collect();
        (!why.is_empty()).then(|| format!("biased: {}", why.join(", ")))
    }
}

impl std::str::FromStr for Variant {
    type Err = String;
    fn from_str(s: &str) -> Result<Variant, String> {
        let mut parts = s.split('/');
        let estimator: Estimator = parts.next().unwrap_or_default().parse()?;
        let mut v = Variant::new(estimator);
        for part in parts {
            if part == "no-rr" {
                v.russian_roulette = false;
            } else if part == "env-uniform" {
                v.uniform_environment = true;
            } else if part == "adaptive" {
                v.adaptive = true;
            } else if let Some(lv) = part.strip_prefix("light-vertices=") {
                v.light_vertices = Some(lv.parse().map_err(|e| format!("variant {s:?}: light-vertices: {e}"))?);
            } else if let Some(t) = part.strip_prefix("light-tree=") {
                v.light_tree = Some(t.parse().map_err(|e| format!("variant {s:?}: light-tree: {e}"))?);
            } else if let Some(c) = part.strip_prefix("clamp=") {
                match c.parse::<f32>() {
                    Ok(c) if c > 0.0 && c.is_finite() => v.clamp = Some(Clamp(c)),
                    _ => return Err(format!("variant {s:?}: clamp {c:?} is not a positive number")),
                }
            } else if let Some(d) = part.strip_prefix("depth=") {
                v.max_depth = Some(d.parse().map_err(|_| format!("variant {s:?}: depth {d:?} is not a whole number"))?);
            } else if let Ok(k) = part.parse::<SamplerKind>() {
                v.sampler = Some(k);
            } else if part == "denoise" {
                v.denoise = Some(AuxMode::DEFAULT);
            } else if let Some(m) = part.strip_prefix("denoise=") {
                v.denoise = Some(m.parse().map_err(|e| format!("variant {s:?}: {e}"))?);
            } else {
                return Err(format!(
                    "variant {s:?}: unknown option {part:?} (expected no-rr, depth=D, sobol, independent, env-uniform, adaptive, light-vertices=on|off, light-tree=auto|off, clamp=X, denoise or denoise=MODE)"
                ));
            }
        }
        Ok(v)
    }
}

/// Parses a comma-separated list of variants and groups:
/// - `estimators`: the four estimators at full depth with Russian roulette;
/// - `no-rr`: the four estimators at full depth without Russian roulette;
/// - `depth`: NEE+MIS with Russian roulette at each depth of [`DEPTH_GROUP`] below `full_depth`;
/// - `samplers`: NEE+MIS with each sampler;
/// - `adaptive`: NEE+MIS with every pixel at the rung's spp, and `/adaptive` (the same cost,
///   spent where the image is noisy);
/// - `light-vertices`: NEE+MIS as the scene analysis decides, with light vertices on, and off;
/// - `light-tree`: NEE+MIS with many lights chosen through a light tree (the default), and by
///   power (`/light-tree=off`);
/// - `denoise`: NEE+MIS, and NEE+MIS denoised in each [`AuxMode`] (colour only; albedo and
///   normal noisy, prefiltered, clean);
/// - `all`: `estimators`, `no-rr`, `depth` and `denoise`;
/// - or one variant,
///   `ESTIMATOR[/no-rr][/depth=D][/SAMPLER][/env-uniform][/adaptive][/clamp=X][/denoise[=MODE]]`
///   (see [`Variant::name`]).
///
/// Duplicates are dropped; the order is kept.
pub fn parse_variants(list: &str, full_depth: u32) -> Result<Vec<Variant>, String> {
    let mut out: Vec<Variant> = Vec::new();
    for item in list.split(',').map(str::trim) {
        let group: Vec<Variant> = match item {
            "estimators" => Estimator::ALL.into_iter().map(Variant::new).collect(),
            "no-rr" => {
                Estimator::ALL.into_iter().map(|e| Variant { russian_roulette: false, ..Variant::new(e) }).collect()
            }
            "depth" => DEPTH_GROUP
                .filter(|&d| d < full_depth)
                .map(|d| Variant { max_depth: Some(d), ..Variant::new(Estimator::NeeMis) })
                .collect(),
            "samplers" => SamplerKind::ALL
                .into_iter()
                .map(|k| Variant { sampler: Some(k), ..Variant::new(Estimator::NeeMis) })
                .collect(),
            "adaptive" => [false, true]
                .into_iter()
                .map(|adaptive| Variant { adaptive, ..Variant::new(Estimator::NeeMis) })
                .collect(),
            "light-vertices" => [None, Some(LightVertices::On), Some(LightVertices::Off)]
                .into_iter()
                .map(|light_vertices| Variant { light_vertices, ..Variant::new(Estimator::NeeMis) })
                .collect(),
            "light-tree" => [None, Some(LightTreeMode::Off)]
                .into_iter()
                .map(|light_tree| Variant { light_tree, ..Variant::new(Estimator::NeeMis) })
                .collect(),
            "denoise" => std::iter::once(None)
                .chain(AuxMode::ALL.into_iter().map(Some))
                .map(|denoise| Variant { denoise, ..Variant::new(Estimator::NeeMis) })
                .collect(),
            "all" => parse_variants("estimators,no-rr,depth,denoise", full_depth)?,
            "" => return Err("empty variant in the list".into()),
            spec => vec![spec.parse()?],
        };
        for v in group {
            if !out.contains(&v) {
                out.push(v);
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn variant_names_round_trip() {
        for v in parse_variants("all", 64).unwrap() {
            assert_eq!(v.name().parse::<Variant>().unwrap(), v);
        }
        let v: Variant = "bsdf-uniform/no-rr/depth=3".parse().unwrap();
        assert_eq!(
            v,
            Variant {
                estimator: Estimator::BsdfUniform,
                russian_roulette: false,
                max_depth: Some(3),
                sampler: None,
                light_vertices: None,
                light_tree: None,
                uniform_environment: false,
                adaptive: false,
                clamp: None,
                denoise: None
            }
        );
        let v: Variant = "nee-mis/light-vertices=off".parse().unwrap();
        assert_eq!(v.light_vertices, Some(LightVertices::Off));
        assert_eq!(v.name(), "nee-mis/light-vertices=off");
        let v: Variant = "nee-mis/light-tree=off".parse().unwrap();
        assert_eq!((v.light_tree, v.name().as_str()), (Some(LightTreeMode::Off), "nee-mis/light-tree=off"));
        assert!("nee-mis/light-tree=on".parse::<Variant>().is_err());
        assert_eq!(parse_variants("light-tree", 64).unwrap().len(), 2);
        assert_eq!(parse_variants("light-vertices", 64).unwrap().len(), 3);
        assert!("nee-mis/light-vertices=maybe".parse::<Variant>().unwrap_err().contains("light-vertices"));
        let v: Variant = "nee-mis/adaptive".parse().unwrap();
        assert!(v.adaptive);
        assert_eq!(v.name(), "nee-mis/adaptive");
        assert_eq!(parse_variants("adaptive", 64).unwrap(), vec![Variant::new(Estimator::NeeMis), v]);
        let v: Variant = "nee-mis/sobol".parse().unwrap();
        assert_eq!(v.sampler, Some(SamplerKind::Sobol));
        assert_eq!(v.name(), "nee-mis/sobol");
        assert_eq!(parse_variants("samplers", 64).unwrap().len(), 2);
        let v: Variant = "nee-mis/denoise".parse().unwrap();
        assert_eq!(v.name(), "nee-mis/denoise=prefilter");
        assert_eq!(v.bias().as_deref(), Some("biased: denoised"));
        let v: Variant = "nee/depth=3/clamp=10/denoise".parse().unwrap();
        assert_eq!(v.clamp, Some(Clamp(10.0)));
        assert_eq!(v.name(), "nee/depth=3/clamp=10/denoise=prefilter");
        assert_eq!(v.bias().as_deref(), Some("biased: depth limit, clamped at 10, denoised"));
        assert_eq!(v.name().parse::<Variant>().unwrap(), v);
        assert!("nee/clamp=-1".parse::<Variant>().unwrap_err().contains("not a positive number"));
        assert_eq!("nee-mis/denoise=color".parse::<Variant>().unwrap().denoise, Some(AuxMode::ColorOnly));
        assert!("nee-mis/denoise=fast".parse::<Variant>().unwrap_err().contains("unknown auxiliary mode"));
        let v: Variant = "nee-mis/independent/denoise=clean".parse().unwrap();
        assert_eq!(v.name().parse::<Variant>().unwrap(), v);
        let v: Variant = "nee-mis/env-uniform".parse().unwrap();
        assert_eq!(v, Variant { uniform_environment: true, ..Variant::new(Estimator::NeeMis) });
        assert_eq!(v.name(), "nee-mis/env-uniform");
        let v: Variant = "nee-mis/independent/env-uniform".parse().unwrap();
        assert_eq!(v.name().parse::<Variant>().unwrap(), v);
    }

    #[test]
    fn groups_expand_and_duplicates_are_dropped() {
        let all = parse_variants("all", 64).unwrap();
        assert_eq!(all.len(), 4 + 4 + 10 + 4);
        assert_eq!(parse_variants("denoise", 64).unwrap().len(), 5);
        assert_eq!(parse_variants("nee-mis,estimators,nee-mis", 64).unwrap().len(), 4);
        // Depths at or beyond the full depth are not in the group.
        assert_eq!(parse_variants("depth", 4).unwrap().len(), 3);
        assert!(parse_variants("nee-mis/fast", 64).unwrap_err().contains("unknown option \"fast\""));
        assert!(parse_variants("mis", 64).unwrap_err().contains("unknown estimator"));
        assert!(parse_variants("nee,,bsdf", 64).is_err());
    }
}

//! Convergence studies: what accuracy costs in time. Renders a scene at 1, 2, 4, … N samples
//! per pixel with several estimator variants, measures each image against a high-spp
//! reference ([`super::metrics`]), and reports the error against spp and against seconds
//! (CSV, log-log plots) and the time each variant needs to reach a target relMSE.
//!
//! Seeds: the reference is rendered with the study's seed itself; the render at rung k,
//! repeat j uses an unrelated seed derived from it ([`Study::render_seed`]), so no render
//! shares random numbers with the reference (a render whose samples were a prefix of the
//! reference's would look more accurate than it is). All variants use the same seed at the
//! same rung (common random numbers), which makes their curves easier to compare.

use super::metrics::{ImageError, SizeMismatch, image_error};
use super::plot::{LineStyle, PlotError, PlotOptions, Series, log_log_plot_with};
use crate::accel::Accel;
use crate::film::Film;
use crate::integrator::{Estimator, RenderError, RenderSettings, RenderStats, RrDepth, render};
use crate::sampler::mix64;
use crate::scene::Scene;
use std::path::{Path, PathBuf};

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
}

impl Variant {
    pub const fn new(estimator: Estimator) -> Variant {
        Variant { estimator, russian_roulette: true, max_depth: None }
    }

    /// `ESTIMATOR[/no-rr][/depth=D]`, e.g. `nee-mis`, `bsdf/no-rr`, `nee-mis/depth=3`; the
    /// same syntax is accepted by [`parse_variants`].
    pub fn name(&self) -> String {
        let mut s = self.estimator.name().to_string();
        if !self.russian_roulette {
            s.push_str("/no-rr");
        }
        if let Some(d) = self.max_depth {
            s.push_str(&format!("/depth={d}"));
        }
        s
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
            } else if let Some(d) = part.strip_prefix("depth=") {
                v.max_depth = Some(d.parse().map_err(|_| format!("variant {s:?}: depth {d:?} is not a whole number"))?);
            } else {
                return Err(format!("variant {s:?}: unknown option {part:?} (expected no-rr or depth=D)"));
            }
        }
        Ok(v)
    }
}

/// Parses a comma-separated list of variants and groups:
/// - `estimators`: the four estimators at full depth with Russian roulette;
/// - `no-rr`: the four estimators at full depth without Russian roulette;
/// - `depth`: NEE+MIS with Russian roulette at each depth of [`DEPTH_GROUP`] below `full_depth`;
/// - `all`: the three groups;
/// - or one variant, `ESTIMATOR[/no-rr][/depth=D]` (see [`Variant::name`]).
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
            "all" => parse_variants("estimators,no-rr,depth", full_depth)?,
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

/// 1, 2, 4, … up to `max_spp` (and `max_spp` itself when it is not a power of two).
pub fn spp_ladder(max_spp: u32) -> Vec<u32> {
    let mut ladder: Vec<u32> = (0..32).map(|k| 1u32 << k).take_while(|&s| s <= max_spp).collect();
    if ladder.last() != Some(&max_spp) && max_spp > 0 {
        ladder.push(max_spp);
    }
    ladder
}

/// What a study renders and how.
#[derive(Clone, Debug, PartialEq)]
pub struct Study {
    pub width: u32,
    pub height: u32,
    /// The full depth: that of the reference and of every variant without its own depth.
    pub max_depth: u32,
    /// Where Russian roulette starts when a variant has it on (and for the reference).
    pub rr_depth: u32,
    pub seed: u64,
    pub threads: Option<usize>,
    /// The spp of the measured renders, increasing.
    pub ladder: Vec<u32>,
    /// Renders per rung with different seeds; their errors and times are averaged.
    pub repeats: u32,
}

/// One measured point: a variant at one spp, averaged over the study's repeats.
#[derive(Clone, Debug, PartialEq)]
pub struct Measurement {
    pub variant: Variant,
    pub spp: u32,
    /// Mean render time ([`RenderStats::elapsed`]: the render only, not the BVH build).
    pub seconds: f64,
    /// Mean rays traced per render.
    pub rays: f64,
    /// Mean error against the reference.
    pub error: ImageError,
    /// Non-finite samples the renders dropped, in total.
    pub nonfinite: u64,
}

/// Why a study could not run.
#[derive(Debug, thiserror::Error)]
pub enum ConvergeError {
    #[error("{}: reference is {}x{} pixels but the study renders {}x{}", path.display(), found.0, found.1, expected.0, expected.1)]
    ReferenceSize { path: PathBuf, found: (u32, u32), expected: (u32, u32) },
    #[error("{}: reference pixel ({x}, {y}) is not finite", path.display())]
    ReferenceNotFinite { path: PathBuf, x: u32, y: u32 },
    #[error(transparent)]
    Render(#[from] RenderError),
    #[error(transparent)]
    Size(#[from] SizeMismatch),
}

impl Study {
    /// The render settings of `variant` at `spp` with `seed`.
    pub fn settings(&self, variant: &Variant, spp: u32, seed: u64) -> RenderSettings {
        RenderSettings {
            width: self.width,
            height: self.height,
            spp,
            max_depth: variant.max_depth.unwrap_or(self.max_depth),
            rr_depth: if variant.russian_roulette { RrDepth::After(self.rr_depth) } else { RrDepth::Off },
            seed,
            threads: self.threads,
            estimator: variant.estimator,
            ..RenderSettings::default()
        }
    }

    /// The reference's settings: NEE+MIS at full depth with Russian roulette, the study's seed.
    pub fn reference_settings(&self, spp: u32) -> RenderSettings {
        self.settings(&Variant::new(Estimator::NeeMis), spp, self.seed)
    }

    /// The seed of the render at rung `rung` (index into the ladder), repeat `repeat`.
    pub fn render_seed(&self, rung: usize, repeat: u32) -> u64 {
        // "converge" in ASCII: the derived seeds are unrelated to small seeds given by hand.
        mix64(self.seed ^ 0x636f_6e76_6572_6765).wrapping_add(rung as u64 * self.repeats as u64 + repeat as u64)
    }

    /// Renders the reference at `spp`.
    pub fn render_reference(
        &self,
        scene: &Scene,
        accel: &dyn Accel,
        spp: u32,
    ) -> Result<(Film, RenderStats), RenderError> {
        render(scene, accel, &self.reference_settings(spp))
    }

    /// Refuses a reference (read from `path`) that does not fit the study: another size, or a
    /// non-finite pixel.
    pub fn check_reference(&self, path: &Path, reference: &Film) -> Result<(), ConvergeError> {
        if (reference.width, reference.height) != (self.width, self.height) {
            return Err(ConvergeError::ReferenceSize {
                path: path.to_path_buf(),
                found: (reference.width, reference.height),
                expected: (self.width, self.height),
            });
        }
        if let Some(i) = reference.pixels.iter().position(|p| !p.is_finite()) {
            let (x, y) = (i as u32 % reference.width, i as u32 / reference.width);
            return Err(ConvergeError::ReferenceNotFinite { path: path.to_path_buf(), x, y });
        }
        Ok(())
    }

    /// Renders `variant` at every rung of the ladder and measures it against `reference`;
    /// `on_point` sees each measurement as it is made.
    pub fn measure(
        &self,
        scene: &Scene,
        accel: &dyn Accel,
        reference: &Film,
        variant: Variant,
        mut on_point: impl FnMut(&Measurement),
    ) -> Result<Vec<Measurement>, ConvergeError> {
        let repeats = self.repeats.max(1);
        let mut out = Vec::with_capacity(self.ladder.len());
        for (rung, &spp) in self.ladder.iter().enumerate() {
            let mut m =
                Measurement { variant, spp, seconds: 0.0, rays: 0.0, error: ImageError::default(), nonfinite: 0 };
            for repeat in 0..repeats {
                let (film, stats) =
                    render(scene, accel, &self.settings(&variant, spp, self.render_seed(rung, repeat)))?;
                let e = image_error(&film, reference)?;
                m.seconds += stats.elapsed.as_secs_f64();
                m.rays += stats.rays as f64;
                m.error.rel_mse += e.rel_mse;
                m.error.mae += e.mae;
                m.nonfinite += stats.nonfinite;
            }
            let r = repeats as f64;
            (m.seconds, m.rays, m.error.rel_mse, m.error.mae) =
                (m.seconds / r, m.rays / r, m.error.rel_mse / r, m.error.mae / r);
            on_point(&m);
            out.push(m);
        }
        Ok(out)
    }
}

/// Where a variant first reaches a target relMSE.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Reach {
    /// Already at or below the target at the first (lowest-spp) point.
    AtFirst { spp: u32, seconds: f64 },
    /// Crossed between two measured points; spp and seconds interpolated in log-log.
    Interpolated { spp: f64, seconds: f64 },
    /// Above the target at every measured point, the last of which had `max_spp`.
    NotReached { max_spp: u32 },
}

impl std::fmt::Display for Reach {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match *self {
            Reach::AtFirst { spp, seconds } => write!(f, "<= {seconds:.3} s (already at {spp} spp)"),
            Reach::Interpolated { spp, seconds } => write!(f, "{seconds:.3} s (~{spp:.0} spp)"),
            Reach::NotReached { max_spp } => write!(f, "not reached within {max_spp} spp"),
        }
    }
}

/// When the points of one variant (in increasing spp) first reach relMSE ≤ `target`: the
/// first measured point at or below it and the one before are joined by a straight line in
/// log(error) against log(spp) and log(seconds).
pub fn time_to_reach(points: &[Measurement], target: f64) -> Reach {
    let Some(i) = points.iter().position(|m| m.error.rel_mse <= target) else {
        return Reach::NotReached { max_spp: points.last().map_or(0, |m| m.spp) };
    };
    let b = &points[i];
    if i == 0 {
        return Reach::AtFirst { spp: b.spp, seconds: b.seconds };
    }
    let a = &points[i - 1];
    if b.error.rel_mse <= 0.0 || a.seconds <= 0.0 || b.seconds <= 0.0 {
        return Reach::Interpolated { spp: b.spp as f64, seconds: b.seconds };
    }
    let f = (target.ln() - a.error.rel_mse.ln()) / (b.error.rel_mse.ln() - a.error.rel_mse.ln());
    let lerp = |x0: f64, x1: f64| (x0.ln() + f * (x1.ln() - x0.ln())).exp();
    Reach::Interpolated { spp: lerp(a.spp as f64, b.spp as f64), seconds: lerp(a.seconds, b.seconds) }
}

/// Least-squares slope of ln y against ln x; `None` without two distinct x or with a
/// non-positive value.
pub fn log_log_slope(points: &[(f64, f64)]) -> Option<f64> {
    if points.iter().any(|&(x, y)| !(x > 0.0 && y > 0.0)) {
        return None;
    }
    let n = points.len() as f64;
    let (mx, my) = points.iter().fold((0.0, 0.0), |(sx, sy), &(x, y)| (sx + x.ln() / n, sy + y.ln() / n));
    let (sxy, sxx) = points.iter().fold((0.0, 0.0), |(sxy, sxx), &(x, y)| {
        let dx = x.ln() - mx;
        (sxy + dx * (y.ln() - my), sxx + dx * dx)
    });
    (sxx > 0.0).then(|| sxy / sxx)
}

/// The CSV header of [`to_csv`].
pub const CSV_HEADER: &str =
    "variant,estimator,russian_roulette,max_depth,spp,repeats,seconds,rays,rel_mse,mae,nonfinite";

/// The measurements as CSV, one row per point; `full_depth` fills `max_depth` for variants
/// without their own.
pub fn to_csv(points: &[Measurement], full_depth: u32, repeats: u32) -> String {
    let mut s = format!("{CSV_HEADER}\n");
    for m in points {
        let v = &m.variant;
        s.push_str(&format!(
            "{},{},{},{},{},{},{:.6},{:.0},{:.6e},{:.6e},{}\n",
            v.name(),
            v.estimator.name(),
            v.russian_roulette,
            v.max_depth.unwrap_or(full_depth),
            m.spp,
            repeats.max(1),
            m.seconds,
            m.rays,
            m.error.rel_mse,
            m.error.mae,
            m.nonfinite
        ));
    }
    s
}

/// The points grouped into one series per variant (in order of first appearance).
fn series(points: &[Measurement], x: impl Fn(&Measurement) -> f64) -> Vec<(Variant, Series)> {
    let mut out: Vec<(Variant, Series)> = Vec::new();
    for m in points {
        let p = (x(m), m.error.rel_mse);
        match out.iter_mut().find(|(v, _)| *v == m.variant) {
            Some((_, s)) => s.points.push(p),
            None => out.push((m.variant, Series { name: m.variant.name(), points: vec![p] })),
        }
    }
    out
}

/// One colour per estimator, dashed without Russian roulette; depth-limited variants shade
/// from orange (depth 1) to dark blue (depth 10 and beyond), the full-depth line among them
/// black.
fn style(v: &Variant, among_depths: bool) -> LineStyle {
    let color = match (v.max_depth, v.estimator) {
        (Some(d), _) => {
            let t = (d.clamp(1, 10) - 1) as f32 / 9.0;
            let mix = |a: u8, b: u8| (a as f32 + t * (b as f32 - a as f32)).round() as u8;
            (mix(245, 20), mix(160, 40), mix(40, 130))
        }
        (None, _) if among_depths => (0, 0, 0),
        (None, Estimator::NeeMis) => (215, 30, 40),
        (None, Estimator::NeeOnly) => (30, 110, 200),
        (None, Estimator::BsdfOnly) => (40, 160, 60),
        (None, Estimator::BsdfUniform) => (150, 60, 180),
    };
    LineStyle { color, dashed: !v.russian_roulette }
}

fn plot(
    path: &Path,
    title: &str,
    x_label: &str,
    lines: Vec<(Variant, Series)>,
    among_depths: bool,
    target: f64,
) -> Result<(), PlotError> {
    let mut styles: Vec<LineStyle> = lines.iter().map(|(v, _)| style(v, among_depths)).collect();
    let mut series: Vec<Series> = lines.into_iter().map(|(_, s)| s).collect();
    // A flat grey dashed line at the target, across the x range.
    let xs = series.iter().flat_map(|s| s.points.iter().map(|p| p.0)).filter(|&x| x > 0.0 && x.is_finite());
    let (lo, hi) = xs.fold((f64::INFINITY, 0.0f64), |(lo, hi), x| (lo.min(x), hi.max(x)));
    if lo <= hi {
        series.push(Series { name: format!("target relMSE {target}"), points: vec![(lo, target), (hi, target)] });
        styles.push(LineStyle { color: (130, 130, 130), dashed: true });
    }
    let options = PlotOptions { plain_numbers: true, legend_lower_left: true, styles };
    log_log_plot_with(path, title, x_label, "relMSE", &series, &options)
}

/// Writes `error_vs_spp.png` and `error_vs_time.png` into `dir` (the full-depth variants, or
/// every variant when none is full-depth) and, when the study has both, the depth variants
/// with the full-depth NEE+MIS line in `depth_error_vs_spp.png` and `depth_error_vs_time.png`.
/// Returns the files written.
pub fn write_plots(
    dir: &Path,
    points: &[Measurement],
    full_depth: u32,
    target: f64,
) -> Result<Vec<PathBuf>, PlotError> {
    let (full, depth): (Vec<Measurement>, Vec<Measurement>) =
        points.iter().cloned().partition(|m| m.variant.max_depth.is_none());
    let mut files = Vec::new();
    let (main, what) = if full.is_empty() {
        (&depth, "depth-limited variants".to_string())
    } else {
        (&full, format!("depth {full_depth}; dashed: no Russian roulette"))
    };
    let spp = |m: &Measurement| m.spp as f64;
    let secs = |m: &Measurement| m.seconds;
    for (file, x_label, x) in [
        ("error_vs_spp.png", "samples per pixel", &spp as &dyn Fn(&Measurement) -> f64),
        ("error_vs_time.png", "seconds", &secs),
    ] {
        let path = dir.join(file);
        plot(&path, &format!("relMSE vs {x_label} ({what})"), x_label, series(main, x), false, target)?;
        files.push(path);
    }
    if !full.is_empty() && !depth.is_empty() {
        let base = Variant::new(Estimator::NeeMis);
        let with_base: Vec<Measurement> =
            depth.iter().cloned().chain(full.iter().filter(|m| m.variant == base).cloned()).collect();
        for (file, x_label, x) in [
            ("depth_error_vs_spp.png", "samples per pixel", &spp as &dyn Fn(&Measurement) -> f64),
            ("depth_error_vs_time.png", "seconds", &secs),
        ] {
            let path = dir.join(file);
            let title = format!("relMSE vs {x_label}: max depth 1..10 against a depth-{full_depth} reference");
            let mut lines = series(&with_base, x);
            for (v, s) in &mut lines {
                if v.max_depth.is_none() {
                    s.name = format!("{}/depth={full_depth} (full)", s.name);
                }
            }
            plot(&path, &title, x_label, lines, true, target)?;
            files.push(path);
        }
    }
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(spp: u32, seconds: f64, rel_mse: f64) -> Measurement {
        Measurement {
            variant: Variant::new(Estimator::NeeMis),
            spp,
            seconds,
            rays: 0.0,
            error: ImageError { rel_mse, mae: 0.0 },
            nonfinite: 0,
        }
    }

    #[test]
    fn ladder_is_powers_of_two_up_to_the_maximum() {
        assert_eq!(spp_ladder(1), vec![1]);
        assert_eq!(spp_ladder(16), vec![1, 2, 4, 8, 16]);
        assert_eq!(spp_ladder(20), vec![1, 2, 4, 8, 16, 20]);
    }

    #[test]
    fn variant_names_round_trip() {
        for v in parse_variants("all", 64).unwrap() {
            assert_eq!(v.name().parse::<Variant>().unwrap(), v);
        }
        let v: Variant = "bsdf-uniform/no-rr/depth=3".parse().unwrap();
        assert_eq!(v, Variant { estimator: Estimator::BsdfUniform, russian_roulette: false, max_depth: Some(3) });
    }

    #[test]
    fn groups_expand_and_duplicates_are_dropped() {
        let all = parse_variants("all", 64).unwrap();
        assert_eq!(all.len(), 4 + 4 + 10);
        assert_eq!(parse_variants("nee-mis,estimators,nee-mis", 64).unwrap().len(), 4);
        // Depths at or beyond the full depth are not in the group.
        assert_eq!(parse_variants("depth", 4).unwrap().len(), 3);
        assert!(parse_variants("nee-mis/fast", 64).unwrap_err().contains("unknown option \"fast\""));
        assert!(parse_variants("mis", 64).unwrap_err().contains("unknown estimator"));
        assert!(parse_variants("nee,,bsdf", 64).is_err());
    }

    #[test]
    fn slope_of_an_exact_power_law() {
        let pts: Vec<(f64, f64)> = [1.0, 2.0, 4.0, 8.0, 16.0].iter().map(|&x: &f64| (x, 3.0 * x.powf(-1.0))).collect();
        assert!((log_log_slope(&pts).unwrap() + 1.0).abs() < 1e-12);
        let pts: Vec<(f64, f64)> = [1.0, 10.0, 100.0].iter().map(|&x: &f64| (x, 0.5 * x.powf(-0.5))).collect();
        assert!((log_log_slope(&pts).unwrap() + 0.5).abs() < 1e-12);
        assert_eq!(log_log_slope(&[(1.0, 1.0), (1.0, 2.0)]), None);
        assert_eq!(log_log_slope(&[(1.0, 1.0), (2.0, 0.0)]), None);
    }

    #[test]
    fn time_to_reach_interpolates_in_log_log() {
        // relMSE = 0.16/spp and seconds = 0.01·spp: 1% is reached at 16 spp, 0.16 s, which lies
        // between the measured 8 and 32 spp points.
        let pts: Vec<Measurement> = [1, 2, 8, 32].iter().map(|&s| point(s, 0.01 * s as f64, 0.16 / s as f64)).collect();
        let Reach::Interpolated { spp, seconds } = time_to_reach(&pts, 0.01) else { panic!() };
        assert!((spp - 16.0).abs() < 1e-9 && (seconds - 0.16).abs() < 1e-12, "{spp} {seconds}");
        assert_eq!(time_to_reach(&pts, 0.5), Reach::AtFirst { spp: 1, seconds: 0.01 });
        assert_eq!(time_to_reach(&pts, 0.001), Reach::NotReached { max_spp: 32 });
    }

    #[test]
    fn csv_has_one_row_per_point() {
        let mut p = point(4, 0.5, 0.02);
        p.variant.max_depth = Some(3);
        let csv = to_csv(&[point(1, 0.25, 0.125), p], 64, 2);
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines[0], CSV_HEADER);
        assert_eq!(lines[1], "nee-mis,nee-mis,true,64,1,2,0.250000,0,1.250000e-1,0.000000e0,0");
        assert_eq!(lines[2], "nee-mis/depth=3,nee-mis,true,3,4,2,0.500000,0,2.000000e-2,0.000000e0,0");
        assert_eq!(lines.len(), 3);
    }
}

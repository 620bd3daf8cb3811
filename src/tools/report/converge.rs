//! Writing a convergence study's results ([`crate::tools::converge`]): the CSV table, the
//! log-log plots of error (relMSE and FLIP) against spp and seconds, and the time-to-reach
//! table.

use super::plot::{LineStyle, PlotError, PlotOptions, Series, log_log_plot_with};
use crate::film::AuxMode;
use crate::integrator::Estimator;
use crate::oidn::Aux;
use crate::settings::LightVertices;
use crate::tools::converge::{ConvergencePoint, ImageDifference, TimeToReach, Variant, time_to_reach_by};
use std::path::{Path, PathBuf};

/// The CSV header of [`to_csv`].
pub const CSV_HEADER: &str = "variant,estimator,russian_roulette,max_depth,spp,repeats,seconds,rays,rel_mse,mae,\
                              nonfinite,denoise,denoise_seconds,flip";

/// The points as CSV, one row each; `full_depth` fills `max_depth` for variants
/// without their own. `denoise` is the auxiliary mode of a denoised variant (`none`: not
/// denoised); `seconds` includes `denoise_seconds`.
pub fn to_csv(points: &[ConvergencePoint], full_depth: u32, repeats: u32) -> String {
    let mut s = format!("{CSV_HEADER}\n");
    for m in points {
        let v = &m.variant;
        s.push_str(&format!(
            "{},{},{},{},{},{},{:.6},{:.0},{:.6e},{:.6e},{},{},{:.6},{:.6e}\n",
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
            m.nonfinite,
            v.denoise.map_or("none", AuxMode::name),
            m.denoise_seconds,
            m.error.flip
        ));
    }
    s
}

/// The error measures plotted: (file name prefix, axis label, value).
type Metric = (&'static str, &'static str, fn(&ImageDifference) -> f64);
const REL_MSE: Metric = ("error", "relMSE", |e| e.rel_mse);
const FLIP: Metric = ("flip", "mean FLIP", |e| e.flip);

/// The points grouped into one series per variant (in order of first appearance).
fn series(
    points: &[ConvergencePoint],
    x: impl Fn(&ConvergencePoint) -> f64,
    y: fn(&ImageDifference) -> f64,
) -> Vec<(Variant, Series)> {
    let mut out: Vec<(Variant, Series)> = Vec::new();
    for m in points {
        let p = (x(m), y(&m.error));
        match out.iter_mut().find(|(v, _)| *v == m.variant) {
            Some((_, s)) => s.points.push(p),
            None => out.push((m.variant, Series { name: m.variant.name(), points: vec![p] })),
        }
    }
    out
}

/// One colour per estimator, dashed without Russian roulette; depth-limited variants shade
/// from orange (depth 1) to dark blue (depth 10 and beyond), the full-depth line among them
/// black; denoised variants one colour per auxiliary mode (prefiltered: black); adaptive
/// ones black; light vertices forced on black, off blue.
fn line_style(v: &Variant, among_depths: bool) -> LineStyle {
    let color = match (v.max_depth, v.estimator) {
        _ if v.adaptive && v.denoise.is_none() => (0, 0, 0),
        _ if v.light_vertices == Some(LightVertices::On) => (0, 0, 0),
        _ if v.light_vertices == Some(LightVertices::Off) => (30, 110, 200),
        _ if v.denoise.is_some() => match v.denoise.unwrap() {
            AuxMode::ColorOnly => (230, 140, 20),
            AuxMode::With(Aux::Noisy) => (0, 160, 160),
            AuxMode::With(Aux::Prefilter) => (0, 0, 0),
            AuxMode::With(Aux::Clean) => (140, 90, 40),
        },
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
    y_label: &str,
    lines: Vec<(Variant, Series)>,
    among_depths: bool,
    target: f64,
) -> Result<(), PlotError> {
    let mut styles: Vec<LineStyle> = lines.iter().map(|(v, _)| line_style(v, among_depths)).collect();
    let mut series: Vec<Series> = lines.into_iter().map(|(_, s)| s).collect();
    // A flat grey dashed line at the target, across the x range.
    let xs = series.iter().flat_map(|s| s.points.iter().map(|p| p.0)).filter(|&x| x > 0.0 && x.is_finite());
    let (lo, hi) = xs.fold((f64::INFINITY, 0.0f64), |(lo, hi), x| (lo.min(x), hi.max(x)));
    if lo <= hi {
        series.push(Series { name: format!("target {y_label} {target}"), points: vec![(lo, target), (hi, target)] });
        styles.push(LineStyle { color: (130, 130, 130), dashed: true });
    }
    let options = PlotOptions { plain_numbers: true, legend_lower_left: true, styles };
    log_log_plot_with(path, title, x_label, y_label, &series, &options)
}

/// Writes `error_vs_spp.png` and `error_vs_time.png` (relMSE) and `flip_vs_spp.png` and
/// `flip_vs_time.png` (mean FLIP) into `dir` (the full-depth variants, denoised ones included,
/// or every variant when none is full-depth) and, when the study has both, the depth variants
/// with the full-depth NEE+MIS line in `depth_error_vs_spp.png` and `depth_error_vs_time.png`.
/// `target` and `flip_target` draw the targets. Returns the files written.
pub fn write_plots(
    dir: &Path,
    points: &[ConvergencePoint],
    full_depth: u32,
    target: f64,
    flip_target: f64,
) -> Result<Vec<PathBuf>, PlotError> {
    let (full, depth): (Vec<ConvergencePoint>, Vec<ConvergencePoint>) =
        points.iter().cloned().partition(|m| m.variant.max_depth.is_none());
    let mut files = Vec::new();
    let (main, what) = if full.is_empty() {
        (&depth, "depth-limited variants".to_string())
    } else {
        (&full, format!("depth {full_depth}; dashed: no Russian roulette"))
    };
    let spp = |m: &ConvergencePoint| m.spp as f64;
    let secs = |m: &ConvergencePoint| m.seconds;
    for ((prefix, y_label, y), target) in [(REL_MSE, target), (FLIP, flip_target)] {
        for (file, x_label, x) in [
            ("vs_spp.png", "samples per pixel", &spp as &dyn Fn(&ConvergencePoint) -> f64),
            ("vs_time.png", "seconds", &secs),
        ] {
            let path = dir.join(format!("{prefix}_{file}"));
            let title = format!("{y_label} vs {x_label} ({what})");
            plot(&path, &title, x_label, y_label, series(main, x, y), false, target)?;
            files.push(path);
        }
    }
    if !full.is_empty() && !depth.is_empty() {
        let base = Variant::new(Estimator::NeeMis);
        let with_base: Vec<ConvergencePoint> =
            depth.iter().cloned().chain(full.iter().filter(|m| m.variant == base).cloned()).collect();
        for (file, x_label, x) in [
            ("depth_error_vs_spp.png", "samples per pixel", &spp as &dyn Fn(&ConvergencePoint) -> f64),
            ("depth_error_vs_time.png", "seconds", &secs),
        ] {
            let path = dir.join(file);
            let title = format!("relMSE vs {x_label}: max depth 1..10 against a depth-{full_depth} reference");
            let mut lines = series(&with_base, x, REL_MSE.2);
            for (v, s) in &mut lines {
                if v.max_depth.is_none() {
                    s.name = format!("{}/depth={full_depth} (full)", s.name);
                }
            }
            plot(&path, &title, x_label, "relMSE", lines, true, target)?;
            files.push(path);
        }
    }
    Ok(files)
}

/// The terminal table of a study: one row per variant (its points in `per_variant`, in
/// increasing spp up to `largest_spp`) with its relMSE, MAE and mean FLIP at `largest_spp`,
/// when it reaches relMSE `target` and FLIP `flip_target`
/// ([`crate::tools::converge::time_to_reach`]), and whether it is biased (its error keeps a
/// floor more samples do not remove: [`Variant::bias`]).
pub fn time_to_reach_table(
    per_variant: &[Vec<ConvergencePoint>],
    largest_spp: u32,
    target: f64,
    flip_target: f64,
) -> String {
    let name_width = per_variant.iter().filter_map(|p| p.first()).map(|m| m.variant.name().len()).max().unwrap_or(0);
    let name_width = name_width.max(28);
    let mut s = format!(
        "{:<name_width$} {:>12} {:>12} {:>10}   {:<36} {:<36} {}\n",
        "variant",
        format!("relMSE@{largest_spp}"),
        format!("MAE@{largest_spp}"),
        format!("FLIP@{largest_spp}"),
        format!("time to reach relMSE {target}"),
        format!("time to reach FLIP {flip_target}"),
        "bias"
    );
    for points in per_variant {
        let Some(last) = points.last() else { continue };
        s.push_str(&format!(
            "{:<name_width$} {:>12.3e} {:>12.3e} {:>10.4}   {:<36} {:<36} {}\n",
            last.variant.name(),
            last.error.rel_mse,
            last.error.mae,
            last.error.flip,
            time_to_reach_cell(&time_to_reach_by(points, target, |e| e.rel_mse)),
            time_to_reach_cell(&time_to_reach_by(points, flip_target, |e| e.flip)),
            last.variant.bias().as_deref().unwrap_or("unbiased")
        ));
    }
    s
}

/// A cell of the time-to-reach column.
fn time_to_reach_cell(reach: &TimeToReach) -> String {
    match *reach {
        TimeToReach::AtFirst { spp, seconds } => format!("<= {seconds:.3} s (already at {spp} spp)"),
        TimeToReach::Interpolated { spp, seconds } => format!("{seconds:.3} s (~{spp:.0} spp)"),
        TimeToReach::NotReached { max_spp } => format!("not reached within {max_spp} spp"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_has_one_row_per_point() {
        let mut p = ConvergencePoint::nee_mis(4, 0.5, 0.02);
        p.variant.max_depth = Some(3);
        let csv = to_csv(&[ConvergencePoint::nee_mis(1, 0.25, 0.125), p], 64, 2);
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines[0], CSV_HEADER);
        assert_eq!(
            lines[1],
            "nee-mis,nee-mis,true,64,1,2,0.250000,0,1.250000e-1,0.000000e0,0,none,0.000000,0.000000e0"
        );
        assert_eq!(
            lines[2],
            "nee-mis/depth=3,nee-mis,true,3,4,2,0.500000,0,2.000000e-2,0.000000e0,0,none,0.000000,0.000000e0"
        );
        assert_eq!(lines.len(), 3);
    }

    #[test]
    fn time_to_reach_table_has_a_row_per_variant() {
        let points: Vec<ConvergencePoint> =
            [1, 2, 8, 32].iter().map(|&s| ConvergencePoint::nee_mis(s, 0.01 * s as f64, 0.16 / s as f64)).collect();
        let mut denoised = points.clone();
        for m in &mut denoised {
            m.variant.denoise = Some(AuxMode::DEFAULT);
        }
        let table = time_to_reach_table(&[points.clone(), points[..2].to_vec(), denoised], 32, 0.01, 0.05);
        let lines: Vec<&str> = table.lines().collect();
        assert_eq!(lines.len(), 4, "{table}");
        assert!(lines[0].contains("time to reach relMSE 0.01") && lines[0].ends_with("bias"), "{table}");
        assert!(lines[1].contains("0.160 s (~16 spp)") && lines[1].ends_with("unbiased"), "{table}");
        assert!(lines[2].contains("not reached within 2 spp"), "{table}");
        assert!(lines[3].starts_with("nee-mis/denoise=prefilter") && lines[3].ends_with("biased: denoised"), "{table}");
    }
}

//! Log-log line plots (PNG) with plotters: one line per series, a legend, labelled axes.
//!
//! Text needs a font: plotters is built without system font discovery (which would need
//! fontconfig at build time), so a TrueType font is loaded from disk once, from
//! `EMBER_PLOT_FONT` or Debian's DejaVu Sans (package `fonts-dejavu-core`).

use plotters::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// One line of a plot: a name for the legend and its (x, y) points. Points with a
/// non-positive or non-finite coordinate cannot be shown on log axes and are skipped.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    pub name: String,
    pub points: Vec<(f64, f64)>,
}

#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    #[error("no font for plot text: {0} (install fonts-dejavu-core or set EMBER_PLOT_FONT to a .ttf file)")]
    Font(String),
    #[error("nothing to plot in {0}: no series has a positive, finite point")]
    Empty(PathBuf),
    #[error(transparent)]
    Write(#[from] crate::output::WriteError),
}

const FONT_FAMILY: &str = "sans-serif";
const FONT_PATHS: [&str; 2] =
    ["/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf", "/usr/share/fonts/truetype/freefont/FreeSans.ttf"];

fn ensure_font() -> Result<(), PlotError> {
    static FONT: OnceLock<Result<(), String>> = OnceLock::new();
    FONT.get_or_init(|| {
        let candidates: Vec<PathBuf> = match std::env::var_os("EMBER_PLOT_FONT") {
            Some(p) => vec![PathBuf::from(p)],
            None => FONT_PATHS.iter().map(PathBuf::from).collect(),
        };
        for path in &candidates {
            if let Ok(bytes) = std::fs::read(path) {
                // Registered fonts must live for the whole program; this happens once.
                let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
                return plotters::style::register_font(FONT_FAMILY, FontStyle::Normal, bytes)
                    .map_err(|_| format!("{} is not a usable TrueType font", path.display()));
            }
        }
        let tried: Vec<String> = candidates.iter().map(|p| p.display().to_string()).collect();
        Err(format!("none of {} could be read", tried.join(", ")))
    })
    .clone()
    .map_err(PlotError::Font)
}

/// Writes a log-log plot of `series` to `path` (PNG, 900×600).
pub fn log_log_plot(path: &Path, title: &str, x_label: &str, y_label: &str, series: &[Series]) -> Result<(), PlotError> {
    ensure_font()?;
    let usable = |&(x, y): &(f64, f64)| x > 0.0 && y > 0.0 && x.is_finite() && y.is_finite();
    let all: Vec<(f64, f64)> = series.iter().flat_map(|s| s.points.iter().copied().filter(usable)).collect();
    if all.is_empty() {
        return Err(PlotError::Empty(path.to_path_buf()));
    }
    let range = |v: &mut dyn Iterator<Item = f64>| {
        let (lo, hi) = v.fold((f64::INFINITY, 0.0f64), |(lo, hi), x| (lo.min(x), hi.max(x)));
        // Pad by a fraction of a decade so points do not sit on the frame.
        let hi = if hi > lo { hi } else { lo * 10.0 };
        (lo / 1.25)..(hi * 1.25)
    };
    let xr = range(&mut all.iter().map(|p| p.0));
    let yr = range(&mut all.iter().map(|p| p.1));
    crate::output::write_atomically(path, |tmp| {
        draw(tmp, title, x_label, y_label, series, xr, yr, &usable).map_err(|e| e.to_string())
    })?;
    Ok(())
}

type DrawResult = Result<(), Box<dyn std::error::Error>>;

#[allow(clippy::too_many_arguments)]
fn draw(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    xr: std::ops::Range<f64>,
    yr: std::ops::Range<f64>,
    usable: &dyn Fn(&(f64, f64)) -> bool,
) -> DrawResult {
    let root = BitMapBackend::new(path, (900, 600)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, (FONT_FAMILY, 22))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(xr.log_scale(), yr.log_scale())?;
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc(y_label)
        .label_style((FONT_FAMILY, 14))
        .x_label_formatter(&|v| format!("{v:.3e}"))
        .y_label_formatter(&|v| format!("{v:.1e}"))
        .draw()?;
    for (i, s) in series.iter().enumerate() {
        let color = Palette99::pick(i).to_rgba();
        let points: Vec<(f64, f64)> = s.points.iter().copied().filter(usable).collect();
        chart
            .draw_series(LineSeries::new(points.clone(), color.stroke_width(2)))?
            .label(s.name.clone())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2)));
        chart.draw_series(points.into_iter().map(|p| Circle::new(p, 3, color.filled())))?;
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font((FONT_FAMILY, 14))
        .position(SeriesLabelPosition::UpperRight)
        .draw()?;
    root.present()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_a_png_with_the_requested_size() {
        let dir = std::env::temp_dir().join(format!("ember-plot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("p.png");
        let s = Series { name: "1/x".into(), points: (1..=64).map(|i| (i as f64, 1.0 / i as f64)).collect() };
        log_log_plot(&path, "test", "x", "y", &[s]).unwrap();
        let img = image::open(&path).unwrap();
        assert_eq!((img.width(), img.height()), (900, 600));
        // Not a blank canvas: the line and text put non-white pixels in it.
        let rgb = img.to_rgb8();
        let dark = rgb.pixels().filter(|p| p.0.iter().all(|&c| c < 128)).count();
        assert!(dark > 1000, "{dark} dark pixels");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn refuses_a_plot_with_no_usable_point() {
        let path = std::env::temp_dir().join("ember-never-written.png");
        let s = Series { name: "zero".into(), points: vec![(0.0, 1.0), (1.0, f64::NAN)] };
        assert!(matches!(log_log_plot(&path, "t", "x", "y", &[s]), Err(PlotError::Empty(_))));
        assert!(!path.exists());
    }
}

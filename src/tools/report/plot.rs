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
    Write(#[from] crate::atomic_write::WriteError),
}

const FONT_FAMILY: &str = "sans-serif";
/// Width and height of a plot in pixels.
const PLOT_SIZE: (u32, u32) = (900, 600);
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

/// How one series is drawn (see [`PlotOptions::styles`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LineStyle {
    /// RGB colour.
    pub color: (u8, u8, u8),
    /// Dashed rather than solid.
    pub dashed: bool,
}

/// Choices beyond [`log_log_plot`]'s defaults, for [`log_log_plot_with`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PlotOptions {
    /// Axis numbers as plain decimals (1, 16, 0.01) rather than scientific notation.
    pub plain_numbers: bool,
    /// Legend in the lower left corner rather than the upper right (where falling curves
    /// start).
    pub legend_lower_left: bool,
    /// Style of series i; series beyond the list get the default palette, solid.
    pub styles: Vec<LineStyle>,
}

/// Writes a log-log plot of `series` to `path` (PNG, 900×600).
pub fn log_log_plot(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
) -> Result<(), PlotError> {
    log_log_plot_with(path, title, x_label, y_label, series, &PlotOptions::default())
}

/// [`log_log_plot`] with [`PlotOptions`].
pub fn log_log_plot_with(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    options: &PlotOptions,
) -> Result<(), PlotError> {
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
    let (w, h) = PLOT_SIZE;
    let mut rgb = vec![0u8; w as usize * h as usize * 3];
    draw(&mut rgb, title, x_label, y_label, series, xr, yr, &usable, options)
        .map_err(|e| crate::atomic_write::WriteError { path: path.to_path_buf(), reason: e.to_string() })?;
    crate::atomic_write::write_atomically(path, |file| {
        use image::ImageEncoder;
        let mut out = std::io::BufWriter::new(file);
        image::codecs::png::PngEncoder::new(&mut out)
            .write_image(&rgb, w, h, image::ExtendedColorType::Rgb8)
            .map_err(|e| e.to_string())?;
        out.into_inner().map(|_| ()).map_err(|e| e.error().to_string())
    })?;
    Ok(())
}

/// A number with at most three significant digits and no exponent between 0.001 and 10⁶
/// ("0.005", "16", "2000"), else in short scientific notation ("1e-5").
fn plain_number(v: f64) -> String {
    let a = v.abs();
    if !(1e-3..1e6).contains(&a) {
        return if a == 0.0 { "0".into() } else { format!("{v:.0e}") };
    }
    let decimals = (2 - a.log10().floor() as i32).max(0) as usize;
    let s = format!("{v:.decimals$}");
    if s.contains('.') { s.trim_end_matches('0').trim_end_matches('.').to_string() } else { s }
}

type DrawResult = Result<(), Box<dyn std::error::Error>>;

#[allow(clippy::too_many_arguments)]
fn draw(
    rgb: &mut [u8],
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    xr: std::ops::Range<f64>,
    yr: std::ops::Range<f64>,
    usable: &dyn Fn(&(f64, f64)) -> bool,
    options: &PlotOptions,
) -> DrawResult {
    let root = BitMapBackend::with_buffer(rgb, PLOT_SIZE).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, (FONT_FAMILY, 22))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(xr.log_scale(), yr.log_scale())?;
    let x_fmt = |v: &f64| if options.plain_numbers { plain_number(*v) } else { format!("{v:.3e}") };
    let y_fmt = |v: &f64| if options.plain_numbers { plain_number(*v) } else { format!("{v:.1e}") };
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc(y_label)
        .label_style((FONT_FAMILY, 14))
        .x_label_formatter(&x_fmt)
        .y_label_formatter(&y_fmt)
        .draw()?;
    for (i, s) in series.iter().enumerate() {
        let style = options.styles.get(i).copied();
        let color = match style {
            Some(LineStyle { color: (r, g, b), .. }) => RGBColor(r, g, b).to_rgba(),
            None => Palette99::pick(i).to_rgba(),
        };
        let dashed = style.is_some_and(|s| s.dashed);
        let points: Vec<(f64, f64)> = s.points.iter().copied().filter(usable).collect();
        let line = color.stroke_width(2);
        // Two segments with a gap when dashed, one over the other when solid.
        let (end1, start2) = if dashed { (7, 12) } else { (20, 0) };
        let legend = move |(x, y): (i32, i32)| {
            EmptyElement::at((x, y))
                + PathElement::new(vec![(0, 0), (end1, 0)], line)
                + PathElement::new(vec![(start2, 0), (20, 0)], line)
        };
        let annotation = if dashed {
            chart.draw_series(DashedLineSeries::new(points.clone(), 8, 5, line))?
        } else {
            chart.draw_series(LineSeries::new(points.clone(), line))?
        };
        annotation.label(s.name.clone()).legend(legend);
        chart.draw_series(points.into_iter().map(|p| Circle::new(p, 3, color.filled())))?;
    }
    chart
        .configure_series_labels()
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font((FONT_FAMILY, 14))
        .position(if options.legend_lower_left {
            SeriesLabelPosition::LowerLeft
        } else {
            SeriesLabelPosition::UpperRight
        })
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
    fn plain_numbers_have_at_most_three_significant_digits() {
        let cases = [
            (1.0, "1"),
            (16.0, "16"),
            (2000.0, "2000"),
            (0.01, "0.01"),
            (0.005, "0.005"),
            (0.123456, "0.123"),
            (2.5, "2.5"),
        ];
        for (v, s) in cases {
            assert_eq!(plain_number(v), s);
        }
        assert_eq!(plain_number(1e-5), "1e-5");
        assert_eq!(plain_number(3e7), "3e7");
        assert_eq!(plain_number(0.0), "0");
    }

    #[test]
    fn dashed_and_coloured_lines_with_options() {
        let dir = std::env::temp_dir().join(format!("ember-plot-opts-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("p.png");
        let s = Series { name: "1/x".into(), points: (1..=64).map(|i| (i as f64, 1.0 / i as f64)).collect() };
        let options = PlotOptions {
            plain_numbers: true,
            legend_lower_left: true,
            styles: vec![LineStyle { color: (0, 0, 255), dashed: true }],
        };
        log_log_plot_with(&path, "test", "x", "y", &[s], &options).unwrap();
        let rgb = image::open(&path).unwrap().to_rgb8();
        // The line is drawn in the requested colour.
        let blue = rgb.pixels().filter(|p| p.0 == [0, 0, 255]).count();
        assert!(blue > 200, "{blue} blue pixels");
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

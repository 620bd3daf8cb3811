//! Log-log line plots (PNG) with plotters: one line per series, a legend, labelled axes.
//!
//! Text is drawn in DejaVu Sans, built into the binary (assets/fonts/, with its licence):
//! plotters is built without system font discovery (which would need fontconfig at build
//! time), and a plot must not depend on a font at a fixed path. Axis numbers are placed by
//! [`log_ticks`], which leaves room between labels whatever the range.

use plotters::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// DejaVu Sans 2.37, unmodified (assets/fonts/DejaVu-LICENSE: Bitstream Vera licence, free to
/// copy and redistribute, also embedded in software).
static FONT: &[u8] = include_bytes!("../../../assets/fonts/DejaVuSans.ttf");

/// One line of a plot: a name for the legend and its (x, y) points. Points with a
/// non-positive or non-finite coordinate cannot be shown on log axes and are skipped.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    pub name: String,
    pub points: Vec<(f64, f64)>,
}

#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    #[error("the plot font built into ember could not be loaded: {0}")]
    Font(String),
    #[error("nothing to plot in {0}: no series has a positive, finite point")]
    Empty(PathBuf),
    #[error(transparent)]
    Write(#[from] crate::atomic_write::WriteError),
}

const FONT_FAMILY: &str = "sans-serif";
/// Width and height of a plot in pixels.
const PLOT_SIZE: (u32, u32) = (900, 600);
/// Size of axis numbers, in pixels.
const LABEL_SIZE: u32 = 14;
/// Room the axes get, in pixels: the plot less margins, caption and label areas (a little
/// less than plotters gives them, so that labels keep their room).
const X_AXIS_PIXELS: f64 = 780.0;
const Y_AXIS_PIXELS: f64 = 470.0;
/// Width of a character of an axis number (DejaVu Sans digits are 0.64 em) and the least gap
/// between two numbers, in pixels.
const CHAR_PIXELS: f64 = 9.0;
const LABEL_GAP: f64 = 12.0;
/// The most numbers on an axis.
const MAX_TICKS: usize = 10;

fn ensure_font() -> Result<(), PlotError> {
    static REGISTERED: OnceLock<Result<(), String>> = OnceLock::new();
    REGISTERED
        .get_or_init(|| {
            plotters::style::register_font(FONT_FAMILY, FontStyle::Normal, FONT)
                .map_err(|_| "not a usable TrueType font".to_string())
        })
        .clone()
        .map_err(PlotError::Font)
}

/// Values for the numbers of a log axis over `range`: the densest of 1, 1.5, 2, … 9.5; 1, 2,
/// … 9; 1, 2, 5; 1, 3; 1 per decade; then one every 2, 3, 5, 10, … decades, with at most
/// [`MAX_TICKS`] numbers and room for each of them (`fits` says whether two consecutive numbers
/// have room). Few points make a range of less than a decade or two, where plotters' own
/// choice (1 to 9 in every decade) crowds 6, 7, 8, 9 into each other. A range too narrow for
/// two of these gets one number, in its middle.
fn log_ticks(range: std::ops::Range<f64>, fits: &dyn Fn(f64, f64) -> bool) -> Vec<f64> {
    let (lo, hi) = (range.start, range.end);
    let halves: Vec<f64> = (2..20).map(|i| i as f64 / 2.0).collect();
    let mantissas: [&[f64]; 5] =
        [&halves, &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0], &[1.0, 2.0, 5.0], &[1.0, 3.0], &[1.0]];
    let (first, last) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
    let round = |v: f64| {
        // Exact decimal values (0.1 * 3 is not 0.3): through the shortest text of 3 digits.
        format!("{v:.2e}").parse::<f64>().unwrap_or(v)
    };
    let per_decade = mantissas.iter().map(|m| (1, *m));
    let sparser = [2, 3, 5, 10, 20, 50, 100].into_iter().map(|step| (step, &[1.0][..]));
    for (step, m) in per_decade.chain(sparser) {
        let ticks: Vec<f64> = (first..=last)
            .filter(|e| e.rem_euclid(step) == 0)
            .flat_map(|e| m.iter().map(move |&k| round(k * 10f64.powi(e))))
            .filter(|v| (lo..=hi).contains(v))
            .collect();
        if ticks.len() > MAX_TICKS || ticks.windows(2).any(|w| !fits(w[0], w[1])) {
            continue;
        }
        if ticks.len() >= 2 || step > 1 {
            return ticks;
        }
    }
    vec![round((lo * hi).sqrt())]
}

/// Whether numbers at `a` < `b` on a log axis over `range`, `pixels` long, are apart by at
/// least `room(a, b)` pixels.
fn apart(range: &std::ops::Range<f64>, pixels: f64, a: f64, b: f64, room: f64) -> bool {
    (b / a).log10() / (range.end / range.start).log10() * pixels >= room
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

/// A number in the shortest scientific notation that keeps three significant digits ("2e3",
/// "1.5e-4", "1.25e6").
fn short_scientific(v: f64) -> String {
    for digits in 0..2 {
        let s = format!("{v:.digits$e}");
        if s.parse::<f64>().is_ok_and(|p| (p - v).abs() <= 1e-9 * v.abs()) {
            return s;
        }
    }
    format!("{v:.2e}")
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
    let fmt = |v: f64| if options.plain_numbers { plain_number(v) } else { short_scientific(v) };
    let width = |v: f64| fmt(v).chars().count() as f64 * CHAR_PIXELS;
    // Side by side on x: half of each number's width and a gap; one above the other on y.
    let x_ticks = log_ticks(xr.clone(), &|a: f64, b: f64| {
        apart(&xr, X_AXIS_PIXELS, a, b, (width(a) + width(b)) / 2.0 + LABEL_GAP)
    });
    let y_ticks =
        log_ticks(yr.clone(), &|a: f64, b: f64| apart(&yr, Y_AXIS_PIXELS, a, b, LABEL_SIZE as f64 + LABEL_GAP));
    // Light grid lines at 1 to 9 of every decade, as plotters draws them.
    let light = |r: &std::ops::Range<f64>| -> Vec<f64> {
        let (first, last) = (r.start.log10().floor() as i32, r.end.log10().ceil() as i32);
        (first..=last).flat_map(|e| (1..10).map(move |k| k as f64 * 10f64.powi(e))).filter(|v| r.contains(v)).collect()
    };
    let (x_light, y_light) = (light(&xr), light(&yr));
    let root = BitMapBackend::with_buffer(rgb, PLOT_SIZE).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, (FONT_FAMILY, 22))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(
            xr.log_scale().with_key_points(x_ticks).with_light_points(x_light),
            yr.log_scale().with_key_points(y_ticks).with_light_points(y_light),
        )?;
    let x_fmt = |v: &f64| fmt(*v);
    let y_fmt = |v: &f64| fmt(*v);
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc(y_label)
        .label_style((FONT_FAMILY, LABEL_SIZE))
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
    fn axis_numbers_have_room_whatever_the_range() {
        // Each range as log_log_plot pads it (/1.25, *1.25): a ladder of 1 to 4 spp, 1 to 64,
        // relMSE over five decades, a single point (one decade), a narrow range, nine decades.
        let ranges = [(1.0, 4.0), (1.0, 64.0), (1e-5, 1.0), (3.0, 30.0), (9.1, 11.0), (1.0, 1e9), (0.012, 0.013)];
        let label = |v: f64| plain_number(v).len() as f64 * CHAR_PIXELS;
        for (lo, hi) in ranges {
            let r = (lo / 1.25)..(hi * 1.25);
            let fits = |a: f64, b: f64| apart(&r, X_AXIS_PIXELS, a, b, (label(a) + label(b)) / 2.0 + LABEL_GAP);
            let ticks = log_ticks(r.clone(), &fits);
            assert!(!ticks.is_empty() && ticks.len() <= MAX_TICKS, "{r:?}: {ticks:?}");
            assert!(ticks.iter().all(|t| (r.start..=r.end).contains(t)), "{r:?}: {ticks:?}");
            assert!(ticks.windows(2).all(|w| w[0] < w[1] && fits(w[0], w[1])), "{r:?}: {ticks:?}");
            // Two numbers at least, but for a range narrower than a factor of two.
            assert!(ticks.len() >= 2 || hi / lo < 2.0, "{r:?}: {ticks:?}");
        }
        let r = 0.8..80.0;
        let fits = |a: f64, b: f64| apart(&r, X_AXIS_PIXELS, a, b, (label(a) + label(b)) / 2.0 + LABEL_GAP);
        // Not 1 to 9 in each decade (plotters' choice, where 7, 8, 9 run into each other).
        assert_eq!(log_ticks(r.clone(), &fits), vec![1.0, 2.0, 5.0, 10.0, 20.0, 50.0]);
        // Nine decades on the height of the y axis: one number every other decade at most.
        let r = 1e-5..1e4;
        let y = log_ticks(r.clone(), &|a: f64, b: f64| apart(&r, Y_AXIS_PIXELS, a, b, 26.0));
        assert_eq!(y, vec![1e-5, 1e-4, 1e-3, 1e-2, 1e-1, 1.0, 10.0, 100.0, 1e3, 1e4]);
        assert_eq!(short_scientific(2000.0), "2e3");
        assert_eq!(short_scientific(1.5e-4), "1.5e-4");
        assert_eq!(short_scientific(1.25e6), "1.25e6");
    }

    #[test]
    fn refuses_a_plot_with_no_usable_point() {
        let path = std::env::temp_dir().join("ember-never-written.png");
        let s = Series { name: "zero".into(), points: vec![(0.0, 1.0), (1.0, f64::NAN)] };
        assert!(matches!(log_log_plot(&path, "t", "x", "y", &[s]), Err(PlotError::Empty(_))));
        assert!(!path.exists());
    }
}

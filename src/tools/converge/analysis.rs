//! What a study's points say: how fast the error falls (the slope of log error against log
//! spp) and when a variant first reaches a target relMSE.

use super::metrics::ImageDifference;
use super::study::ConvergencePoint;

/// Where a variant first reaches a target relMSE.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TimeToReach {
    /// Already at or below the target at the first (lowest-spp) point.
    AtFirst { spp: u32, seconds: f64 },
    /// Crossed between two measured points; spp and seconds interpolated in log-log.
    Interpolated { spp: f64, seconds: f64 },
    /// Above the target at every measured point, the last of which had `max_spp`.
    NotReached { max_spp: u32 },
}

/// When the points of one variant (in increasing spp) first reach relMSE ≤ `target`: the
/// first measured point at or below it and the one before are joined by a straight line in
/// log(error) against log(spp) and log(seconds).
pub fn time_to_reach(points: &[ConvergencePoint], target: f64) -> TimeToReach {
    time_to_reach_by(points, target, |e| e.rel_mse)
}

/// [`time_to_reach`] by another measure of the error (e.g. `|e| e.flip`).
pub fn time_to_reach_by(
    points: &[ConvergencePoint],
    target: f64,
    metric: impl Fn(&ImageDifference) -> f64,
) -> TimeToReach {
    let Some(i) = points.iter().position(|m| metric(&m.error) <= target) else {
        return TimeToReach::NotReached { max_spp: points.last().map_or(0, |m| m.spp) };
    };
    let b = &points[i];
    if i == 0 {
        return TimeToReach::AtFirst { spp: b.spp, seconds: b.seconds };
    }
    let a = &points[i - 1];
    let (ea, eb) = (metric(&a.error), metric(&b.error));
    if eb <= 0.0 || ea <= eb || a.seconds <= 0.0 || b.seconds <= 0.0 {
        return TimeToReach::Interpolated { spp: b.spp as f64, seconds: b.seconds };
    }
    let f = (target.ln() - ea.ln()) / (eb.ln() - ea.ln());
    let lerp = |x0: f64, x1: f64| (x0.ln() + f * (x1.ln() - x0.ln())).exp();
    TimeToReach::Interpolated { spp: lerp(a.spp as f64, b.spp as f64), seconds: lerp(a.seconds, b.seconds) }
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

#[cfg(test)]
mod tests {
    use super::*;

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
        let pts: Vec<ConvergencePoint> =
            [1, 2, 8, 32].iter().map(|&s| ConvergencePoint::nee_mis(s, 0.01 * s as f64, 0.16 / s as f64)).collect();
        let TimeToReach::Interpolated { spp, seconds } = time_to_reach(&pts, 0.01) else { panic!() };
        assert!((spp - 16.0).abs() < 1e-9 && (seconds - 0.16).abs() < 1e-12, "{spp} {seconds}");
        assert_eq!(time_to_reach(&pts, 0.5), TimeToReach::AtFirst { spp: 1, seconds: 0.01 });
        assert_eq!(time_to_reach(&pts, 0.001), TimeToReach::NotReached { max_spp: 32 });
    }
}

//! The terminal progress bar of a render, fed by the renderer's progress reports: it counts
//! samples, and its time left is this session's time per sample times the samples left
//! ([`estimate`]). That tells the truth because the renderer takes its tiles in a shuffled
//! order (`integrator::tile_order`): the share of samples done follows the share of time
//! spent, where row by row the cheap tiles of a sky came first (32% at 1 s of a 12 s render,
//! "ETA 2s" with 8 s to go). Drawn only when stderr is a terminal.

use crate::integrator::Progress;
use std::io::IsTerminal;
use std::sync::Mutex;
use std::time::Duration;

/// What a bar shows of one progress report.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    /// Share of the planned samples done, in [0, 1].
    pub fraction: f64,
    /// Time left: the samples left at this session's time per sample; `None` before this
    /// session has taken any.
    pub remaining: Option<Duration>,
}

/// The [`Estimate`] of report `p`: samples of earlier sessions count as done but not in the
/// rate (they took no time in this one).
pub fn estimate(p: &Progress) -> Estimate {
    let planned = p.samples_planned.max(1);
    let done = p.samples_done.min(planned);
    let this_session = done.saturating_sub(p.samples_before);
    let secs = p.elapsed.as_secs_f64();
    let remaining = (this_session > 0 && secs > 0.0)
        .then(|| Duration::from_secs_f64(secs * (planned - done) as f64 / this_session as f64));
    Estimate { fraction: done as f64 / planned as f64, remaining }
}

/// `7s`, `2m05s`, `1h02m`.
fn short_duration(d: Duration) -> String {
    let s = d.as_secs_f64().round() as u64;
    match s {
        0..60 => format!("{s}s"),
        60..3600 => format!("{}m{:02}s", s / 60, s % 60),
        _ => format!("{}h{:02}m", s / 3600, s / 60 % 60),
    }
}

/// A bar on stderr, or nothing when stderr is not a terminal.
pub struct ProgressBar(Option<(indicatif::ProgressBar, Mutex<Option<Progress>>)>);

impl ProgressBar {
    /// A bar labelled `label` (e.g. `reference`), or none if stderr is not a terminal.
    pub fn new(label: &str) -> ProgressBar {
        if !std::io::stderr().is_terminal() {
            return ProgressBar(None);
        }
        let bar = indicatif::ProgressBar::new(1);
        let template = format!("{label}{{bar:40.cyan/blue}} {{percent:>3}}% samples  {{msg}}");
        bar.set_style(
            indicatif::ProgressStyle::with_template(&template)
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        ProgressBar(Some((bar, Mutex::new(None))))
    }

    /// Shows a progress report. Reports come from several worker threads and may arrive out of
    /// order: one older than the last shown (an earlier round, or fewer samples) is dropped,
    /// so the bar never goes back.
    pub fn update(&self, p: Progress) {
        let Some((bar, last)) = &self.0 else { return };
        let mut last = last.lock().unwrap_or_else(|e| e.into_inner());
        if last.is_some_and(|l| (l.round, l.samples_done) > (p.round, p.samples_done)) {
            return;
        }
        *last = Some(p);
        let e = estimate(&p);
        bar.set_length(p.samples_planned.max(1));
        bar.set_position(p.samples_done.min(p.samples_planned));
        let eta = e.remaining.map_or("-".into(), short_duration);
        let rate = p.rays as f64 / p.elapsed.as_secs_f64().max(1e-9) / 1e6;
        let round = if p.rounds > 1 { format!("  round {}/{}", p.round, p.rounds) } else { String::new() };
        bar.set_message(format!("ETA {eta}{round}  {rate:.1} Mrays/s"));
    }

    /// Removes the bar.
    pub fn finish(&self) {
        if let Some((bar, _)) = &self.0 {
            bar.finish_and_clear();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrator::tile_order;

    fn report(done: u64, before: u64, planned: u64, secs: f64) -> Progress {
        Progress {
            samples_done: done,
            samples_before: before,
            samples_planned: planned,
            rays: 0,
            elapsed: Duration::from_secs_f64(secs),
            round: 1,
            rounds: 1,
        }
    }

    #[test]
    fn time_left_is_the_samples_left_at_this_sessions_rate() {
        let e = estimate(&report(250, 0, 1000, 3.0));
        assert_eq!(e.fraction, 0.25);
        assert!((e.remaining.unwrap().as_secs_f64() - 9.0).abs() < 1e-9);
        // Resumed at 500 of 1000: 100 more in 2 s, so 400 left take 8 s.
        let e = estimate(&report(600, 500, 1000, 2.0));
        assert_eq!(e.fraction, 0.6);
        assert!((e.remaining.unwrap().as_secs_f64() - 8.0).abs() < 1e-9);
        // Nothing taken yet in this session: no guess.
        assert_eq!(estimate(&report(500, 500, 1000, 2.0)).remaining, None);
        assert_eq!(estimate(&report(0, 0, 1000, 0.0)).remaining, None);
        assert_eq!(estimate(&report(1000, 0, 1000, 4.0)).remaining, Some(Duration::ZERO));
    }

    #[test]
    fn durations_are_short() {
        assert_eq!(short_duration(Duration::from_secs_f64(7.4)), "7s");
        assert_eq!(short_duration(Duration::from_secs(125)), "2m05s");
        assert_eq!(short_duration(Duration::from_secs(3720)), "1h02m");
    }

    /// Replays a render of a 640×400 image on 2 workers taking tiles in `order`, where the top
    /// 40% of tile rows (a sky) costs 1/20 of the rest, and returns each report as a worker
    /// finishes a tile, with the render's total time.
    fn synthetic_render(order: &[(u32, u32)]) -> (Vec<Progress>, f64) {
        let rows = 400u32.div_ceil(16);
        let cost = |ty: u32| if ty < rows * 2 / 5 { 0.05 } else { 1.0 };
        let samples_per_tile = 16 * 16 * 64;
        let mut free = [0.0f64; 2];
        let mut finishes: Vec<f64> = order
            .iter()
            .map(|&(_, ty)| {
                let w = if free[0] <= free[1] { 0 } else { 1 };
                free[w] += cost(ty);
                free[w]
            })
            .collect();
        finishes.sort_by(f64::total_cmp);
        let planned = order.len() as u64 * samples_per_tile;
        let reports = finishes
            .iter()
            .enumerate()
            .map(|(i, &t)| report((i as u64 + 1) * samples_per_tile, 0, planned, t))
            .collect();
        (reports, free[0].max(free[1]))
    }

    /// The largest gap between the share of samples done and the share of time spent, and
    /// between the time left estimated and the true one (as a share of the whole render), over
    /// the reports after the first 5% of the time.
    fn worst_errors(reports: &[Progress], total: f64) -> (f64, f64) {
        let mut worst = (0.0f64, 0.0f64);
        for p in reports.iter().filter(|p| p.elapsed.as_secs_f64() >= 0.05 * total) {
            let t = p.elapsed.as_secs_f64();
            let e = estimate(p);
            worst.0 = worst.0.max((e.fraction - t / total).abs());
            worst.1 = worst.1.max((e.remaining.unwrap().as_secs_f64() - (total - t)).abs() / total);
        }
        worst
    }

    #[test]
    fn the_bar_and_eta_follow_time_when_cheap_sky_tiles_are_on_top() {
        let (reports, total) = synthetic_render(&tile_order(640, 400));
        let (fraction, eta) = worst_errors(&reports, total);
        eprintln!("shuffled tiles: fraction off by {fraction:.3} at worst, time left by {eta:.3}");
        assert!(fraction < 0.08, "samples done are {fraction:.3} of the render away from the time spent");
        assert!(eta < 0.15, "time left off by {eta:.3} of the render");

        // Row by row (as before), the same render reads far ahead of the time: the bug.
        let rows: Vec<(u32, u32)> = (0..25).flat_map(|ty| (0..40).map(move |tx| (tx, ty))).collect();
        let (reports, total) = synthetic_render(&rows);
        let (fraction, eta) = worst_errors(&reports, total);
        eprintln!("row order: fraction off by {fraction:.3} at worst, time left by {eta:.3}");
        assert!(fraction > 0.3 && eta > 0.3, "row order: {fraction:.3}, {eta:.3}");
    }

    #[test]
    fn tile_order_is_every_tile_once() {
        let mut tiles = tile_order(650, 400);
        assert_eq!(tiles.len(), 41 * 25);
        assert_eq!(tiles, tile_order(650, 400));
        tiles.sort();
        tiles.dedup();
        assert_eq!(tiles.len(), 41 * 25);
        assert!(tiles.iter().all(|&(x, y)| x < 41 && y < 25));
    }
}

//! The terminal progress bar of a render, fed by the renderer's progress reports: it shows the
//! share of the render's work done, and its time left is this session's time per unit of work
//! times the work left ([`estimate`]). Both follow the time spent because the renderer counts
//! work as time goes (`integrator::Progress`): its tiles are taken in a shuffled order
//! (`integrator::tile_order`), so the samples done are a fair share of the image whatever the
//! cost of its parts; an adaptive render's whole budget is planned from the start, and the
//! second round's samples weigh what their pixels cost. Drawn only when stderr is a terminal.

use crate::integrator::Progress;
use std::io::IsTerminal;
use std::sync::Mutex;
use std::time::Duration;

/// What a bar shows of one progress report.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    /// Share of the planned work done, in [0, 1].
    pub fraction: f64,
    /// Time left: the work left at this session's time per unit of work; `None` before this
    /// session has done any.
    pub remaining: Option<Duration>,
}

/// The [`Estimate`] of report `p`: work of earlier sessions counts as done but not in the
/// rate (it took no time in this one). While the caustics' light paths are traced no pixel
/// work is done: 0, time left unknown.
pub fn estimate(p: &Progress) -> Estimate {
    if p.light_paths.is_some() {
        return Estimate { fraction: 0.0, remaining: None };
    }
    if p.work_planned <= 0.0 {
        return Estimate { fraction: 1.0, remaining: Some(Duration::ZERO) };
    }
    let planned = p.work_planned;
    let done = p.work_done.clamp(0.0, planned);
    let this_session = done - p.work_before;
    let secs = p.elapsed.as_secs_f64();
    let remaining = (this_session > 0.0 && secs > 0.0)
        .then(|| Duration::from_secs_f64((secs * (planned - done) / this_session).min(1e9)));
    Estimate { fraction: done / planned, remaining }
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

/// The bar's resolution.
const STEPS: u64 = 1000;

/// A bar on stderr (none when stderr is not a terminal), and the last report either way.
pub struct ProgressBar {
    bar: Option<indicatif::ProgressBar>,
    last: Mutex<Option<Progress>>,
}

impl ProgressBar {
    /// A bar labelled `label` (e.g. `reference`), drawn if stderr is a terminal.
    pub fn new(label: &str) -> ProgressBar {
        let bar = std::io::stderr().is_terminal().then(|| {
            let bar = indicatif::ProgressBar::new(STEPS);
            let template = format!("{label}{{bar:40.cyan/blue}} {{percent:>3}}%  {{msg}}");
            bar.set_style(
                indicatif::ProgressStyle::with_template(&template)
                    .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
            );
            bar
        });
        ProgressBar { bar, last: Mutex::new(None) }
    }

    /// Shows a progress report. Reports come from several worker threads and may arrive out of
    /// order: one older than the last shown (an earlier round, or less work) is dropped, so
    /// the bar never goes back.
    pub fn update(&self, p: Progress) {
        let mut last = self.last.lock().unwrap_or_else(|e| e.into_inner());
        let order = |p: &Progress| (p.round, p.work_done, p.light_paths.map_or(0, |(traced, _)| traced));
        if last.is_some_and(|l| order(&l) > order(&p)) {
            return;
        }
        *last = Some(p);
        let Some(bar) = &self.bar else { return };
        let rate = p.rays as f64 / p.elapsed.as_secs_f64().max(1e-9) / 1e6;
        if let Some((traced, planned)) = p.light_paths {
            let percent = 100.0 * traced as f64 / planned.max(1) as f64;
            bar.set_message(format!("caustic light paths {percent:.0}%  {rate:.1} Mrays/s"));
            return;
        }
        let e = estimate(&p);
        // Never back: a new plan may find a little more or less work than the budget.
        bar.set_position(((e.fraction * STEPS as f64) as u64).max(bar.position()));
        let eta = e.remaining.map_or("-".into(), short_duration);
        let round = if p.rounds > 1 { format!("  round {}/{}", p.round, p.rounds) } else { String::new() };
        bar.set_message(format!("ETA {eta}{round}  {rate:.1} Mrays/s"));
    }

    /// The share of the work done at the last report, if there was one: what the bar shows.
    pub fn fraction(&self) -> Option<f64> {
        self.last.lock().unwrap_or_else(|e| e.into_inner()).as_ref().map(|p| estimate(p).fraction)
    }

    /// Removes the bar.
    pub fn finish(&self) {
        if let Some(bar) = &self.bar {
            bar.finish_and_clear();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::{AdaptivePixel, PixelState};
    use crate::integrator::{adaptive, tile_order};
    use crate::settings::TILE;

    fn report(done: f64, before: f64, planned: f64, secs: f64) -> Progress {
        Progress {
            work_done: done,
            work_before: before,
            work_planned: planned,
            rays: 0,
            elapsed: Duration::from_secs_f64(secs),
            round: 1,
            rounds: 1,
            light_paths: None,
        }
    }

    #[test]
    fn the_light_paths_come_before_any_pixel_work() {
        // While the caustics' light paths are traced nothing of the pixels is done, and the
        // time left is unknown: the bar stays at 0 and says how far the light paths are.
        let light = Progress { round: 0, light_paths: Some((4096, 12288)), ..report(0.0, 0.0, 0.0, 2.0) };
        assert_eq!(estimate(&light), Estimate { fraction: 0.0, remaining: None });
        let bar = ProgressBar::new("");
        bar.update(light);
        assert_eq!(bar.fraction(), Some(0.0));
        // The first pixels' report follows; a late light-path report does not undo it.
        bar.update(report(10.0, 0.0, 100.0, 3.0));
        bar.update(Progress { light_paths: Some((8192, 12288)), ..light });
        assert_eq!(bar.fraction(), Some(0.1));
    }

    #[test]
    fn time_left_is_the_work_left_at_this_sessions_rate() {
        let e = estimate(&report(250.0, 0.0, 1000.0, 3.0));
        assert_eq!(e.fraction, 0.25);
        assert!((e.remaining.unwrap().as_secs_f64() - 9.0).abs() < 1e-9);
        // Resumed at 500 of 1000: 100 more in 2 s, so 400 left take 8 s.
        let e = estimate(&report(600.0, 500.0, 1000.0, 2.0));
        assert_eq!(e.fraction, 0.6);
        assert!((e.remaining.unwrap().as_secs_f64() - 8.0).abs() < 1e-9);
        // Nothing done yet in this session: no guess.
        assert_eq!(estimate(&report(500.0, 500.0, 1000.0, 2.0)).remaining, None);
        assert_eq!(estimate(&report(0.0, 0.0, 1000.0, 0.0)).remaining, None);
        assert_eq!(estimate(&report(1000.0, 0.0, 1000.0, 4.0)).remaining, Some(Duration::ZERO));
        // Nothing to do (every pixel was already done): finished.
        assert_eq!(estimate(&report(0.0, 0.0, 0.0, 0.0)).fraction, 1.0);
    }

    #[test]
    fn durations_are_short() {
        assert_eq!(short_duration(Duration::from_secs_f64(7.4)), "7s");
        assert_eq!(short_duration(Duration::from_secs(125)), "2m05s");
        assert_eq!(short_duration(Duration::from_secs(3720)), "1h02m");
    }

    /// A synthetic 320×208 image: the top 40% of rows a sky whose samples trace 1 ray (cheap,
    /// and quiet), the rest an object whose samples trace 12 (its left half noisy, its right
    /// half less so). A sample's time is its rays × 1 ms.
    struct Synthetic {
        w: u32,
        h: u32,
        rays_per_sample: Vec<u32>,
        noise: Vec<f32>,
    }

    impl Synthetic {
        fn new() -> Synthetic {
            let (w, h) = (320u32, 208u32);
            let sky = |y: u32| y < h * 2 / 5;
            let pixels = (0..w * h).map(|i| (i % w, i / w));
            let rays_per_sample = pixels.clone().map(|(_, y)| if sky(y) { 1 } else { 12 }).collect();
            let noise = pixels
                .map(|(x, y)| {
                    if sky(y) {
                        0.01
                    } else if x < w / 2 {
                        0.4
                    } else {
                        0.1
                    }
                })
                .collect();
            Synthetic { w, h, rays_per_sample, noise }
        }
    }

    /// One tile's samples finishing: (time, the report the renderer sends).
    type Reports = Vec<Progress>;

    /// Replays an adaptive render of `image` at mean `spp` on 2 workers taking tiles in the
    /// renderer's order, round by round, and returns a report per finished tile (work counted
    /// as `integrator::Progress` says, or, with `by_samples`, as plain samples, planned
    /// to the end of the current round) and the render's total time.
    fn adaptive_render(image: &Synthetic, spp: u32, by_samples: bool) -> (Reports, f64) {
        let (w, h) = (image.w, image.h);
        let n = (w * h) as usize;
        let first = adaptive::first_round_spp(spp);
        // The first round: `first` samples alternating around 0.5 by each pixel's noise.
        let mut states = vec![PixelState::default(); n];
        let mut plan = vec![AdaptivePixel::default(); n];
        for i in 0..n {
            for k in 0..first {
                let v = 0.5 + if k % 2 == 0 { image.noise[i] } else { -image.noise[i] };
                states[i].add(glam::Vec3::splat(v));
                plan[i].sum_sq += glam::DVec3::splat((v * v) as f64);
            }
            plan[i].rays = image.rays_per_sample[i] * first;
        }
        let targets = adaptive::allocate(&states, &plan, w, h, spp);
        for (p, t) in plan.iter_mut().zip(&targets) {
            p.target = *t;
        }
        let costs = adaptive::sample_costs(&plan, first, |_| true);
        let tiles = tile_order(w, h);
        let pixels_of = |(tx, ty): (u32, u32)| {
            (ty * TILE..((ty + 1) * TILE).min(h))
                .flat_map(move |y| (tx * TILE..((tx + 1) * TILE).min(w)).map(move |x| (y * w + x) as usize))
        };
        let mut free = [0.0f64; 2];
        let mut reports = Vec::new();
        let mut done = 0.0;
        for round in 0..2 {
            let planned = match (by_samples, round) {
                (true, 0) => (n as u32 * first) as f64,
                (true, _) => targets.iter().map(|&t| t as f64).sum(),
                (false, 0) => n as f64 * spp as f64,
                (false, _) => (0..n).map(|i| adaptive::work(targets[i], first, costs[i])).sum(),
            };
            let start = free[0].max(free[1]);
            free = [start; 2];
            let mut finished: Vec<(f64, f64)> = tiles
                .iter()
                .map(|&tile| {
                    let (mut secs, mut work) = (0.0, 0.0);
                    for i in pixels_of(tile) {
                        let (from, to) = if round == 0 { (0, first) } else { (first, targets[i]) };
                        secs += (to - from) as f64 * image.rays_per_sample[i] as f64 * 1e-3;
                        work += if by_samples {
                            (to - from) as f64
                        } else {
                            adaptive::work(to, first, costs[i]) - adaptive::work(from, first, costs[i])
                        };
                    }
                    let worker = if free[0] <= free[1] { 0 } else { 1 };
                    free[worker] += secs;
                    (free[worker], work)
                })
                .collect();
            finished.sort_by(|a, b| a.0.total_cmp(&b.0));
            for (t, work) in finished {
                done += work;
                reports.push(Progress { round: round + 1, rounds: 2, ..report(done, 0.0, planned, t) });
            }
        }
        (reports, free[0].max(free[1]))
    }

    /// Replays a uniform render of a 640×400 image on 2 workers taking tiles in `order`, where
    /// the top 40% of tile rows (a sky) costs 1/20 of the rest, and returns each report as a
    /// worker finishes a tile, with the render's total time.
    fn uniform_render(order: &[(u32, u32)]) -> (Reports, f64) {
        let rows = 400u32.div_ceil(16);
        let cost = |ty: u32| if ty < rows * 2 / 5 { 0.05 } else { 1.0 };
        let samples_per_tile = (16 * 16 * 64) as f64;
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
        let planned = order.len() as f64 * samples_per_tile;
        let reports = finishes
            .iter()
            .enumerate()
            .map(|(i, &t)| report((i + 1) as f64 * samples_per_tile, 0.0, planned, t))
            .collect();
        (reports, free[0].max(free[1]))
    }

    /// The largest gap between the share of work done and the share of time spent, and
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
        let (reports, total) = uniform_render(&tile_order(640, 400));
        let (fraction, eta) = worst_errors(&reports, total);
        eprintln!("shuffled tiles: fraction off by {fraction:.3} at worst, time left by {eta:.3}");
        assert!(fraction < 0.08, "work done is {fraction:.3} of the render away from the time spent");
        assert!(eta < 0.15, "time left off by {eta:.3} of the render");

        // Row by row, the same render reads far ahead of the time.
        let rows: Vec<(u32, u32)> = (0..25).flat_map(|ty| (0..40).map(move |tx| (tx, ty))).collect();
        let (reports, total) = uniform_render(&rows);
        let (fraction, eta) = worst_errors(&reports, total);
        eprintln!("row order: fraction off by {fraction:.3} at worst, time left by {eta:.3}");
        assert!(fraction > 0.3 && eta > 0.3, "row order: {fraction:.3}, {eta:.3}");
    }

    #[test]
    fn the_bar_and_eta_follow_time_through_both_rounds_of_an_adaptive_render() {
        let image = Synthetic::new();
        let (reports, total) = adaptive_render(&image, 64, false);
        let (fraction, eta) = worst_errors(&reports, total);
        let end_of_first = reports.iter().rfind(|p| p.round == 1).unwrap();
        let t1 = end_of_first.elapsed.as_secs_f64() / total;
        eprintln!(
            "adaptive: fraction off by {fraction:.3} at worst, time left by {eta:.3}; the first round ends at \
             {:.3} of the work, {t1:.3} of the time",
            estimate(end_of_first).fraction
        );
        assert!(fraction < 0.1, "work done is {fraction:.3} of the render away from the time spent");
        assert!(eta < 0.1, "time left off by {eta:.3} of the render");
        // Never 100% before the end.
        assert!(reports[..reports.len() - 1].iter().all(|p| estimate(p).fraction < 0.999));
        assert!((estimate(reports.last().unwrap()).fraction - 1.0).abs() < 1e-9);

        // Counted in samples, each round planned on its own, it would read 100% at
        // the end of the first round, then drops.
        let (reports, total) = adaptive_render(&image, 64, true);
        let end_of_first = reports.iter().rfind(|p| p.round == 1).unwrap();
        assert_eq!(estimate(end_of_first).fraction, 1.0);
        let (fraction, _) = worst_errors(&reports, total);
        assert!(fraction > 0.5, "by samples: {fraction:.3}");
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

//! The path tracer against raw Embree: how much of Embree's ray throughput survives shading
//! (the path tracer's rays/s over Embree's rays/s on the very rays the path tracer traced),
//! and how samples/s scale from one thread to two.
//!
//! The path tracer renders the scene with identical settings through a recording wrapper
//! (every intersect/occluded query kept, in each worker's order), then timed with 1 and with 2
//! threads. Rendering is deterministic, so the timed renders trace exactly
//! the recorded rays; the recorded queries are then replayed through the same Embree scene
//! (one `rtcIntersect1`/`rtcOccluded1` each, via ember's safe wrapper) on 2 threads.

use super::BenchError;
use super::cputime::cpu_of;
use super::measure::{Times, Timing};
use super::record::{RecordedQuery, RecordingAccel, replay};
use crate::accel::EmbreeAccel;
use crate::embree::{BuildOptions, Device};
use crate::integrator::{RenderSettings, render};
use crate::report::Table;
use crate::scene::Scene;
use std::path::Path;
use std::time::{Duration, Instant};

/// Image size and repetition of the render measurements.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderConfig {
    /// Image width; the height follows the scene's aspect.
    pub width: u32,
    pub spp: u32,
    pub timing: Timing,
}

impl RenderConfig {
    pub fn full() -> Self {
        RenderConfig { width: 128, spp: 16, timing: Timing { min_passes: 3, min_total: Duration::from_millis(500) } }
    }

    pub fn quick() -> Self {
        RenderConfig { width: 48, spp: 2, timing: Timing { min_passes: 1, min_total: Duration::ZERO } }
    }

    /// Settings for `scene`: its own depth, Russian roulette and seed, the configured size.
    pub fn settings(&self, scene: &Scene, threads: Option<usize>) -> RenderSettings {
        let s = RenderSettings::from_scene(&scene.render);
        let height = ((self.width as u64 * s.height as u64) / s.width.max(1) as u64).max(1) as u32;
        RenderSettings { width: self.width, height, spp: self.spp, threads, progress: false, ..s }
    }
}

/// What was measured on one scene.
#[derive(Clone, Debug)]
pub struct RenderMeasurement {
    pub scene: String,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub samples: u64,
    /// Rays the path tracer counted.
    pub rays: u64,
    pub closest_queries: usize,
    pub occlusion_queries: usize,
    /// Best render times with 1 and 2 threads.
    pub one_thread: Duration,
    pub two_threads: Duration,
    /// CPU time of the best 2-thread render (least over the renders).
    pub two_threads_cpu: Option<Duration>,
    /// Best replay of the recorded queries on 2 threads, and its CPU time.
    pub replay: Duration,
    pub replay_cpu: Option<Duration>,
}

impl RenderMeasurement {
    pub fn recorded(&self) -> usize {
        self.closest_queries + self.occlusion_queries
    }

    pub fn samples_per_s(&self, threads: usize) -> f64 {
        let t = if threads == 1 { self.one_thread } else { self.two_threads };
        self.samples as f64 / t.as_secs_f64().max(1e-12)
    }

    /// Samples/s with 2 threads over 1.
    pub fn thread_scaling(&self) -> f64 {
        self.one_thread.as_secs_f64() / self.two_threads.as_secs_f64().max(1e-12)
    }

    pub fn path_tracer_mrays_per_s(&self) -> f64 {
        self.rays as f64 / self.two_threads.as_secs_f64().max(1e-12) / 1e6
    }

    pub fn embree_mrays_per_s(&self) -> f64 {
        self.recorded() as f64 / self.replay.as_secs_f64().max(1e-12) / 1e6
    }

    /// The path tracer's rays/s as a percentage of Embree's on the same rays (wall time).
    pub fn efficiency_percent(&self) -> f64 {
        100.0 * self.path_tracer_mrays_per_s() / self.embree_mrays_per_s()
    }

    /// The same from CPU time (the same rays, so Embree's CPU time over the path tracer's):
    /// less sensitive to other work on the machine.
    pub fn cpu_efficiency_percent(&self) -> Option<f64> {
        Some(100.0 * self.replay_cpu?.as_secs_f64() / self.two_threads_cpu?.as_secs_f64().max(1e-12))
    }
}

/// Best of repeated `f` runs by wall time (each returning its own wall time), with the
/// least CPU time of the pool's threads over the runs.
fn best_of<T>(
    timing: Timing,
    mut f: impl FnMut() -> Result<(T, Duration), BenchError>,
) -> Result<(T, Times), BenchError> {
    let (mut best, mut times, mut total, mut passes) =
        (None::<T>, Times { wall: Duration::MAX, cpu: None }, Duration::ZERO, 0);
    while passes < timing.min_passes.max(1) || total < timing.min_total {
        let (r, cpu) = cpu_of(&mut f);
        let (value, wall) = r?;
        total += wall;
        passes += 1;
        if wall < times.wall {
            times.wall = wall;
            best = Some(value);
        }
        times.cpu = match (times.cpu, cpu) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        };
    }
    Ok((best.expect("at least one pass"), times))
}

fn pool(threads: usize) -> Result<rayon::ThreadPool, BenchError> {
    rayon::ThreadPoolBuilder::new().num_threads(threads).build().map_err(|e| BenchError::Invalid(e.to_string()))
}

/// Measures one scene file. Everything runs in thread pools made here (renders with
/// `threads: None` use the pool they run in), so their threads live through each measurement
/// and their CPU time can be read.
pub fn measure_scene(path: &Path, device: &Device, cfg: &RenderConfig) -> Result<RenderMeasurement, BenchError> {
    let scene = Scene::load(path)?;
    let accel = EmbreeAccel::new(device, &scene.geometry, BuildOptions::default())?;
    let settings = cfg.settings(&scene, None);
    let (one, two) = (pool(1)?, pool(2)?);

    let recorder = RecordingAccel::new(&accel, 2);
    let (_, recorded_stats) = two.install(|| render(&scene, &recorder, &settings))?;
    let queries: Vec<RecordedQuery> = recorder.into_queries();
    if queries.len() as u64 != recorded_stats.rays {
        return Err(BenchError::Invalid(format!(
            "{}: the path tracer counted {} rays but made {} queries",
            path.display(),
            recorded_stats.rays,
            queries.len()
        )));
    }

    let timed_render = |p: &rayon::ThreadPool| {
        p.install(|| {
            best_of(cfg.timing, || {
                let (_, stats) = render(&scene, &accel, &settings)?;
                Ok((stats, stats.elapsed))
            })
        })
    };
    let (stats1, t1) = timed_render(&one)?;
    let (stats2, t2) = timed_render(&two)?;
    if stats1.rays != stats2.rays || stats2.rays != recorded_stats.rays {
        return Err(BenchError::Invalid(format!(
            "{}: renders with the same settings traced {} / {} / {} rays",
            path.display(),
            recorded_stats.rays,
            stats1.rays,
            stats2.rays
        )));
    }

    let ((), replay_times) = two.install(|| {
        best_of(cfg.timing, || {
            let start = Instant::now();
            std::hint::black_box(replay(&accel, &queries)?);
            Ok(((), start.elapsed()))
        })
    })?;

    let occlusion_queries = queries.iter().filter(|q| q.occlusion).count();
    let name = path.file_name().map_or(path.display().to_string(), |n| n.to_string_lossy().into_owned());
    Ok(RenderMeasurement {
        scene: name,
        width: settings.width,
        height: settings.height,
        spp: settings.spp,
        samples: stats2.samples,
        rays: stats2.rays,
        closest_queries: queries.len() - occlusion_queries,
        occlusion_queries,
        one_thread: t1.wall,
        two_threads: t2.wall,
        two_threads_cpu: t2.cpu,
        replay: replay_times.wall,
        replay_cpu: replay_times.cpu,
    })
}

/// The terminal table.
pub fn summary_table(ms: &[RenderMeasurement]) -> Table {
    let mut t = Table::new([
        "scene",
        "image",
        "rays (closest+shadow)",
        "1-thread samples/s",
        "2-thread samples/s",
        "2t/1t",
        "path tracer Mrays/s",
        "Embree alone Mrays/s",
        "path tracer/Embree",
        "same, CPU time",
    ]);
    for m in ms {
        t.push([
            m.scene.clone(),
            format!("{}x{}x{}", m.width, m.height, m.spp),
            format!("{}+{}", m.closest_queries, m.occlusion_queries),
            format!("{:.0}", m.samples_per_s(1)),
            format!("{:.0}", m.samples_per_s(2)),
            format!("{:.2}×", m.thread_scaling()),
            format!("{:.2}", m.path_tracer_mrays_per_s()),
            format!("{:.2}", m.embree_mrays_per_s()),
            format!("{:.0}%", m.efficiency_percent()),
            m.cpu_efficiency_percent().map_or("-".into(), |p| format!("{p:.0}%")),
        ]);
    }
    t
}

/// Column names of render.csv.
pub const CSV_COLUMNS: [&str; 19] = [
    "scene",
    "width",
    "height",
    "spp",
    "samples",
    "rays",
    "closest_queries",
    "occlusion_queries",
    "one_thread_s",
    "two_threads_s",
    "samples_per_s_1t",
    "samples_per_s_2t",
    "thread_scaling",
    "path_tracer_mrays_per_s_2t",
    "embree_replay_mrays_per_s_2t",
    "path_tracer_percent_of_embree",
    "two_threads_cpu_s",
    "replay_cpu_s",
    "path_tracer_percent_of_embree_cpu",
];

pub fn csv_table(ms: &[RenderMeasurement]) -> Table {
    let mut t = Table::new(CSV_COLUMNS);
    for m in ms {
        t.push([
            m.scene.clone(),
            m.width.to_string(),
            m.height.to_string(),
            m.spp.to_string(),
            m.samples.to_string(),
            m.rays.to_string(),
            m.closest_queries.to_string(),
            m.occlusion_queries.to_string(),
            format!("{:.6}", m.one_thread.as_secs_f64()),
            format!("{:.6}", m.two_threads.as_secs_f64()),
            format!("{:.1}", m.samples_per_s(1)),
            format!("{:.1}", m.samples_per_s(2)),
            format!("{:.3}", m.thread_scaling()),
            format!("{:.3}", m.path_tracer_mrays_per_s()),
            format!("{:.3}", m.embree_mrays_per_s()),
            format!("{:.1}", m.efficiency_percent()),
            m.two_threads_cpu.map_or(String::new(), |c| format!("{:.6}", c.as_secs_f64())),
            m.replay_cpu.map_or(String::new(), |c| format!("{:.6}", c.as_secs_f64())),
            m.cpu_efficiency_percent().map_or(String::new(), |p| format!("{p:.1}")),
        ]);
    }
    t
}

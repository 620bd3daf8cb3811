//! The path tracer against raw Embree: how much of Embree's ray throughput survives shading
//! (the path tracer's rays/s over Embree's rays/s on the very rays the path tracer traced),
//! and how samples/s scale from one thread to two.
//!
//! The path tracer renders the scene with identical settings through a recording wrapper
//! (every intersect/occluded query kept, in each worker's order), then timed with 1 and with 2
//! threads. Rendering is deterministic, so the timed renders trace exactly
//! the recorded rays; the recorded queries are then replayed through the same Embree scene
//! on 2 threads as the path tracer traced them (camera rays 8 at a time with `rtcIntersect8`,
//! every other ray with `rtcIntersect1`/`rtcOccluded1`, via ember's safe wrapper).

use super::BenchError;
use super::cputime::cpu_of;
use super::measure::{Timing, median};
use super::record::{RecordedQuery, RecordingAccel, replay, replay_chunks};
use super::run::RenderBvh;
use crate::accel::EmbreeAccel;
use crate::embree::{BuildOptions, Device};
use crate::integrator::{RenderPlan, RenderSettings, render};
use crate::scene::Scene;
use crate::settings::PathLoop;
use crate::tools::report::Table;
use std::path::Path;
use std::time::{Duration, Instant};

/// Image size and repetition of the render measurements.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderConfig {
    /// Image width; the height follows the scene's aspect.
    pub width: u32,
    pub spp: u32,
    pub timing: Timing,
    /// How the renders advance their paths.
    pub path_loop: PathLoop,
}

impl RenderConfig {
    pub fn full() -> Self {
        RenderConfig {
            width: 128,
            spp: 16,
            timing: Timing { min_passes: 9, min_total: Duration::from_secs(2) },
            path_loop: PathLoop::Scalar,
        }
    }

    pub fn quick() -> Self {
        RenderConfig {
            width: 48,
            spp: 2,
            timing: Timing { min_passes: 1, min_total: Duration::ZERO },
            path_loop: PathLoop::Scalar,
        }
    }

    /// Settings for `scene`: its own depth, Russian roulette and seed, the configured size and
    /// path loop.
    pub fn settings(&self, scene: &Scene, threads: Option<usize>) -> RenderSettings {
        let s = RenderSettings::from_scene(&scene.render);
        let height = ((self.width as u64 * s.height as u64) / s.width.max(1) as u64).max(1) as u32;
        RenderSettings { width: self.width, height, spp: self.spp, threads, path_loop: self.path_loop, ..s }
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
    /// The BVH the renders and the replay were built with.
    pub bvh: BuildOptions,
    /// The path loop of the renders.
    pub path_loop: PathLoop,
    /// The rounds measured, in order.
    pub rounds: Vec<Round>,
}

/// One round of measurements, taken back to back: a render on 1 thread, the same render on 2
/// threads, and the replay of its queries through Embree alone on 2 threads. A change in the
/// machine's load then touches all three alike, and each ratio is taken within a round.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Round {
    pub one_thread: Duration,
    pub two_threads: Duration,
    /// CPU time of all threads of the 2-thread render and of the replay, where it can be read.
    pub two_threads_cpu: Option<Duration>,
    pub replay: Duration,
    pub replay_cpu: Option<Duration>,
}

impl RenderMeasurement {
    pub fn recorded(&self) -> usize {
        self.closest_queries + self.occlusion_queries
    }

    fn fastest(&self, time: impl Fn(&Round) -> Duration) -> Duration {
        self.rounds.iter().map(time).min().unwrap_or(Duration::MAX)
    }

    /// Fastest render on 1 and on 2 threads, and fastest replay (wall time).
    pub fn one_thread(&self) -> Duration {
        self.fastest(|r| r.one_thread)
    }

    pub fn two_threads(&self) -> Duration {
        self.fastest(|r| r.two_threads)
    }

    pub fn replay(&self) -> Duration {
        self.fastest(|r| r.replay)
    }

    /// Least CPU time of a 2-thread render and of a replay.
    pub fn two_threads_cpu(&self) -> Option<Duration> {
        self.rounds.iter().filter_map(|r| r.two_threads_cpu).min()
    }

    pub fn replay_cpu(&self) -> Option<Duration> {
        self.rounds.iter().filter_map(|r| r.replay_cpu).min()
    }

    pub fn samples_per_s(&self, threads: usize) -> f64 {
        let t = if threads == 1 { self.one_thread() } else { self.two_threads() };
        self.samples as f64 / t.as_secs_f64().max(1e-12)
    }

    /// Samples/s with 2 threads over 1: the median over the rounds.
    pub fn thread_scaling(&self) -> f64 {
        median_over(&self.rounds, |r| Some(r.one_thread.as_secs_f64() / r.two_threads.as_secs_f64().max(1e-12)))
    }

    pub fn path_tracer_mrays_per_s(&self) -> f64 {
        self.rays as f64 / self.two_threads().as_secs_f64().max(1e-12) / 1e6
    }

    pub fn embree_mrays_per_s(&self) -> f64 {
        self.recorded() as f64 / self.replay().as_secs_f64().max(1e-12) / 1e6
    }

    /// The path tracer's rays/s as a percentage of Embree's on the same rays ([`measure_scene`]
    /// checks they are as many), so Embree's wall time over the 2-thread render's: the median
    /// over the rounds.
    pub fn efficiency_percent(&self) -> f64 {
        median_over(&self.rounds, |r| Some(100.0 * r.replay.as_secs_f64() / r.two_threads.as_secs_f64().max(1e-12)))
    }

    /// The same from CPU time: less sensitive to other work on the machine.
    pub fn cpu_efficiency_percent(&self) -> Option<f64> {
        let p = median_over(&self.rounds, |r| {
            Some(100.0 * r.replay_cpu?.as_secs_f64() / r.two_threads_cpu?.as_secs_f64().max(1e-12))
        });
        p.is_finite().then_some(p)
    }
}

fn median_over(rounds: &[Round], f: impl Fn(&Round) -> Option<f64>) -> f64 {
    median(&rounds.iter().filter_map(f).collect::<Vec<_>>())
}

fn pool(threads: usize) -> Result<rayon::ThreadPool, BenchError> {
    rayon::ThreadPoolBuilder::new().num_threads(threads).build().map_err(|e| BenchError::Invalid(e.to_string()))
}

/// Measures one scene file. Everything runs in thread pools made here (renders with
/// `threads: None` use the pool they run in), so their threads live through each measurement
/// and their CPU time can be read.
pub fn measure_scene(
    path: &Path,
    device: &Device,
    cfg: &RenderConfig,
    bvh: RenderBvh,
) -> Result<RenderMeasurement, BenchError> {
    let scene = Scene::load(path)?;
    let settings = RenderSettings { bvh_quality: bvh.quality, robust: bvh.robust, ..cfg.settings(&scene, None) };
    // The build `ember render` makes with these requests: the plan's.
    let bvh = RenderPlan::new(&scene, &settings).bvh;
    let accel = EmbreeAccel::new(device, &scene.geometry, bvh)?;
    let (one, two) = (pool(1)?, pool(2)?);

    let recorder = RecordingAccel::new(&accel, 2);
    let (_, recorded_stats) = two.install(|| render(&scene, &recorder, &settings))?;
    let queries: Vec<RecordedQuery> = recorder.into_queries();
    let chunks = replay_chunks(&queries);
    if queries.len() as u64 != recorded_stats.rays {
        return Err(BenchError::Invalid(format!(
            "{}: the path tracer counted {} rays but made {} queries",
            path.display(),
            recorded_stats.rays,
            queries.len()
        )));
    }

    let mut rounds = Vec::new();
    let mut total = Duration::ZERO;
    while cfg.timing.wants_more(rounds.len(), total) {
        // Only the 2-thread render's CPU time is used: the 1-thread one is timed by its wall clock.
        let (_, stats1) = one.install(|| render(&scene, &accel, &settings))?;
        let (stats2, two_cpu) = two.install(|| cpu_of(|| render(&scene, &accel, &settings)));
        let stats2 = stats2?.1;
        if stats1.rays != recorded_stats.rays || stats2.rays != recorded_stats.rays {
            return Err(BenchError::Invalid(format!(
                "{}: renders with the same settings traced {} / {} / {} rays",
                path.display(),
                recorded_stats.rays,
                stats1.rays,
                stats2.rays
            )));
        }
        let (replayed, replay_cpu) = two.install(|| {
            cpu_of(|| {
                let start = Instant::now();
                std::hint::black_box(replay(&accel, &queries, &chunks)?);
                Ok::<_, BenchError>(start.elapsed())
            })
        });
        let replay_wall = replayed?;
        total += stats1.elapsed + stats2.elapsed + replay_wall;
        rounds.push(Round {
            one_thread: stats1.elapsed,
            two_threads: stats2.elapsed,
            two_threads_cpu: two_cpu,
            replay: replay_wall,
            replay_cpu,
        });
    }

    let occlusion_queries = queries.iter().filter(|q| q.occlusion).count();
    let name = path.file_name().map_or(path.display().to_string(), |n| n.to_string_lossy().into_owned());
    Ok(RenderMeasurement {
        scene: name,
        width: settings.width,
        height: settings.height,
        spp: settings.spp,
        samples: recorded_stats.samples,
        rays: recorded_stats.rays,
        closest_queries: queries.len() - occlusion_queries,
        occlusion_queries,
        bvh,
        path_loop: cfg.path_loop,
        rounds,
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
pub const CSV_COLUMNS: [&str; 22] = [
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
    "bvh_quality",
    "bvh_robust",
    "path_loop",
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
            format!("{:.6}", m.one_thread().as_secs_f64()),
            format!("{:.6}", m.two_threads().as_secs_f64()),
            format!("{:.1}", m.samples_per_s(1)),
            format!("{:.1}", m.samples_per_s(2)),
            format!("{:.3}", m.thread_scaling()),
            format!("{:.3}", m.path_tracer_mrays_per_s()),
            format!("{:.3}", m.embree_mrays_per_s()),
            format!("{:.1}", m.efficiency_percent()),
            m.two_threads_cpu().map_or(String::new(), |c| format!("{:.6}", c.as_secs_f64())),
            m.replay_cpu().map_or(String::new(), |c| format!("{:.6}", c.as_secs_f64())),
            m.cpu_efficiency_percent().map_or(String::new(), |p| format!("{p:.1}")),
            m.bvh.quality.to_string(),
            m.bvh.robust.to_string(),
            m.path_loop.name().to_string(),
        ]);
    }
    t
}

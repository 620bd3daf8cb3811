//! The intersection matrix: every strategy on every scene, for the three ray workloads, with
//! BVH build times, throughput, the speedup over the naive loop measured in the same run, and
//! a check of every strategy's answers against the naive loop's.

use super::BenchError;
use super::measure::{Answer, Batch, Timing, answers, time_answers, time_queries};
use super::rays::{self, Query, RayKind};
use super::scenes::{BenchScene, Family};
use super::strategy::Strategy;
use super::versus_naive::{AgreementWithNaive, compare_with_naive};
use crate::accel::{Accel, EmbreeAccel, NaiveAccel};
use crate::embree::{BuildOptions, Device};
use crate::geometry::{Geometry, bounds_of};
use crate::tools::report::{Series, Table, log_log_plot};
use std::collections::HashMap;
use std::path::Path;
use std::time::{Duration, Instant};

/// Sizes of a matrix run.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MatrixConfig {
    /// Coherent rays: `image_side`² camera rays.
    pub image_side: u32,
    /// Incoherent rays.
    pub incoherent: usize,
    /// The naive loop runs on a subsample of each workload of about this many primitive tests
    /// (rays × primitives), within `naive_min ..= naive_max` rays.
    pub naive_tests: f64,
    pub naive_min: usize,
    pub naive_max: usize,
    pub timing: Timing,
    pub seed: u64,
}

impl MatrixConfig {
    /// The full run: 512² camera rays, 262,144 random rays.
    pub fn full() -> Self {
        MatrixConfig {
            image_side: 512,
            incoherent: 512 * 512,
            naive_tests: 1.5e8,
            naive_min: 256,
            naive_max: 16_384,
            timing: Timing { min_passes: 3, min_total: Duration::from_millis(250) },
            seed: 2024,
        }
    }

    /// A smoke run of a few seconds.
    pub fn quick() -> Self {
        MatrixConfig {
            image_side: 96,
            incoherent: 96 * 96,
            naive_tests: 1e7,
            naive_min: 64,
            naive_max: 2_048,
            timing: Timing { min_passes: 1, min_total: Duration::from_millis(20) },
            seed: 2024,
        }
    }

    /// Size of the naive loop's subsample for a scene of `primitives`.
    pub fn naive_rays(&self, primitives: usize, available: usize) -> usize {
        let n = (self.naive_tests / primitives.max(1) as f64) as usize;
        n.clamp(self.naive_min, self.naive_max).min(available)
    }
}

/// One strategy on one workload of one scene: its speed, and its answers against the naive
/// loop's.
#[derive(Clone, Debug)]
pub struct StrategyMeasurement {
    pub scene: String,
    pub family: Family,
    pub strategy: &'static str,
    /// Triangles and spheres + cylinders in the scene as described.
    pub triangles: usize,
    pub shapes: usize,
    /// Triangles the strategy traces (more than `triangles` when shapes are tessellated).
    pub traced_triangles: usize,
    /// Embree registration + BVH build (best of up to three builds); `None` for the naive loop.
    pub build: Option<Duration>,
    pub kind: RayKind,
    /// Rays timed (the subsample for the naive loop).
    pub rays: usize,
    /// Best pass over those rays: wall time, and (separately) CPU time of all threads.
    pub time: Duration,
    pub cpu: Option<Duration>,
    pub hits: usize,
    pub threads: usize,
    /// The naive loop's subsample size and time per ray on this workload.
    pub naive_rays: usize,
    pub naive_ns_per_ray: f64,
    pub naive_cpu_ns_per_ray: Option<f64>,
    pub agreement: AgreementWithNaive,
}

impl StrategyMeasurement {
    pub fn ns_per_ray(&self) -> f64 {
        self.time.as_secs_f64() * 1e9 / self.rays.max(1) as f64
    }

    pub fn mrays_per_s(&self) -> f64 {
        self.rays as f64 / self.time.as_secs_f64().max(1e-12) / 1e6
    }

    /// CPU time per ray (all threads), when it could be read.
    pub fn cpu_ns_per_ray(&self) -> Option<f64> {
        self.cpu.map(|c| c.as_secs_f64() * 1e9 / self.rays.max(1) as f64)
    }

    /// Wall time per ray of the naive loop over this strategy's.
    pub fn speedup(&self) -> f64 {
        self.naive_ns_per_ray / self.ns_per_ray()
    }

    /// CPU time per ray of the naive loop over this strategy's: less sensitive than
    /// [`Self::speedup`] to other work on the machine.
    pub fn cpu_speedup(&self) -> Option<f64> {
        Some(self.naive_cpu_ns_per_ray? / self.cpu_ns_per_ray()?)
    }
}

/// Builds with `strategy`; Embree builds shorter than 70 ms are repeated (three in all) and
/// the fastest is reported, small builds being noisy.
fn build(
    strategy: Strategy,
    device: &Device,
    geometry: &[Geometry],
) -> Result<(Box<dyn Accel>, Option<Duration>), BenchError> {
    let (mut accel, mut best) = strategy.build(device, geometry)?;
    for _ in 1..3 {
        match best {
            Some(t) if t < Duration::from_millis(70) => {
                let (a, t2) = strategy.build(device, geometry)?;
                accel = a;
                best = best.min(t2);
            }
            _ => break,
        }
    }
    Ok((accel, best))
}

/// The workloads of a scene.
struct Workloads {
    sets: Vec<(RayKind, Vec<Query>)>,
}

impl Workloads {
    fn new(device: &Device, geometry: &[Geometry], cfg: &MatrixConfig) -> Result<Workloads, BenchError> {
        let b = bounds_of(geometry);
        let camera = rays::coherent(&b, cfg.image_side);
        let incoherent = rays::incoherent(&b, cfg.incoherent, cfg.seed);
        // Shadow rays start where the camera rays hit, found with a medium-quality build.
        let reference = EmbreeAccel::new(device, geometry, BuildOptions::default())?;
        let occlusion = rays::occlusion(&reference, &b, &camera, cfg.seed)?;
        Ok(Workloads {
            sets: vec![(RayKind::Coherent, camera), (RayKind::Incoherent, incoherent), (RayKind::Occlusion, occlusion)],
        })
    }
}

/// The naive loop's run on a workload's subsample.
struct NaiveReference {
    queries: Vec<Query>,
    answers: Vec<Answer>,
    ns_per_ray: f64,
    cpu_ns_per_ray: Option<f64>,
}

/// Runs every strategy on `scene`; `log` receives progress and mismatch reports.
pub fn run_scene(
    scene: &BenchScene,
    device: &Device,
    cfg: &MatrixConfig,
    log: &mut dyn FnMut(&str),
) -> Result<Vec<StrategyMeasurement>, BenchError> {
    let start = Instant::now();
    let threads = rayon::current_num_threads();
    let work = Workloads::new(device, &scene.geometry, cfg)?;
    let primitives = scene.primitives();
    let tessellated = scene.tessellated();
    let traced_tess = tessellated.as_ref().map(|g| g.iter().map(Geometry::len).sum::<usize>());

    // The naive loop on a subsample of each workload: its time per ray and reference answers.
    let naive = NaiveAccel::new(&scene.geometry);
    let mut out = Vec::new();
    let mut reference: HashMap<RayKind, NaiveReference> = HashMap::new();
    for (kind, queries) in &work.sets {
        let sub = rays::subsample(queries, cfg.naive_rays(primitives, queries.len()));
        let (t, ans) = time_answers(&naive, &sub, kind.closest())?;
        let per_ray = |d: Duration| d.as_secs_f64() * 1e9 / sub.len().max(1) as f64;
        let (ns, cpu_ns) = (per_ray(t.wall), t.cpu.map(per_ray));
        out.push(StrategyMeasurement {
            scene: scene.name.clone(),
            family: scene.family,
            strategy: Strategy::Naive.name(),
            triangles: scene.triangles(),
            shapes: scene.shapes(),
            traced_triangles: scene.triangles(),
            build: None,
            kind: *kind,
            rays: sub.len(),
            time: t.wall,
            cpu: t.cpu,
            hits: ans.iter().filter(|a| a.is_hit()).count(),
            threads,
            naive_rays: sub.len(),
            naive_ns_per_ray: ns,
            naive_cpu_ns_per_ray: cpu_ns,
            agreement: AgreementWithNaive::default(),
        });
        reference.insert(*kind, NaiveReference { queries: sub, answers: ans, ns_per_ray: ns, cpu_ns_per_ray: cpu_ns });
    }

    // Reference answers for the tessellated geometry: the naive loop over its triangles, on
    // the first rays of the subsample (it has many more primitives).
    let mut tess_reference: HashMap<RayKind, (Vec<Query>, Vec<Answer>)> = HashMap::new();
    let tess_naive = tessellated.as_ref().map(|g| NaiveAccel::new(g));

    for strategy in Strategy::for_scene(scene.shapes() > 0).into_iter().filter(|s| *s != Strategy::Naive) {
        let geometry =
            if strategy.tessellated() { tessellated.as_deref().unwrap_or(&scene.geometry) } else { &scene.geometry };
        let (accel, build_time) = build(strategy, device, geometry)?;
        for (kind, queries) in &work.sets {
            let (time, hits) =
                time_queries(accel.as_ref(), queries, kind.closest(), strategy.batch(*kind), cfg.timing)?;
            let NaiveReference {
                queries: sub,
                answers: ref_answers,
                ns_per_ray: naive_ns,
                cpu_ns_per_ray: naive_cpu_ns,
            } = &reference[kind];
            let agreement = match (&tess_naive, strategy.tessellated()) {
                (Some(tn), true) => {
                    if !tess_reference.contains_key(kind) {
                        let n = cfg.naive_rays(traced_tess.unwrap_or(1), sub.len());
                        let s: Vec<Query> = sub[..n].to_vec();
                        let a = answers(tn, &s, kind.closest(), Batch::Single)?;
                        tess_reference.insert(*kind, (s, a));
                    }
                    let (tsub, tref) = &tess_reference[kind];
                    let cand = answers(accel.as_ref(), tsub, kind.closest(), strategy.batch(*kind))?;
                    compare_with_naive(geometry, tsub, tref, tn, &cand, accel.as_ref())?
                }
                _ => {
                    let cand = answers(accel.as_ref(), sub, kind.closest(), strategy.batch(*kind))?;
                    compare_with_naive(geometry, sub, ref_answers, &naive, &cand, accel.as_ref())?
                }
            };
            for e in &agreement.examples {
                log(&format!("  mismatch {} {} {}: {e}", scene.name, strategy.name(), kind));
            }
            out.push(StrategyMeasurement {
                scene: scene.name.clone(),
                family: scene.family,
                strategy: strategy.name(),
                triangles: scene.triangles(),
                shapes: scene.shapes(),
                traced_triangles: if strategy.tessellated() { traced_tess.unwrap_or(0) } else { scene.triangles() },
                build: build_time,
                kind: *kind,
                rays: queries.len(),
                time: time.wall,
                cpu: time.cpu,
                hits,
                threads,
                naive_rays: sub.len(),
                naive_ns_per_ray: *naive_ns,
                naive_cpu_ns_per_ray: *naive_cpu_ns,
                agreement,
            });
        }
    }
    log(&format!(
        "{}: {} triangles, {} spheres/cylinders: measured in {:.1} s",
        scene.name,
        scene.triangles(),
        scene.shapes(),
        start.elapsed().as_secs_f64()
    ));
    Ok(out)
}

/// `x` with three significant digits (more left of the point from 1000 up), in scientific
/// notation below 0.01; "-" when not finite.
fn three_significant_digits(x: f64) -> String {
    if !x.is_finite() {
        return "-".into();
    }
    let digits = if x >= 100.0 {
        0
    } else if x >= 10.0 {
        1
    } else if x >= 1.0 {
        2
    } else {
        3
    };
    if x < 0.01 { format!("{x:.2e}") } else { format!("{x:.digits$}") }
}

fn primitives_cell(m: &StrategyMeasurement) -> String {
    if m.shapes > 0 && m.traced_triangles == m.triangles {
        if m.triangles > 0 {
            format!("{} tris + {} shapes", m.triangles, m.shapes)
        } else {
            format!("{} shapes", m.shapes)
        }
    } else {
        format!("{} tris", m.traced_triangles)
    }
}

/// The terminal table: one row per scene and strategy, the three workloads side by side.
/// Mrays/s are from wall time; ×naive from CPU time per ray where it can be read (else wall).
pub fn summary_table(ms: &[StrategyMeasurement]) -> Table {
    let mut t = Table::new([
        "scene",
        "primitives",
        "strategy",
        "build ms",
        "coherent Mrays/s",
        "×naive",
        "incoherent Mrays/s",
        "×naive",
        "occlusion Mrays/s",
        "×naive",
        "rays c/i/o",
        "mismatches",
    ]);
    let mut keys: Vec<(&str, &str)> = Vec::new();
    for m in ms {
        if !keys.contains(&(m.scene.as_str(), m.strategy)) {
            keys.push((m.scene.as_str(), m.strategy));
        }
    }
    for (scene, strategy) in keys {
        let row: Vec<&StrategyMeasurement> = ms.iter().filter(|m| m.scene == scene && m.strategy == strategy).collect();
        let by = |k: RayKind| row.iter().find(|m| m.kind == k);
        let first = row[0];
        let mut cells = vec![
            scene.to_string(),
            primitives_cell(first),
            strategy.to_string(),
            first.build.map_or("-".into(), |b| three_significant_digits(b.as_secs_f64() * 1e3)),
        ];
        for k in RayKind::ALL {
            match by(k) {
                Some(m) => {
                    cells.push(three_significant_digits(m.mrays_per_s()));
                    cells
                        .push(format!("{}×", three_significant_digits(m.cpu_speedup().unwrap_or_else(|| m.speedup()))));
                }
                None => cells.extend(["-".to_string(), "-".to_string()]),
            }
        }
        cells.push(RayKind::ALL.map(|k| by(k).map_or("-".into(), |m| m.rays.to_string())).join("/"));
        let (mis, edge): (usize, usize) =
            row.iter().fold((0, 0), |(a, b), m| (a + m.agreement.mismatches, b + m.agreement.at_edges));
        cells.push(if first.strategy == Strategy::Naive.name() {
            "-".into()
        } else if mis == 0 {
            "0".into()
        } else {
            format!("{mis} ({edge} at edges)")
        });
        t.push(cells);
    }
    t
}

/// Column names of bench.csv.
pub const CSV_COLUMNS: [&str; 25] = [
    "scene",
    "family",
    "strategy",
    "triangles",
    "shapes",
    "traced_triangles",
    "build_ms",
    "rays",
    "ray_count",
    "threads",
    "best_pass_s",
    "mrays_per_s",
    "ns_per_ray",
    "hits",
    "naive_ray_count",
    "naive_ns_per_ray",
    "speedup_vs_naive",
    "cpu_ns_per_ray",
    "naive_cpu_ns_per_ray",
    "cpu_speedup_vs_naive",
    "checked",
    "mismatches",
    "mismatches_at_edges",
    "ties",
    "timed_on",
];

/// One row per scene, strategy and workload.
pub fn csv_table(ms: &[StrategyMeasurement]) -> Table {
    let mut t = Table::new(CSV_COLUMNS);
    for m in ms {
        t.push([
            m.scene.clone(),
            format!("{:?}", m.family).to_lowercase(),
            m.strategy.to_string(),
            m.triangles.to_string(),
            m.shapes.to_string(),
            m.traced_triangles.to_string(),
            m.build.map_or(String::new(), |b| format!("{:.3}", b.as_secs_f64() * 1e3)),
            m.kind.name().to_string(),
            m.rays.to_string(),
            m.threads.to_string(),
            format!("{:.6}", m.time.as_secs_f64()),
            format!("{:.4}", m.mrays_per_s()),
            format!("{:.2}", m.ns_per_ray()),
            m.hits.to_string(),
            m.naive_rays.to_string(),
            format!("{:.1}", m.naive_ns_per_ray),
            format!("{:.2}", m.speedup()),
            m.cpu_ns_per_ray().map_or(String::new(), |x| format!("{x:.2}")),
            m.naive_cpu_ns_per_ray.map_or(String::new(), |x| format!("{x:.1}")),
            m.cpu_speedup().map_or(String::new(), |x| format!("{x:.2}")),
            m.agreement.checked.to_string(),
            m.agreement.mismatches.to_string(),
            m.agreement.at_edges.to_string(),
            m.agreement.ties.to_string(),
            if m.strategy == Strategy::Naive.name() { "subsample".into() } else { "all".into() },
        ]);
    }
    t
}

/// Time per ray against triangle count, log-log: the naive loop and Embree (medium) on each
/// workload, over the procedural family (or every triangle scene measured when the run has
/// no procedural scene). The time is CPU time per ray (all threads) when it could be read for
/// every point, as for the ×naive column; else wall time per ray.
pub fn scaling_plot(path: &Path, ms: &[StrategyMeasurement]) -> Result<(), BenchError> {
    let procedural = ms.iter().any(|m| m.family == Family::Procedural);
    let keep = |m: &&StrategyMeasurement| {
        if procedural { m.family == Family::Procedural } else { m.shapes == 0 || m.triangles > 0 }
    };
    let cpu = ms.iter().filter(keep).all(|m| m.cpu.is_some());
    let per_ray = |m: &StrategyMeasurement| if cpu { m.cpu_ns_per_ray().unwrap_or(f64::NAN) } else { m.ns_per_ray() };
    let mut series = Vec::new();
    for strategy in ["naive", "embree-medium"] {
        for kind in RayKind::ALL {
            let mut points: Vec<(f64, f64)> = ms
                .iter()
                .filter(keep)
                .filter(|m| m.strategy == strategy && m.kind == kind)
                .map(|m| (m.traced_triangles as f64, per_ray(m)))
                .collect();
            points.sort_by(|a, b| a.0.total_cmp(&b.0));
            if !points.is_empty() {
                series.push(Series { name: format!("{strategy}, {kind}"), points });
            }
        }
    }
    let threads = ms.first().map_or(1, |m| m.threads);
    let what = if procedural { "bumpy spheres" } else { "scenes measured" };
    log_log_plot(
        path,
        &format!("Time per ray vs triangles ({what}, {threads} threads)"),
        "triangles",
        if cpu { "CPU ns per ray (all threads)" } else { "ns per ray (wall time / rays)" },
        &series,
    )?;
    Ok(())
}

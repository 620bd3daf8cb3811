//! One `ember bench` run: the chosen sections in order, tables on stdout, progress on stderr,
//! CSV files and the plot in the output folder (each written atomically).

use super::BenchError;
use super::matrix::{self, MatrixConfig};
use super::render::{self, RenderConfig};
use super::scenes::{BenchScene, DEFAULT_SET, QUICK_SET};
use super::specialize;
use crate::accel::EmbreeAccel;
use crate::atomic_write::write_file;
use crate::embree::{BuildOptions, BuildQuality, Device};
use crate::settings::PathLoop;
use crate::tools::report::Table;
use crate::tools::{out, say};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// A part of the benchmark.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Section {
    /// Strategies × scenes × workloads → bench.csv, scaling.png.
    Matrix,
    /// Path tracer vs Embree alone, 1 vs 2 threads → render.csv.
    Render,
    /// Specialised vs general kernel on each scene file → specialize.csv.
    Specialize,
}

#[derive(Clone, Debug)]
pub struct Options {
    /// Matrix scenes (built-in names or files); empty: the default (or quick) set.
    pub scenes: Vec<String>,
    pub out: PathBuf,
    pub quick: bool,
    pub sections: Vec<Section>,
    /// Threads for the matrix (`None`: all cores). The render section always compares 1 and 2.
    pub threads: Option<usize>,
    pub scenes_dir: PathBuf,
    /// The BVH build of the render section (its renders and the replay).
    pub render_bvh: RenderBvh,
    /// The path loop of the render section's renders.
    pub render_loop: PathLoop,
}

/// The BVH build of the render section: a quality, or for each scene the one `ember render`
/// builds (`RenderPlan::bvh`), so that the section measures the renderer as it runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RenderBvh {
    pub quality: Option<BuildQuality>,
    pub robust: bool,
}

/// `low BVH, robust`, or `ember render's BVH, robust` when the quality is the scene's.
impl std::fmt::Display for RenderBvh {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.quality {
            Some(q) => write!(f, "{}", BuildOptions { quality: q, robust: self.robust, ..BuildOptions::default() }),
            None => write!(f, "ember render's BVH{}", if self.robust { ", robust" } else { "" }),
        }
    }
}

fn write_table(dir: &Path, name: &str, t: &Table) -> Result<PathBuf, BenchError> {
    let p = dir.join(name);
    write_file(&p, t.to_csv().as_bytes())?;
    Ok(p)
}

fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|m| m.trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into())
}

fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "unknown".into())
}

/// Runs the benchmark.
pub fn run(opts: &Options) -> Result<(), BenchError> {
    if opts.out.exists() && !opts.out.is_dir() {
        return Err(BenchError::Invalid(format!("{}: not a folder", opts.out.display())));
    }
    // Every input is read before anything is measured or written.
    let matrix_cfg = if opts.quick { MatrixConfig::quick() } else { MatrixConfig::full() };
    let matrix_scenes: Vec<BenchScene> = if opts.sections.contains(&Section::Matrix) {
        let names: Vec<&str> = if !opts.scenes.is_empty() {
            opts.scenes.iter().map(String::as_str).collect()
        } else if opts.quick {
            QUICK_SET.to_vec()
        } else {
            DEFAULT_SET.to_vec()
        };
        names.into_iter().map(|n| BenchScene::load(n, &opts.scenes_dir)).collect::<Result<_, _>>()?
    } else {
        Vec::new()
    };
    let specialize_files = if opts.sections.contains(&Section::Specialize) {
        specialize::scene_files(&opts.scenes_dir)?
    } else {
        Vec::new()
    };
    std::fs::create_dir_all(&opts.out)
        .map_err(|e| BenchError::Invalid(format!("{}: cannot create folder: {e}", opts.out.display())))?;
    let device = Device::new()?;
    // The first commit in a process also starts Embree's threads: keep it out of the timings.
    drop(EmbreeAccel::new(&device, &[], BuildOptions::default())?);
    let pool = match opts.threads {
        Some(n) => Some(
            rayon::ThreadPoolBuilder::new().num_threads(n).build().map_err(|e| BenchError::Invalid(e.to_string()))?,
        ),
        None => None,
    };
    let threads = pool.as_ref().map_or_else(rayon::current_num_threads, |p| p.current_num_threads());
    out!(
        "ember bench{}: Embree {}, {}, {} cores",
        if opts.quick { " --quick" } else { "" },
        device.version(),
        cpu_model(),
        std::thread::available_parallelism().map_or(1, |n| n.get())
    );
    out!("load average at start: {}", load_average());
    let start = Instant::now();
    let mut log = |s: &str| say!("{s}");

    if opts.sections.contains(&Section::Matrix) {
        let cfg = matrix_cfg;
        out!();
        out!(
            "Intersection matrix, {threads} threads. Rays per scene: {}² camera rays (coherent), {} random rays in the \
             bounds (incoherent), shadow rays from the visible camera hits to a square light (occlusion). Mrays/s: \
             rays / wall time of the best of >= {} passes. The naive loop runs once on an evenly spaced subsample \
             (column \"rays\" of its row) of about {:.1e} primitive tests, {}..{} rays. ×naive = naive CPU time per \
             ray / strategy CPU time per ray (all threads; wall time where CPU time cannot be read), robust to other \
             load on the machine. Mismatches: answers differing from the naive loop's on that subsample.",
            cfg.image_side,
            cfg.incoherent,
            cfg.timing.min_passes,
            cfg.naive_tests,
            cfg.naive_min,
            cfg.naive_max
        );
        let mut all = Vec::new();
        for scene in &matrix_scenes {
            let ms = match &pool {
                Some(p) => p.install(|| matrix::run_scene(scene, &device, &cfg, &mut log))?,
                None => matrix::run_scene(scene, &device, &cfg, &mut log)?,
            };
            all.extend(ms);
        }
        out!("{}", matrix::summary_table(&all).to_text().trim_end_matches('\n'));
        let csv = write_table(&opts.out, "bench.csv", &matrix::csv_table(&all))?;
        let png = opts.out.join("scaling.png");
        matrix::scaling_plot(&png, &all)?;
        out!("wrote {} and {}", csv.display(), png.display());
    }

    if opts.sections.contains(&Section::Render) {
        let cfg = if opts.quick { RenderConfig::quick() } else { RenderConfig::full() };
        let cfg = RenderConfig { path_loop: opts.render_loop, ..cfg };
        out!();
        out!(
            "Path tracer vs Embree alone ({} spp, width {}, scene depth and Russian roulette, {}, {} path loop): the path tracer's rays/s \
             (2 threads) over Embree's on the same rays, recorded from the path tracer and replayed through \
             rtcIntersect1/rtcOccluded1 on 2 threads; samples/s with 2 threads over 1. >= {} rounds and >= {:.1} s \
             per scene, each a 1-thread render, a 2-thread render and the replay back to back; Mrays/s and samples/s \
             from the fastest of each, the ratios (2t/1t, path tracer/Embree) the medians of the rounds' ratios.",
            cfg.spp,
            cfg.width,
            opts.render_bvh,
            cfg.path_loop.name(),
            cfg.timing.min_passes,
            cfg.timing.min_total.as_secs_f64()
        );
        let mut ms = Vec::new();
        for file in ["cornell.toml", "teapot.toml"] {
            let m = render::measure_scene(&opts.scenes_dir.join(file), &device, &cfg, opts.render_bvh)?;
            log(&format!("{file}: rendered, recorded and replayed ({})", m.bvh));
            ms.push(m);
        }
        out!("{}", render::summary_table(&ms).to_text().trim_end_matches('\n'));
        let csv = write_table(&opts.out, "render.csv", &render::csv_table(&ms))?;
        out!("wrote {}", csv.display());
    }

    if opts.sections.contains(&Section::Specialize) {
        let cfg = if opts.quick { RenderConfig::quick() } else { specialize::config() };
        out!();
        out!(
            "Specialised vs general kernel (RenderSettings.specialize), all cores, {} spp, width {}: >= {} pairs of \
             renders and >= {:.1} s per scene, the order alternating; µs/sample: the fastest render (wall time); \
             speedup: the median over the pairs of general / specialised CPU time.",
            cfg.spp,
            cfg.width,
            cfg.timing.min_passes,
            cfg.timing.min_total.as_secs_f64()
        );
        let mut ms = Vec::new();
        for file in specialize_files {
            ms.push(specialize::measure_scene(&file, &device, &cfg)?);
            log(&format!("{}: measured", file.display()));
        }
        out!("{}", specialize::summary_table(&ms).to_text().trim_end_matches('\n'));
        let csv = write_table(&opts.out, "specialize.csv", &specialize::csv_table(&ms))?;
        out!("wrote {}", csv.display());
    }
    out!();
    out!("total {:.1} s; load average at end: {}", start.elapsed().as_secs_f64(), load_average());
    Ok(())
}

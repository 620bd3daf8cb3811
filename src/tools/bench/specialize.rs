//! Time per sample with the kernel specialised to the scene (`RenderSettings::specialize`)
//! against the general kernel, on each scene file.
//!
//! The renders are short (tens of milliseconds), and on a shared 2-core machine one render's
//! wall time swings by ±10%: best-of-N wall times gave speedups that moved by as much between
//! runs. So the two kernels are timed in pairs, the order alternating from pair to pair (a
//! change in load hits both members of a pair alike, and neither always runs first), each
//! render's time is the CPU time of all render threads ([`cpu_of`]: it does not count time
//! the threads waited for a core), and the speedup is the median of the pairs' ratios.

use super::BenchError;
use super::cputime::cpu_of;
use super::measure::{Timing, median};
use super::render::RenderConfig;
use crate::accel::EmbreeAccel;
use crate::embree::{BuildOptions, Device};
use crate::film::Film;
use crate::integrator::{RenderSettings, render};
use crate::scene::Scene;
use crate::tools::report::Table;
use std::path::{Path, PathBuf};
use std::time::Duration;

#[derive(Clone, Debug)]
pub struct SpecializeMeasurement {
    pub scene: String,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub samples: u64,
    /// Fastest render of each kernel, wall time.
    pub general: Duration,
    pub specialized: Duration,
    /// General over specialised time of each pair of renders (CPU time where it can be read).
    pub ratios: Vec<f64>,
    /// Whether both kernels gave the bit-identical image.
    pub identical: bool,
}

impl SpecializeMeasurement {
    pub fn us_per_sample(&self, specialized: bool) -> f64 {
        let t = if specialized { self.specialized } else { self.general };
        t.as_secs_f64() * 1e6 / self.samples.max(1) as f64
    }

    /// The median over the pairs of general time over specialised time.
    pub fn speedup(&self) -> f64 {
        median(&self.ratios)
    }

    /// The lowest and highest ratio of a pair.
    pub fn ratio_range(&self) -> (f64, f64) {
        let lo = self.ratios.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = self.ratios.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        (lo, hi)
    }
}

/// The full run's renders (those of `ember bench --render`: 128 pixels wide, 16 spp), with
/// at least 15 pairs and 2 s per scene: enough pairs that the median moves by a percent or
/// two between runs.
pub fn config() -> RenderConfig {
    RenderConfig { timing: Timing { min_passes: 15, min_total: Duration::from_secs(2) }, ..RenderConfig::full() }
}

/// The scene files in `dir` (`.toml`, and `.obj` meshes, which render with a default camera,
/// studio and clay material: `teapot.obj` is the plain diffuse teapot), sorted by name.
pub fn scene_files(dir: &Path) -> Result<Vec<PathBuf>, BenchError> {
    let entries = std::fs::read_dir(dir).map_err(|e| BenchError::Invalid(format!("{}: {e}", dir.display())))?;
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "toml" || x == "obj"))
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(BenchError::Invalid(format!("{}: no .toml or .obj scene files", dir.display())));
    }
    Ok(files)
}

/// Measures one scene file with all cores.
pub fn measure_scene(path: &Path, device: &Device, cfg: &RenderConfig) -> Result<SpecializeMeasurement, BenchError> {
    let scene = Scene::load(path)?;
    let accel = EmbreeAccel::new(device, &scene.geometry, BuildOptions::default())?;
    let base = cfg.settings(&scene, None);
    let with = |specialize| RenderSettings { specialize, ..base.clone() };
    let (general, specialized) = (with(false), with(true));
    let mut best = [Duration::MAX; 2];
    let mut total = Duration::ZERO;
    let mut films: [Option<Film>; 2] = [None, None];
    let mut ratios = Vec::new();
    let mut samples = 0;
    while cfg.timing.wants_more(ratios.len(), total) {
        let mut time = [Duration::ZERO; 2];
        // Pairs alternate which kernel goes first.
        let order = if ratios.len() % 2 == 0 { [0, 1] } else { [1, 0] };
        for i in order {
            let s = if i == 0 { &general } else { &specialized };
            let (result, cpu) = cpu_of(|| render(&scene, &accel, s));
            let (film, stats) = result?;
            best[i] = best[i].min(stats.elapsed);
            time[i] = cpu.unwrap_or(stats.elapsed);
            total += stats.elapsed;
            samples = stats.samples;
            films[i] = Some(film);
        }
        ratios.push(time[0].as_secs_f64() / time[1].as_secs_f64().max(1e-12));
    }
    let identical = match (&films[0], &films[1]) {
        (Some(a), Some(b)) => a
            .pixels
            .iter()
            .zip(&b.pixels)
            .all(|(x, y)| x.to_array().map(f32::to_bits) == y.to_array().map(f32::to_bits)),
        _ => false,
    };
    let name = path.file_name().map_or(path.display().to_string(), |n| n.to_string_lossy().into_owned());
    Ok(SpecializeMeasurement {
        scene: name,
        width: base.width,
        height: base.height,
        spp: base.spp,
        samples,
        general: best[0],
        specialized: best[1],
        ratios,
        identical,
    })
}

pub fn summary_table(ms: &[SpecializeMeasurement]) -> Table {
    let mut t = Table::new([
        "scene",
        "image",
        "general µs/sample",
        "specialized µs/sample",
        "pairs",
        "speedup (median)",
        "pair range",
        "same image",
    ]);
    for m in ms {
        let (lo, hi) = m.ratio_range();
        t.push([
            m.scene.clone(),
            format!("{}x{}x{}", m.width, m.height, m.spp),
            format!("{:.3}", m.us_per_sample(false)),
            format!("{:.3}", m.us_per_sample(true)),
            m.ratios.len().to_string(),
            format!("{:.3}×", m.speedup()),
            format!("{lo:.2}–{hi:.2}"),
            if m.identical { "yes".into() } else { "no".into() },
        ]);
    }
    t
}

pub const CSV_COLUMNS: [&str; 12] = [
    "scene",
    "width",
    "height",
    "spp",
    "samples",
    "general_us_per_sample",
    "specialized_us_per_sample",
    "pairs",
    "speedup",
    "speedup_min",
    "speedup_max",
    "identical_image",
];

pub fn csv_table(ms: &[SpecializeMeasurement]) -> Table {
    let mut t = Table::new(CSV_COLUMNS);
    for m in ms {
        let (lo, hi) = m.ratio_range();
        t.push([
            m.scene.clone(),
            m.width.to_string(),
            m.height.to_string(),
            m.spp.to_string(),
            m.samples.to_string(),
            format!("{:.4}", m.us_per_sample(false)),
            format!("{:.4}", m.us_per_sample(true)),
            m.ratios.len().to_string(),
            format!("{:.4}", m.speedup()),
            format!("{lo:.4}"),
            format!("{hi:.4}"),
            m.identical.to_string(),
        ]);
    }
    t
}

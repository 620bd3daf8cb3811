//! Time per sample with the kernel specialised to the scene (`RenderSettings::specialize`)
//! against the general kernel, on each scene file. The two settings are timed alternately
//! (best pass of each kept), so a change in machine load affects both alike.

use super::BenchError;
use super::render::RenderConfig;
use crate::accel::EmbreeAccel;
use crate::embree::{BuildOptions, Device};
use crate::film::Film;
use crate::integrator::{RenderSettings, render};
use crate::report::Table;
use crate::scene::Scene;
use std::path::{Path, PathBuf};
use std::time::Duration;

#[derive(Clone, Debug)]
pub struct SpecializeMeasurement {
    pub scene: String,
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub samples: u64,
    pub general: Duration,
    pub specialized: Duration,
    /// Whether both kernels gave the bit-identical image.
    pub identical: bool,
}

impl SpecializeMeasurement {
    pub fn us_per_sample(&self, specialized: bool) -> f64 {
        let t = if specialized { self.specialized } else { self.general };
        t.as_secs_f64() * 1e6 / self.samples.max(1) as f64
    }

    /// General time over specialised time.
    pub fn speedup(&self) -> f64 {
        self.general.as_secs_f64() / self.specialized.as_secs_f64().max(1e-12)
    }
}

/// The scene files in `dir` (`.toml`, and `.obj` meshes, which render with a default camera,
/// sky and diffuse material: `teapot.obj` is the plain diffuse teapot), sorted by name.
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
    let mut samples = 0;
    let mut passes = 0;
    while passes < cfg.timing.min_passes.max(1) || total < cfg.timing.min_total {
        for (i, s) in [&general, &specialized].into_iter().enumerate() {
            let (film, stats) = render(&scene, &accel, s)?;
            best[i] = best[i].min(stats.elapsed);
            total += stats.elapsed;
            samples = stats.samples;
            films[i] = Some(film);
        }
        passes += 1;
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
        identical,
    })
}

pub fn summary_table(ms: &[SpecializeMeasurement]) -> Table {
    let mut t = Table::new(["scene", "image", "general µs/sample", "specialized µs/sample", "speedup", "same image"]);
    for m in ms {
        t.push([
            m.scene.clone(),
            format!("{}x{}x{}", m.width, m.height, m.spp),
            format!("{:.3}", m.us_per_sample(false)),
            format!("{:.3}", m.us_per_sample(true)),
            format!("{:.2}×", m.speedup()),
            if m.identical { "yes".into() } else { "no".into() },
        ]);
    }
    t
}

pub const CSV_COLUMNS: [&str; 9] = [
    "scene",
    "width",
    "height",
    "spp",
    "samples",
    "general_us_per_sample",
    "specialized_us_per_sample",
    "speedup",
    "identical_image",
];

pub fn csv_table(ms: &[SpecializeMeasurement]) -> Table {
    let mut t = Table::new(CSV_COLUMNS);
    for m in ms {
        t.push([
            m.scene.clone(),
            m.width.to_string(),
            m.height.to_string(),
            m.spp.to_string(),
            m.samples.to_string(),
            format!("{:.4}", m.us_per_sample(false)),
            format!("{:.4}", m.us_per_sample(true)),
            format!("{:.3}", m.speedup()),
            m.identical.to_string(),
        ]);
    }
    t
}

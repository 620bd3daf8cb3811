//! Rendering: the image is cut into tiles rendered in parallel; every sample draws its random
//! numbers from a stream keyed by (seed, pixel, sample index), so the image is bit-identical
//! whatever the thread count or tile order.

mod kernel;
mod path;
mod surface;

pub use kernel::KernelChoice;
pub use path::PathContext;
pub use surface::{SurfacePoint, surface_point};

use crate::accel::{Accel, AccelError};
use crate::film::Film;
use crate::scene::{Effects, Scene};
use glam::Vec3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::{Duration, Instant};

/// Which estimator of the rendering equation to use.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Estimator {
    /// Next-event estimation and BSDF sampling combined by MIS (the default).
    #[default]
    NeeMis,
    /// Next-event estimation only; emission found by BSDF sampling is ignored (except after
    /// specular bounces).
    NeeOnly,
    /// BSDF sampling only (point lights then contribute nothing).
    BsdfOnly,
    /// BSDF sampling only, with diffuse surfaces sampled uniformly over the hemisphere
    /// instead of by cosine (the seed paper's estimator; other BSDFs use their own sampling).
    BsdfUniform,
}

impl Estimator {
    pub const ALL: [Estimator; 4] = [Estimator::NeeMis, Estimator::NeeOnly, Estimator::BsdfOnly, Estimator::BsdfUniform];

    /// The name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            Estimator::NeeMis => "nee-mis",
            Estimator::NeeOnly => "nee",
            Estimator::BsdfOnly => "bsdf",
            Estimator::BsdfUniform => "bsdf-uniform",
        }
    }
}

impl std::str::FromStr for Estimator {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Estimator::ALL
            .into_iter()
            .find(|e| e.name() == s)
            .ok_or_else(|| format!("unknown estimator {s:?} (expected nee-mis, nee, bsdf or bsdf-uniform)"))
    }
}

impl std::fmt::Display for Estimator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// How to render.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    /// Maximum number of bounces: 0 shows emitters only, 1 is direct lighting.
    pub max_depth: u32,
    /// Russian roulette starts after this many bounces (`u32::MAX`: never).
    pub rr_depth: u32,
    pub seed: u64,
    /// Worker threads (`None`: all cores).
    pub threads: Option<usize>,
    pub estimator: Estimator,
    /// Show a progress bar (only when stderr is a terminal).
    pub progress: bool,
    /// Run the kernel specialised to the scene's effects (`false`: the general kernel).
    pub specialize: bool,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            width: 640,
            height: 480,
            spp: 64,
            max_depth: 8,
            rr_depth: 3,
            seed: 0,
            threads: None,
            estimator: Estimator::NeeMis,
            progress: false,
            specialize: true,
        }
    }
}

/// What a render did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderStats {
    pub elapsed: Duration,
    pub rays: u64,
    pub samples: u64,
    /// Samples whose value was NaN or infinite; dropped from the image.
    pub nonfinite: u64,
    /// What the scene analysis found.
    pub effects: Effects,
    /// The kernel that ran.
    pub kernel: KernelChoice,
    /// The bounce limit used (the user's, or less where the scene cannot use more).
    pub max_depth: u32,
}

impl Default for RenderStats {
    fn default() -> Self {
        RenderStats {
            elapsed: Duration::ZERO,
            rays: 0,
            samples: 0,
            nonfinite: 0,
            effects: Effects::default(),
            kernel: KernelChoice::GENERAL,
            max_depth: 0,
        }
    }
}

impl RenderStats {
    pub fn mrays_per_s(&self) -> f64 {
        self.rays as f64 / self.elapsed.as_secs_f64().max(1e-9) / 1e6
    }
}

#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error(transparent)]
    Accel(#[from] AccelError),
    #[error("cannot start {0} worker threads: {1}")]
    Threads(usize, String),
}

const TILE: u32 = 16;

/// Renders `scene` through `accel`.
pub fn render(scene: &Scene, accel: &dyn Accel, settings: &RenderSettings) -> Result<(Film, RenderStats), RenderError> {
    match settings.threads {
        Some(n) => {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .map_err(|e| RenderError::Threads(n, e.to_string()))?;
            pool.install(|| render_in_pool(scene, accel, settings))
        }
        None => render_in_pool(scene, accel, settings),
    }
}

fn render_in_pool(scene: &Scene, accel: &dyn Accel, settings: &RenderSettings) -> Result<(Film, RenderStats), RenderError> {
    let start = Instant::now();
    let (w, h) = (settings.width, settings.height);
    let camera = scene.camera(w as f32 / h as f32);
    let lights = scene.light_set();
    let effects = scene.effects();
    let (kernel, max_depth) = if settings.specialize {
        (KernelChoice::for_effects(&effects), effects.depth_limit().apply(settings.max_depth))
    } else {
        (KernelChoice::GENERAL, settings.max_depth)
    };
    if settings.specialize && !effects.lit {
        // Nothing emits: every path carries zero radiance, so none is traced.
        let stats = RenderStats { samples: w as u64 * h as u64 * settings.spp as u64, effects, kernel, max_depth, ..Default::default() };
        return Ok((Film::new(w, h), RenderStats { elapsed: start.elapsed(), ..stats }));
    }
    let sample = kernel.sample_fn();
    let ctx = PathContext { scene, accel, lights: &lights, camera: &camera, settings, max_depth };
    let tiles: Vec<(u32, u32)> = (0..h.div_ceil(TILE)).flat_map(|ty| (0..w.div_ceil(TILE)).map(move |tx| (tx, ty))).collect();
    let bar = progress_bar(settings.progress, tiles.len() as u64);
    let rays_total = AtomicU64::new(0);
    let results = tiles
        .par_iter()
        .map(|&(tx, ty)| -> Result<(u32, u32, Vec<Vec3>, u64, u64), AccelError> {
            let (x0, y0) = (tx * TILE, ty * TILE);
            let (x1, y1) = ((x0 + TILE).min(w), (y0 + TILE).min(h));
            let mut out = Vec::with_capacity(((x1 - x0) * (y1 - y0)) as usize);
            let (mut rays, mut bad) = (0u64, 0u64);
            for y in y0..y1 {
                for x in x0..x1 {
                    let mut sum = Vec3::ZERO;
                    for s in 0..settings.spp {
                        let v = sample(&ctx, x, y, s, &mut rays)?;
                        if v.is_finite() {
                            sum += v;
                        } else {
                            bad += 1;
                        }
                    }
                    out.push(sum / settings.spp as f32);
                }
            }
            let total = rays_total.fetch_add(rays, Ordering::Relaxed) + rays;
            if let Some(b) = &bar {
                b.inc(1);
                let secs = start.elapsed().as_secs_f64().max(1e-9);
                b.set_message(format!("{:.1} Mrays/s", total as f64 / secs / 1e6));
            }
            Ok((tx, ty, out, rays, bad))
        })
        .collect::<Result<Vec<_>, _>>()?;
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    let mut film = Film::new(w, h);
    let mut stats = RenderStats {
        samples: w as u64 * h as u64 * settings.spp as u64,
        effects,
        kernel,
        max_depth,
        ..Default::default()
    };
    for (tx, ty, px, rays, bad) in results {
        let (x0, y0) = (tx * TILE, ty * TILE);
        let tw = (x0 + TILE).min(w) - x0;
        for (i, v) in px.into_iter().enumerate() {
            let (x, y) = (x0 + i as u32 % tw, y0 + i as u32 / tw);
            film.pixels[(y * w + x) as usize] = v;
        }
        stats.rays += rays;
        stats.nonfinite += bad;
    }
    stats.elapsed = start.elapsed();
    Ok((film, stats))
}

fn progress_bar(wanted: bool, tiles: u64) -> Option<indicatif::ProgressBar> {
    use std::io::IsTerminal;
    if !wanted || !std::io::stderr().is_terminal() {
        return None;
    }
    let bar = indicatif::ProgressBar::new(tiles);
    bar.set_style(
        indicatif::ProgressStyle::with_template("{bar:40.cyan/blue} {percent:>3}% tiles {pos}/{len}  ETA {eta}  {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    Some(bar)
}

//! Rendering: the image is cut into tiles rendered in parallel; every sample draws its random
//! numbers from a stream keyed by (seed, pixel, sample index), so the image is bit-identical
//! whatever the thread count or tile order.

mod kernel;
mod path;
mod progressive;
mod surface;

pub use kernel::KernelChoice;
pub use progressive::{RenderControl, RenderResult};
pub use surface::{FaceNormals, SurfacePoint, surface_point};

use crate::accel::{Accel, AccelError};
use crate::film::Film;
pub use crate::scene::RrDepth;
use crate::scene::{Effects, RenderDefaults, Scene};
use std::time::Duration;

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
    pub const ALL: [Estimator; 4] =
        [Estimator::NeeMis, Estimator::NeeOnly, Estimator::BsdfOnly, Estimator::BsdfUniform];

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
    /// When Russian roulette starts: chosen from the scene ([`Effects::rr_start`]), after a
    /// given number of bounces, or never.
    pub rr_depth: RrDepth,
    pub seed: u64,
    /// Worker threads (`None`: all cores).
    pub threads: Option<usize>,
    pub estimator: Estimator,
    /// Show a progress bar (only when stderr is a terminal).
    pub progress: bool,
    /// Run the kernel specialised to the scene's effects (`false`: the general kernel).
    pub specialize: bool,
    /// Adaptive sampling: a pixel stops taking samples once the estimated relative standard
    /// error of its mean falls below this (see [`crate::film::PixelState::relative_error`]);
    /// `spp` is then the most any pixel gets.
    pub target_error: Option<f32>,
}

impl RenderSettings {
    /// Everything that changes the image of a scene with `effects`, as `key=value` words
    /// (thread count, progress display and kernel choice do not change it; the Russian-roulette
    /// start is the one in force, [`RenderSettings::rr_start`]). Checkpoints record this.
    pub fn image_key(&self, effects: &Effects) -> String {
        let rr = self.rr_start(effects).map_or("off".to_string(), |d| d.to_string());
        let te = self.target_error.map_or("none".to_string(), |e| e.to_string());
        format!(
            "width={} height={} spp={} max-depth={} rr-depth={rr} seed={} estimator={} target-error={te}",
            self.width, self.height, self.spp, self.max_depth, self.seed, self.estimator
        )
    }

    /// The defaults with a scene file's `[render]` values over them.
    pub fn from_scene(r: &RenderDefaults) -> RenderSettings {
        let d = RenderSettings::default();
        RenderSettings {
            width: r.width.unwrap_or(d.width),
            height: r.height.unwrap_or(d.height),
            spp: r.spp.unwrap_or(d.spp),
            max_depth: r.max_depth.unwrap_or(d.max_depth),
            rr_depth: r.rr_depth.unwrap_or(d.rr_depth),
            seed: r.seed.unwrap_or(d.seed),
            ..d
        }
    }

    /// The depth from which Russian roulette runs in a render of a scene with `effects`
    /// (`None`: never): the same for every kernel.
    pub fn rr_start(&self, effects: &Effects) -> Option<u32> {
        self.rr_depth.resolve(effects, self.max_depth)
    }
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            width: 640,
            height: 480,
            spp: 64,
            max_depth: 8,
            rr_depth: RrDepth::Auto,
            seed: 0,
            threads: None,
            estimator: Estimator::NeeMis,
            progress: false,
            specialize: true,
            target_error: None,
        }
    }
}

/// What a render did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderStats {
    /// Time spent in this call (the rays and Mrays/s are this call's too).
    pub elapsed: Duration,
    /// Time spent by earlier, interrupted sessions of a resumed render.
    pub earlier_sessions: Duration,
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
    /// The depth from which Russian roulette ran (`None`: it did not).
    pub rr_start: Option<u32>,
    /// (min, mean, max) samples per pixel.
    pub spp: (u32, f64, u32),
    /// (mean, max) over pixels of the estimated relative standard error.
    pub error_estimate: (f64, f64),
}

impl Default for RenderStats {
    fn default() -> Self {
        RenderStats {
            elapsed: Duration::ZERO,
            earlier_sessions: Duration::ZERO,
            rays: 0,
            samples: 0,
            nonfinite: 0,
            effects: Effects::default(),
            kernel: KernelChoice::GENERAL,
            max_depth: 0,
            rr_start: None,
            spp: (0, 0.0, 0),
            error_estimate: (f64::INFINITY, f64::INFINITY),
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
    #[error(transparent)]
    Checkpoint(#[from] crate::film::CheckpointError),
}

/// Renders `scene` through `accel`: every pixel gets `settings.spp` samples (or, with
/// `target_error`, as many as it needs up to that).
pub fn render(scene: &Scene, accel: &dyn Accel, settings: &RenderSettings) -> Result<(Film, RenderStats), RenderError> {
    let r = render_controlled(scene, accel, settings, RenderControl::default())?;
    Ok((r.accum.film(), r.stats))
}

/// [`render`] with a stop flag, periodic checkpoints and resumption (see [`RenderControl`]).
pub fn render_controlled(
    scene: &Scene,
    accel: &dyn Accel,
    settings: &RenderSettings,
    control: RenderControl,
) -> Result<RenderResult, RenderError> {
    match settings.threads {
        Some(n) => {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .map_err(|e| RenderError::Threads(n, e.to_string()))?;
            pool.install(|| progressive::run(scene, accel, settings, control))
        }
        None => progressive::run(scene, accel, settings, control),
    }
}

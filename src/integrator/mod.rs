//! Rendering: the image is cut into tiles rendered in parallel; every sample draws its random
//! numbers from a stream keyed by (seed, pixel, sample index), so the image is bit-identical
//! whatever the thread count or tile order.

pub mod adaptive;
mod aux;
mod caustic;
mod context;
mod guide;
mod kernel;
mod lanes;
mod light_vertex;
mod mis;
mod path;
mod plan;
mod progressive;
pub mod roulette;
mod surface;
mod visibility;
mod wavefront;

pub use aux::AuxSample;
pub use kernel::KernelChoice;
pub use plan::RenderPlan;
pub use progressive::{FirstRounds, PreviewFn, Progress, RenderControl, RenderResult, tile_order};
pub use surface::{FaceNormals, SurfacePoint, surface_point};

use crate::accel::{Accel, AccelError};
use crate::film::Film;
use crate::scene::Scene;
pub use crate::settings::{Estimator, RenderSettings, RrDepth};
use std::time::Duration;

/// What a render did.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderStats {
    /// Time spent in this call (the rays and Mrays/s are this call's too).
    pub elapsed: Duration,
    /// Time spent by earlier, interrupted sessions of a resumed render.
    pub earlier_sessions: Duration,
    pub rays: u64,
    pub samples: u64,
    /// Samples whose value was NaN or infinite; dropped from the image.
    pub nonfinite: u64,
    /// Samples of this call scaled down by the sample clamp ([`RenderSettings::clamp`]).
    pub clamped: u64,
    /// Splats of the caustics' light paths scaled down by the sample clamp in this call.
    pub clamped_splats: u64,
    /// In an adaptive render, the mean cost of the samples its plan added
    /// ([`adaptive::added_sample_cost`]): above 1 when they went to pixels that trace more rays
    /// per sample than the mean, so that fewer than `spp` per pixel fit in the budget.
    pub added_sample_cost: Option<f64>,
    /// What ran: the kernel, the path depth and the roulette start, and why.
    pub plan: RenderPlan,
    /// (min, mean, max) samples per pixel.
    pub spp: (u32, f64, u32),
    /// (mean, max) over pixels of the estimated relative standard error.
    pub error_estimate: (f64, f64),
    /// The cells where the light choice was weighed by where light samples get through
    /// (`--light-visibility`), if it was.
    pub light_visibility_cells: Option<usize>,
    /// Where light vertices could come from area lights: whether they did, and why.
    pub surface_light_vertices: Option<SurfaceLightVertices>,
}

/// Light vertices from area lights, decided by the pass before the render
/// (`light_vertex::LightVertexPool::from_surfaces`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfaceLightVertices {
    /// The share of the pass's rays after a bounce that left the scene.
    pub escaped: f64,
    /// If paths connected to them: the vertices in the pool, and the light paths traced for it.
    pub pool: Option<(u32, u64)>,
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
    #[error(
        "an adaptive render plans from the whole image's first round: render a shard of it in two stages, --first-round then --plan-from the N first-round files (or render it with --uniform)"
    )]
    AdaptiveShard,
    #[error("stopped while tracing the caustics' light paths, before the first pixel")]
    StoppedInLightPaths,
}

/// Renders `scene` through `accel`: every pixel gets `settings.spp` samples (or, with
/// `target_error`, as many as it needs up to that).
pub fn render(scene: &Scene, accel: &dyn Accel, settings: &RenderSettings) -> Result<(Film, RenderStats), RenderError> {
    let plan = RenderPlan::new(scene, settings);
    let r = render_controlled(scene, accel, &plan, RenderControl::default())?;
    Ok((r.accum.film(), r.stats))
}

/// Renders `scene` as `plan` (made for it) says, with a stop flag, periodic checkpoints,
/// resumption and progress reports (see [`RenderControl`]).
pub fn render_controlled(
    scene: &Scene,
    accel: &dyn Accel,
    plan: &RenderPlan,
    control: RenderControl,
) -> Result<RenderResult, RenderError> {
    let settings = &plan.settings;
    match settings.threads {
        Some(n) => {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .map_err(|e| RenderError::Threads(n, e.to_string()))?;
            pool.install(|| progressive::run(scene, accel, plan, control))
        }
        None => progressive::run(scene, accel, plan, control),
    }
}

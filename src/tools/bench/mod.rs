//! Benchmarks (`ember bench`): the intersection matrix (strategies × scenes × ray workloads,
//! [`matrix`]), the path tracer against raw Embree and its thread scaling ([`render`]), and
//! the specialised-kernel comparison ([`specialize`]). Rays are generated from fixed seeds and
//! shared by every strategy of a run; every strategy's answers are checked against the naive
//! loop's on the rays both trace.

pub mod cputime;
pub mod matrix;
pub mod measure;
pub mod procedural;
pub mod rays;
pub mod record;
pub mod render;
mod run;
pub mod scenes;
pub mod specialize;
pub mod strategy;
pub mod tessellate;
pub mod versus_naive;

pub use run::{Options, RenderBvh, Section, run};

use crate::accel::AccelError;
use crate::atomic_write::WriteError;
use crate::embree::EmbreeError;
use crate::integrator::RenderError;
use crate::scene::SceneError;
use crate::tools::report::PlotError;

/// Why a benchmark could not run or report.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error(transparent)]
    Embree(#[from] EmbreeError),
    #[error(transparent)]
    Accel(#[from] AccelError),
    #[error(transparent)]
    Render(#[from] RenderError),
    #[error(transparent)]
    Write(#[from] WriteError),
    #[error(transparent)]
    Plot(#[from] PlotError),
    #[error("{0}")]
    Invalid(String),
}

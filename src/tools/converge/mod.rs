//! Convergence studies: what accuracy costs in time. A [`Study`] renders a scene at 1, 2, 4,
//! … N samples per pixel with several estimator variants ([`Variant`]), measures each image
//! against a high-spp reference ([`image_difference`]), and the points it measures say how fast
//! the error falls ([`log_log_slope`]) and how long each variant takes to reach a target
//! relMSE ([`time_to_reach`]).
//!
//! This module renders and measures; writing the results (CSV, plots, the time-to-reach
//! table) is [`crate::tools::report::converge`]'s job.

mod analysis;
mod metrics;
mod study;
mod variant;

pub use analysis::{TimeToReach, log_log_slope, time_to_reach, time_to_reach_by};
pub use metrics::{
    FLIP_PIXELS_PER_DEGREE, ImageDifference, REL_MSE_EPSILON, SizeMismatch, flip_error, image_difference,
};
pub use study::{ConvergeError, ConvergencePoint, ProgressFn, Study, spp_ladder};
pub use variant::{DEPTH_GROUP, Variant, parse_variants};

//! Reports: tables and plots of measurements (benchmarks, convergence). Everything here
//! writes files atomically (see [`crate::atomic_write`]).

pub mod converge;
pub mod metrics;
mod plot;
mod table;

pub use metrics::{ImageError, REL_MSE_EPSILON, image_error};
pub use plot::{LineStyle, PlotError, PlotOptions, Series, log_log_plot, log_log_plot_with};
pub use table::Table;

//! Reports: tables and plots of measurements (benchmarks, convergence). It formats and
//! writes, and measures nothing; every file is written atomically (see [`crate::output`]).

pub mod converge;
mod plot;
mod table;

pub use plot::{LineStyle, PlotError, PlotOptions, Series, log_log_plot, log_log_plot_with};
pub use table::Table;

//! Reports: tables and plots of measurements (benchmarks, convergence). Everything here
//! writes files atomically (see [`crate::output`]).

mod plot;
mod table;

pub use plot::{PlotError, Series, log_log_plot};
pub use table::Table;

//! The tools around the renderer: they use it, it never uses them.
//!
//! - [`cli`]: the `ember` command line;
//! - [`bench`]: intersection strategies, the path tracer against Embree alone, kernels;
//! - [`check`]: the hard-case suite;
//! - [`converge`]: convergence studies (error against samples and seconds);
//! - [`report`]: tables, CSV, plots and image error metrics — it formats and writes, and
//!   renders nothing.

pub mod bench;
pub mod check;
pub mod cli;
pub mod report;

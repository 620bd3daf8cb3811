//! The tools around the renderer: they use it, it never uses them.
//!
//! - [`cli`]: the `ember` command line;
//! - [`bench`]: intersection strategies, the path tracer against Embree alone, kernels;
//! - [`check`]: the hard-case suite;
//! - [`converge`]: convergence studies: renders at 1, 2, 4, … spp, their error against a
//!   reference, its slope and the time to reach a target;
//! - [`report`]: tables, CSV and plots — it formats and writes, and renders and measures
//!   nothing.

pub mod bench;
pub mod check;
pub mod cli;
pub mod converge;
pub mod report;

/// `eprintln!` that never panics: with stderr closed or full (`ember … 2>&1 | true`, a
/// terminal gone), the text is lost, not the command's work.
macro_rules! say {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($arg)*);
    }};
}

/// `println!` that never panics: with stdout closed (`ember info … | head -1`), the text is
/// lost, not the command's work.
macro_rules! out {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout(), $($arg)*);
    }};
}

pub(crate) use {out, say};

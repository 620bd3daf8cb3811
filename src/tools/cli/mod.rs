//! The `ember` command line: argument parsing and the sub-commands. `main.rs` only calls
//! [`main`].

mod bench;
mod check;
mod converge;
mod info;
mod interrupt;
mod merge;
mod progress;
mod render;

use crate::tools::say;
use clap::{Parser, Subcommand};
use std::process::ExitCode;

#[derive(Parser, Debug)]
#[command(name = "ember", version, about = "A physically based path tracer on Intel Embree")]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Render a scene (.toml) or a mesh (.obj, .ply, .gltf, .glb) to an image (.png or .exr),
    /// or one shard of it (--shard K/N) to a .shard file.
    Render(render::RenderArgs),
    /// Put the shard files of one image together into the image a whole render gives.
    Merge(merge::MergeArgs),
    /// Print a scene's or mesh's primitive counts, bounds and effects, the kernel, path depth,
    /// Russian roulette and light choice a render would use, and the BVH build time.
    Info(info::InfoArgs),
    /// Measure intersection strategies and the path tracer against Embree alone (with
    /// --specialize: the specialised kernels against the general one).
    Bench(bench::BenchArgs),
    /// Measure error (relMSE and FLIP) against a high-spp reference at 1, 2, 4, … spp for
    /// several estimator variants, noisy and denoised: converge.csv, plots of error against spp
    /// and against time, and a table of the time each variant takes to reach a target relMSE
    /// and FLIP, saying which variants are biased.
    Converge(converge::ConvergeArgs),
    /// Run the hard-case suite (numerical robustness) and print a table; exit code 1 if a
    /// case fails.
    Check(check::CheckArgs),
}

/// Runs the command line. Exit codes: 0 success; 1 `ember check` found a failing case; 2 bad
/// input or environment (errors are printed as `error: …`); 128 + the signal's number when a
/// render was stopped by a signal (130 SIGINT, 143 SIGTERM).
pub fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(a) => render::run(a).map(|()| ExitCode::SUCCESS),
        Command::Info(a) => info::run(a).map(|()| ExitCode::SUCCESS),
        Command::Merge(a) => merge::run(a).map(|()| ExitCode::SUCCESS),
        Command::Bench(a) => bench::run_bench(a).map(|()| ExitCode::SUCCESS),
        Command::Converge(a) => converge::run(a).map(|()| ExitCode::SUCCESS),
        Command::Check(a) => check::run(a),
    };
    match result {
        Ok(code) => code,
        Err(e) if e.is::<interrupt::Interrupted>() => {
            say!("{e}");
            ExitCode::from(e.downcast_ref::<interrupt::Interrupted>().map_or(130, interrupt::Interrupted::exit_code))
        }
        Err(e) => {
            say!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}

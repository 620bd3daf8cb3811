//! The `ember` command line: argument parsing and the sub-commands. `main.rs` only calls
//! [`main`].

mod bench;
mod info;
mod render;

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
    /// Render a scene (.toml) or a mesh (.obj) to an image (.png or .exr).
    Render(render::RenderArgs),
    /// Print primitive counts, bounds and BVH build time of a scene or mesh.
    Info(info::InfoArgs),
    /// Measure intersection strategies, the path tracer against Embree alone, and kernels.
    Bench(bench::BenchArgs),
}

/// Runs the command line; errors are printed as `error: …` and give exit code 2.
pub fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(a) => render::run(a),
        Command::Info(a) => info::run(a),
        Command::Bench(a) => bench::run_bench(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::from(2)
        }
    }
}

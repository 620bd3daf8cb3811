use crate::embree::BuildQuality;
use crate::settings::PathLoop;
use crate::tools::bench::scenes::{BUILTIN, default_scenes_dir};
use crate::tools::bench::{Options, RenderBvh, Section, run};
use clap::Args;
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct BenchArgs {
    /// Intersection-matrix scene: teapot, bunny, blob-1k, blob-10k, blob-100k, blob-1m,
    /// shapes-100, shapes-1k, or a .obj/.toml file; repeatable. Runs the matrix only.
    #[arg(long)]
    pub scene: Vec<String>,
    /// Folder for bench.csv, scaling.png, render.csv and specialize.csv (created if missing).
    #[arg(long, default_value = "bench-results")]
    pub out: PathBuf,
    /// A smoke run of about 20 s (on 2 cores): small scenes, few rays, tiny renders.
    #[arg(long)]
    pub quick: bool,
    /// Run only the render section: path tracer vs Embree alone, 1 vs 2 threads.
    #[arg(long, conflicts_with_all = ["specialize", "scene"])]
    pub render: bool,
    /// Run only the specialised-vs-general kernel table, on each .toml and .obj in the scenes folder.
    #[arg(long, conflicts_with = "scene")]
    pub specialize: bool,
    /// Threads for the intersection matrix [all cores].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub threads: Option<u32>,
    /// Folder of the sample scenes and models [./scenes, else the source tree's].
    #[arg(long)]
    pub scenes_dir: Option<PathBuf>,
    /// With --render: the Embree BVH build quality of the renders and the replay (low, medium
    /// or high) [the one `ember render` builds for each scene].
    #[arg(long, requires = "render")]
    pub bvh_quality: Option<BuildQuality>,
    /// With --render: build without RTC_SCENE_FLAG_ROBUST, as in `ember render --no-robust`.
    #[arg(long, requires = "render")]
    pub no_robust: bool,
    /// With --render: how the renders advance their paths, as in `ember render --path-loop`
    /// (scalar or wavefront) [scalar].
    #[arg(long, requires = "render")]
    pub path_loop: Option<PathLoop>,
}

pub fn run_bench(args: BenchArgs) -> anyhow::Result<()> {
    for s in &args.scene {
        if !BUILTIN.contains(&s.as_str()) && !s.ends_with(".obj") && !s.ends_with(".toml") {
            anyhow::bail!("--scene: unknown scene {s:?} (expected {} or a .obj/.toml file)", BUILTIN.join(", "));
        }
    }
    let sections = if args.render {
        vec![Section::Render]
    } else if args.specialize {
        vec![Section::Specialize]
    } else if !args.scene.is_empty() {
        vec![Section::Matrix]
    } else {
        vec![Section::Matrix, Section::Render]
    };
    let opts = Options {
        scenes: args.scene,
        out: args.out,
        quick: args.quick,
        sections,
        threads: args.threads.map(|t| t as usize),
        scenes_dir: args.scenes_dir.unwrap_or_else(default_scenes_dir),
        render_bvh: RenderBvh { quality: args.bvh_quality, robust: !args.no_robust },
        render_loop: args.path_loop.unwrap_or(PathLoop::Scalar),
    };
    run(&opts)?;
    Ok(())
}

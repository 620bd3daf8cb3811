use crate::accel::AccelKind;
use crate::embree::{BuildOptions, BuildQuality};
use crate::film::{Checkpoint, ImageFormat, checkpoint_path};
use crate::integrator::{Estimator, KernelChoice, RenderControl, RenderSettings, RrDepth, render_controlled};
use crate::limits::{self, MemoryLimit};
use crate::scene::format::MAX_IMAGE_SIDE;
use crate::scene::{DepthLimit, Effects, Scene};
use clap::Args;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

#[derive(Args, Debug)]
pub struct RenderArgs {
    /// Scene file (.toml) or mesh (.obj).
    pub scene: PathBuf,
    /// Output image: .png (8-bit sRGB) or .exr (linear float).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Samples per pixel [scene's render.spp, else 64].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    pub spp: Option<u32>,
    /// Image width in pixels [scene's render.width, else 640].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=MAX_IMAGE_SIDE as i64))]
    pub width: Option<u32>,
    /// Image height in pixels [scene's render.height, else 480].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=MAX_IMAGE_SIDE as i64))]
    pub height: Option<u32>,
    /// Maximum bounces: 0 = emitters only, 1 = direct light [scene's render.max_depth, else 8].
    #[arg(long)]
    pub max_depth: Option<u32>,
    /// Russian roulette after this many bounces; "off" disables it; "auto" chooses from the
    /// scene's albedo [scene's render.rr_depth, else auto].
    #[arg(long)]
    pub rr_depth: Option<String>,
    /// Worker threads [all cores].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub threads: Option<u32>,
    /// Random seed [scene's render.seed, else 0].
    #[arg(long)]
    pub seed: Option<u64>,
    /// Intersection strategy: embree or naive.
    #[arg(long, default_value = "embree")]
    pub accel: AccelKind,
    /// Embree BVH build quality: low, medium or high (`ember bench` measures each).
    #[arg(long, default_value = "medium")]
    pub bvh_quality: BuildQuality,
    /// Build the Embree BVH without RTC_SCENE_FLAG_ROBUST, as Embree's own tutorials do:
    /// faster, but a ray passing exactly through an edge shared by two triangles can miss both
    /// (hard case axis-parallel-rays).
    #[arg(long)]
    pub no_robust: bool,
    /// Adaptive sampling: stop sampling a pixel once its estimated relative error is below
    /// this (e.g. 0.01); --spp is then the most a pixel gets [scene's render.spp, else 1024].
    #[arg(long, value_parser = parse_target_error)]
    pub target_error: Option<f32>,
    /// Continue the interrupted render whose checkpoint is next to the output
    /// (<output>.checkpoint); scene and settings must be the same.
    #[arg(long)]
    pub resume: bool,
    /// Also write the checkpoint periodically, e.g. 60s or 5m (it is always written when the
    /// render is interrupted by Ctrl-C or SIGTERM).
    #[arg(long)]
    pub checkpoint_every: Option<CliDuration>,
    /// Run the general kernel instead of the one specialised to the scene's effects.
    #[arg(long)]
    pub no_specialize: bool,
    /// Estimator: nee-mis, nee, bsdf or bsdf-uniform.
    #[arg(long, default_value = "nee-mis")]
    pub estimator: Estimator,
    /// Fail (exit 2, no image written) if any sample was NaN or infinite.
    #[arg(long)]
    pub strict: bool,
}

fn parse_target_error(s: &str) -> Result<f32, String> {
    match s.parse::<f32>() {
        Ok(e) if e > 0.0 && e < 1.0 => Ok(e),
        _ => Err(format!("expected a relative error between 0 and 1 (e.g. 0.01), found {s:?}")),
    }
}

/// Refuses an image, or image plus scene plus BVH, that would exceed the memory limit.
fn check_memory(
    args: &RenderArgs,
    scene: &Scene,
    settings: &RenderSettings,
    limit: &MemoryLimit,
) -> anyhow::Result<()> {
    let at = |e: limits::LimitError| anyhow::anyhow!("{}: {e}", args.scene.display());
    let (w, h) = (settings.width, settings.height);
    let film = limits::film_bytes(w, h);
    limit.check(format!("image {w}x{h}"), "of film memory", film).map_err(at)?;
    let (tris, spheres, cylinders) = scene.primitive_counts();
    let bvh = match args.accel {
        AccelKind::Embree => limits::embree_bytes(tris as u64, (spheres + cylinders) as u64),
        AccelKind::Naive => 0,
    };
    let data = scene.data_bytes();
    let f = limits::format_bytes;
    limit
        .check(
            format!("rendering {tris} triangles, {} spheres and cylinders at {w}x{h}", spheres + cylinders),
            &format!("(scene data {}, {} {}, film {})", f(data), args.accel_name(), f(bvh), f(film)),
            data + bvh + film,
        )
        .map_err(at)
}

impl RenderArgs {
    fn accel_name(&self) -> &'static str {
        match self.accel {
            AccelKind::Embree => "Embree BVH",
            AccelKind::Naive => "naive accel",
        }
    }
}

/// Settings from the command line, then the scene file, then built-in defaults.
fn settings(args: &RenderArgs, scene: &Scene) -> anyhow::Result<RenderSettings> {
    let s = RenderSettings::from_scene(&scene.render);
    let rr_depth = match args.rr_depth.as_deref() {
        Some(v) => v.parse::<RrDepth>().map_err(|e| anyhow::anyhow!("--rr-depth: {e}"))?,
        None => s.rr_depth,
    };
    Ok(RenderSettings {
        width: args.width.unwrap_or(s.width),
        height: args.height.unwrap_or(s.height),
        spp: args.spp.or(scene.render.spp).unwrap_or(if args.target_error.is_some() { 1024 } else { s.spp }),
        max_depth: args.max_depth.unwrap_or(s.max_depth),
        rr_depth,
        seed: args.seed.unwrap_or(s.seed),
        threads: args.threads.map(|t| t as usize),
        estimator: args.estimator,
        progress: true,
        specialize: !args.no_specialize,
        target_error: args.target_error,
    })
}

/// The render was stopped by a signal; a checkpoint was written.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct Interrupted(pub String);

/// Set by the first SIGINT/SIGTERM; a second one exits at once.
static STOP: AtomicBool = AtomicBool::new(false);

fn install_signal_handler() {
    let result = ctrlc::set_handler(|| {
        if STOP.swap(true, Ordering::SeqCst) {
            eprintln!("\ninterrupted again: quitting without a checkpoint");
            std::process::exit(130);
        }
        eprintln!(
            "\ninterrupt: finishing the pixels in flight, then writing a checkpoint (interrupt again to quit at once)"
        );
    });
    if let Err(e) = result {
        eprintln!("warning: cannot catch interrupts ({e}); an interrupted render will be lost");
    }
}

/// The command line that continues this render.
fn resume_command() -> String {
    let mut args: Vec<String> = std::env::args().collect();
    if !args.iter().any(|a| a == "--resume") {
        args.push("--resume".into());
    }
    args.iter().map(|a| if a.contains(' ') { format!("'{a}'") } else { a.clone() }).collect::<Vec<_>>().join(" ")
}

pub fn run(args: RenderArgs) -> anyhow::Result<()> {
    ImageFormat::from_path(&args.output)?;
    let limit = MemoryLimit::from_env().map_err(anyhow::Error::msg)?;
    crate::output::check_writable(&args.output)?;
    let scene = Scene::load(&args.scene)?;
    for w in &scene.warnings {
        eprintln!("warning: {w}");
    }
    let settings = settings(&args, &scene)?;
    check_memory(&args, &scene, &settings, &limit)?;
    let checkpoint = checkpoint_path(&args.output);
    let resume = if args.resume {
        let c = Checkpoint::load(&checkpoint)?;
        let (_, mean, _) = c.accum.spp_range();
        eprintln!("resuming from {} ({mean:.1} of {} spp done)", checkpoint.display(), settings.spp);
        Some((checkpoint.as_path(), c))
    } else {
        if checkpoint.exists() {
            eprintln!(
                "warning: {} holds an interrupted render; this render starts over (use --resume to continue it)",
                checkpoint.display()
            );
        }
        None
    };
    let bvh = BuildOptions { quality: args.bvh_quality, robust: !args.no_robust, ..BuildOptions::default() };
    let accel = args.accel.build_with(&scene.geometry, bvh)?;
    let effects = scene.effects();
    eprintln!("{effects}");
    eprintln!("{}", describe_plan(&effects, &settings));
    install_signal_handler();
    let control = RenderControl {
        stop: Some(&STOP),
        checkpoint: Some((checkpoint.as_path(), args.checkpoint_every.map(|d| d.0))),
        resume,
    };
    let result = render_controlled(&scene, accel.as_ref(), &settings, control)?;
    let stats = result.stats;
    if !result.complete {
        let (_, mean, _) = stats.spp;
        return Err(Interrupted(format!(
            "interrupted after {:.1} s with {mean:.1} of {} spp done; checkpoint written to {}\nresume with: {}",
            (stats.elapsed + stats.earlier_sessions).as_secs_f64(),
            settings.spp,
            checkpoint.display(),
            resume_command()
        ))
        .into());
    }
    let film = result.accum.film();
    // A pixel can overflow to infinity even when every sample was finite (a sum of huge values).
    let bad_pixels = film.pixels.iter().filter(|p| !p.is_finite()).count();
    if args.strict && (stats.nonfinite > 0 || bad_pixels > 0) {
        anyhow::bail!(
            "{}: {} of {} samples were NaN or infinite (dropped) and {} pixels are not finite; --strict allows none, so {} was not written",
            args.scene.display(),
            stats.nonfinite,
            stats.samples,
            bad_pixels,
            args.output.display()
        );
    }
    film.save(&args.output)?;
    if checkpoint.exists() {
        std::fs::remove_file(&checkpoint)
            .map_err(|e| anyhow::anyhow!("{}: cannot remove finished checkpoint: {e}", checkpoint.display()))?;
    }
    let (min_spp, mean_spp, max_spp) = stats.spp;
    let spp = if min_spp == max_spp {
        format!("{max_spp} spp")
    } else {
        format!("{min_spp}..{max_spp} spp (mean {mean_spp:.1})")
    };
    eprintln!(
        "rendered {}x{} at {spp} in {:.2} s{}: {:.2} Mrays/s ({} rays, {}), {} non-finite samples dropped -> {}",
        settings.width,
        settings.height,
        stats.elapsed.as_secs_f64(),
        if stats.earlier_sessions.is_zero() {
            String::new()
        } else {
            format!(" (plus {:.2} s before the interruption)", stats.earlier_sessions.as_secs_f64())
        },
        stats.mrays_per_s(),
        stats.rays,
        match args.accel {
            AccelKind::Embree => format!("embree accel, {bvh}"),
            AccelKind::Naive => "naive accel".to_string(),
        },
        stats.nonfinite,
        args.output.display()
    );
    let (mean_err, max_err) = stats.error_estimate;
    match settings.target_error {
        Some(e) => eprintln!(
            "estimated relative error: mean {mean_err:.4}, max {max_err:.4} (target {e}; pixels stop at {} spp at most)",
            settings.spp
        ),
        None => eprintln!("estimated relative error: mean {mean_err:.4}, max {max_err:.4}"),
    }
    Ok(())
}

/// A duration on the command line: `90`, `90s`, `1.5m`, `2h`.
#[derive(Clone, Copy, Debug)]
pub struct CliDuration(pub Duration);

impl std::str::FromStr for CliDuration {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let (num, unit) = match s.find(|c: char| c.is_ascii_alphabetic()) {
            Some(i) => s.split_at(i),
            None => (s, "s"),
        };
        let scale = match unit {
            "s" => 1.0,
            "m" | "min" => 60.0,
            "h" => 3600.0,
            _ => return Err(format!("unknown unit {unit:?} in {s:?} (use s, m or h)")),
        };
        let v: f64 = num.trim().parse().map_err(|_| format!("expected a duration such as 60s or 5m, found {s:?}"))?;
        if !(v * scale > 0.0 && v * scale < 1e9) {
            return Err(format!("duration {s:?} must be positive"));
        }
        Ok(CliDuration(Duration::from_secs_f64(v * scale)))
    }
}

/// `kernel: …; path depth N (why); russian roulette …`: what a render with these settings
/// runs (only `max_depth`, `rr_depth` and `specialize` of `settings` matter).
pub(crate) fn describe_plan(effects: &Effects, settings: &RenderSettings) -> String {
    let max_depth = settings.max_depth;
    let (kernel, used) = KernelChoice::plan(effects, max_depth, settings.specialize);
    let depth = if used == max_depth {
        format!("{used} (--max-depth)")
    } else {
        match effects.depth_limit() {
            DepthLimit::EmittersOnly => {
                format!("{used} (nothing scatters light: emitters only; --max-depth {max_depth})")
            }
            DepthLimit::DirectOnly => {
                format!("{used} (direct light only: nothing can bounce light onward; --max-depth {max_depth})")
            }
            DepthLimit::Unbounded => format!("{used}"),
        }
    };
    let rr = match (settings.rr_depth, settings.rr_start(effects)) {
        (RrDepth::Off, _) => "russian roulette off (--rr-depth off)".to_string(),
        (RrDepth::After(n), _) => format!("russian roulette from depth {n} (--rr-depth {n})"),
        (RrDepth::Auto, Some(k)) => format!("russian roulette from depth {k} (scene albedo ≤ {:.2})", effects.albedo),
        (RrDepth::Auto, None) => {
            let why = match crate::scene::throughput_depth(effects.albedo) {
                _ if !effects.scattering => "nothing scatters light".to_string(),
                None => format!("scene albedo {:.2}: throughput never falls to 1/2", effects.albedo),
                Some(k) => format!(
                    "scene albedo ≤ {:.2}: it would start at depth {k}, the path depth is {}",
                    effects.albedo,
                    effects.depth_limit().apply(max_depth)
                ),
            };
            format!("russian roulette off ({why})")
        }
    };
    format!("kernel: {kernel}; path depth {depth}; {rr}")
}

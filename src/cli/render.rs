use crate::accel::{Accel, AccelKind, EmbreeAccel, NaiveAccel};
use crate::embree::{BuildOptions, Device};
use crate::film::ImageFormat;
use crate::integrator::{Estimator, RenderSettings, RenderStats, render};
use crate::scene::{DepthLimit, Effects, Scene};
use crate::scene::format::MAX_IMAGE_SIDE;
use clap::Args;
use std::path::PathBuf;

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
    /// Russian roulette after this many bounces; "off" disables it [scene's, else 3].
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
    /// Run the general kernel instead of the one specialised to the scene's effects.
    #[arg(long)]
    pub no_specialize: bool,
    /// Estimator: nee-mis (default), nee, bsdf, bsdf-uniform.
    #[arg(long, default_value = "nee-mis")]
    pub estimator: Estimator,
}

/// Settings from the command line, then the scene file, then built-in defaults.
fn settings(args: &RenderArgs, scene: &Scene) -> anyhow::Result<RenderSettings> {
    let d = RenderSettings::default();
    let r = &scene.render;
    let rr_depth = match args.rr_depth.as_deref() {
        Some("off") => u32::MAX,
        Some(s) => s.parse().map_err(|_| anyhow::anyhow!("--rr-depth: expected a number or \"off\", found {s:?}"))?,
        None => r.rr_depth.unwrap_or(d.rr_depth),
    };
    Ok(RenderSettings {
        width: args.width.or(r.width).unwrap_or(d.width),
        height: args.height.or(r.height).unwrap_or(d.height),
        spp: args.spp.or(r.spp).unwrap_or(d.spp),
        max_depth: args.max_depth.or(r.max_depth).unwrap_or(d.max_depth),
        rr_depth,
        seed: args.seed.or(r.seed).unwrap_or(d.seed),
        threads: args.threads.map(|t| t as usize),
        estimator: args.estimator,
        progress: true,
        specialize: !args.no_specialize,
        ..d
    })
}

pub fn run(args: RenderArgs) -> anyhow::Result<()> {
    ImageFormat::from_path(&args.output)?;
    let scene = Scene::load(&args.scene)?;
    for w in &scene.warnings {
        eprintln!("warning: {w}");
    }
    let settings = settings(&args, &scene)?;
    let device;
    let accel: Box<dyn Accel> = match args.accel {
        AccelKind::Embree => {
            device = Device::new()?;
            Box::new(EmbreeAccel::new(&device, &scene.geometry, BuildOptions::default())?)
        }
        AccelKind::Naive => Box::new(NaiveAccel::new(&scene.geometry)),
    };
    let (film, stats) = render(&scene, accel.as_ref(), &settings)?;
    film.save(&args.output)?;
    eprintln!("{}", stats.effects);
    eprintln!("{}", describe_kernel(&stats, &settings));
    eprintln!(
        "rendered {}x{} at {} spp in {:.2} s: {:.2} Mrays/s ({} rays, {} accel), {} non-finite samples dropped -> {}",
        settings.width,
        settings.height,
        settings.spp,
        stats.elapsed.as_secs_f64(),
        stats.mrays_per_s(),
        stats.rays,
        accel.name(),
        stats.nonfinite,
        args.output.display()
    );
    Ok(())
}

/// `kernel: lens off, …; path depth 1 (direct light only: …)`
pub(crate) fn describe_kernel(stats: &RenderStats, settings: &RenderSettings) -> String {
    format!("kernel: {}; path depth {}", stats.kernel, describe_depth(&stats.effects, settings.max_depth, settings.specialize))
}

/// The path depth a render uses, and why.
pub(crate) fn describe_depth(effects: &Effects, max_depth: u32, specialize: bool) -> String {
    let used = if specialize { effects.depth_limit().apply(max_depth) } else { max_depth };
    if used == max_depth {
        return format!("{used} (--max-depth)");
    }
    match effects.depth_limit() {
        DepthLimit::EmittersOnly => format!("{used} (nothing scatters light: emitters only; --max-depth {max_depth})"),
        DepthLimit::DirectOnly => format!("{used} (direct light only: nothing can bounce light onward; --max-depth {max_depth})"),
        DepthLimit::Unbounded => format!("{used}"),
    }
}

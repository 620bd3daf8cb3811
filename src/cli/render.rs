use crate::accel::{Accel, AccelKind, EmbreeAccel, NaiveAccel};
use crate::embree::{BuildOptions, Device};
use crate::film::ImageFormat;
use crate::integrator::{Estimator, RenderSettings, render};
use crate::scene::Scene;
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
    /// Estimator: nee-mis (default), nee, bsdf, bsdf-uniform.
    #[arg(long, default_value = "nee-mis")]
    pub estimator: Estimator,
    /// Fail (exit 2, no image written) if any sample was NaN or infinite.
    #[arg(long)]
    pub strict: bool,
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

use super::progress::ProgressBar;
use crate::accel::AccelKind;
use crate::atomic_write::write_file;
use crate::film::Film;
use crate::scene::Scene;
use crate::scene::format::MAX_IMAGE_SIDE;
use crate::tools::converge::{ConvergencePoint, Study, parse_variants, spp_ladder};
use crate::tools::report::converge::{time_to_reach_table, to_csv, write_plots};
use crate::tools::{out, say};
use anyhow::Context;
use clap::Args;
use std::path::PathBuf;

/// How many times the largest measured spp the reference gets by default.
const REFERENCE_FACTOR: u32 = 16;

#[derive(Args, Debug)]
pub struct ConvergeArgs {
    /// Scene file (.toml) or mesh (.obj). Of its [render] table only the seed is used: size,
    /// spp, depth and Russian roulette come from the options below.
    pub scene: PathBuf,
    /// Reference image (.exr, linear) to measure against, e.g. DIR/reference.exr of an
    /// earlier run [rendered: NEE+MIS at full depth, --reference-spp samples].
    #[arg(long)]
    pub reference: Option<PathBuf>,
    /// Folder for converge.csv, the plots and reference.exr (created if missing).
    #[arg(long, default_value = "converge")]
    pub out: PathBuf,
    /// Image width in pixels.
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=MAX_IMAGE_SIDE as i64))]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..=MAX_IMAGE_SIDE as i64))]
    pub height: u32,
    /// Largest spp measured: renders at 1, 2, 4, … up to this.
    #[arg(long, default_value_t = 256, value_parser = clap::value_parser!(u32).range(1..=1 << 20))]
    pub max_spp: u32,
    /// Samples per pixel of the rendered reference [16 × --max-spp].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    pub reference_spp: Option<u32>,
    /// Comma-separated variants: groups estimators, no-rr, depth, samplers, adaptive (NEE+MIS
    /// with every pixel at the rung's spp, and adaptive), light-vertices (NEE+MIS as the
    /// scene decides, with light vertices on, and off), light-tree (NEE+MIS, and with many
    /// lights chosen by power instead of through a light tree), denoise (NEE+MIS and its denoised variants: Open Image
    /// Denoise given colour only, or albedo and normal noisy, prefiltered or clean), all
    /// (estimators, no-rr, depth, denoise), or single variants
    /// ESTIMATOR[/no-rr][/depth=D][/sobol|/independent][/env-uniform][/adaptive][/light-vertices=on|off][/light-tree=off][/clamp=X][/denoise[=color|noisy|prefilter|clean]]
    /// with ESTIMATOR one of nee-mis, nee, bsdf, bsdf-uniform (/env-uniform: an environment
    /// image sampled uniformly, not by luminance; /adaptive: the rung's spp as a mean, spent
    /// where the image is noisy; /clamp=X: `ember render --clamp X`, biased).
    #[arg(long, default_value = "all")]
    pub variants: String,
    /// Full depth: bounce limit of the reference and of every variant without /depth=D.
    #[arg(long, default_value_t = 64, value_parser = clap::value_parser!(u32).range(1..))]
    pub max_depth: u32,
    /// Russian roulette starts after this many bounces (variants with it on, and the reference).
    #[arg(long, default_value_t = 3)]
    pub rr_depth: u32,
    /// Renders per spp with different seeds; errors and times are averaged.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub repeats: u32,
    /// Target relMSE for the "time to reach" table.
    #[arg(long, default_value_t = 0.01)]
    pub target: f64,
    /// Target mean FLIP error (perceptual, 0 to 1) for the "time to reach" table.
    #[arg(long, default_value_t = 0.05)]
    pub target_flip: f64,
    /// Random seed [scene's render.seed, else 0].
    #[arg(long)]
    pub seed: Option<u64>,
    /// Worker threads [all cores].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub threads: Option<u32>,
    /// Intersection strategy: embree or naive.
    #[arg(long, default_value = "embree")]
    pub accel: AccelKind,
}

pub fn run(args: ConvergeArgs) -> anyhow::Result<()> {
    if !(args.target > 0.0 && args.target.is_finite()) {
        anyhow::bail!("--target: expected a positive number, found {}", args.target);
    }
    if !(args.target_flip > 0.0 && args.target_flip <= 1.0) {
        anyhow::bail!("--target-flip: expected a number in (0, 1], found {}", args.target_flip);
    }
    let mut variants =
        parse_variants(&args.variants, args.max_depth).map_err(|e| anyhow::anyhow!("--variants: {e}"))?;
    if variants.iter().any(|v| v.denoise.is_some()) {
        // Before anything is rendered. Without the library, the default `all` runs the
        // variants that need none; denoised variants asked for by name fail, saying how to
        // install it.
        if let Err(e) = crate::oidn::Denoiser::new() {
            if args.variants != "all" {
                anyhow::bail!(
                    "{e}\n(the denoised variants need it; --variants estimators,no-rr,depth runs without it)"
                );
            }
            say!("warning: the denoised variants are left out: {e}");
            variants.retain(|v| v.denoise.is_none());
        }
    }
    let scene = Scene::load(&args.scene)?;
    for w in &scene.warnings {
        say!("warning: {w}");
    }
    let study = Study {
        width: args.width,
        height: args.height,
        max_depth: args.max_depth,
        rr_depth: args.rr_depth,
        seed: args.seed.or(scene.render.seed).unwrap_or(0),
        threads: args.threads.map(|t| t as usize),
        ladder: spp_ladder(args.max_spp),
        repeats: args.repeats,
    };
    // A given reference is checked before any rendering starts.
    let given = match &args.reference {
        Some(path) => {
            let film = Film::load_exr(path)?;
            study.check_reference(path, &film)?;
            Some(film)
        }
        None => None,
    };
    std::fs::create_dir_all(&args.out).with_context(|| format!("{}: cannot create folder", args.out.display()))?;
    if !scene.effects().lit {
        say!("warning: {}: {}", args.scene.display(), super::render::UNLIT);
    }

    let accel = args.accel.build(&scene.geometry)?;

    let largest = *study.ladder.last().expect("the ladder has at least 1 spp");
    let reference = match given {
        Some(film) => {
            say!(
                "reference: {} (given; its own error also lands in every measurement)",
                args.reference.as_ref().unwrap().display()
            );
            film
        }
        None => {
            let spp = args.reference_spp.unwrap_or(largest.saturating_mul(REFERENCE_FACTOR));
            let bar = ProgressBar::new("reference                    ");
            let rendered = study.render_reference(&scene, accel.as_ref(), spp, Some(&|p| bar.update(p)));
            bar.finish();
            let (film, stats) = rendered?;
            let path = args.out.join("reference.exr");
            film.save(&path)?;
            say!(
                "reference: {spp} spp, nee-mis, depth {}, seed {} in {:.1} s -> {} \
                 (its own error adds about {:.1}% to the relMSE at {largest} spp)",
                study.max_depth,
                study.seed,
                stats.elapsed.as_secs_f64(),
                path.display(),
                100.0 * largest as f64 / spp as f64
            );
            film
        }
    };

    let mut all: Vec<ConvergencePoint> = Vec::new();
    let mut per_variant: Vec<Vec<ConvergencePoint>> = Vec::new();
    for &v in &variants {
        let bar = ProgressBar::new(&format!("{:<28} ", v.name()));
        let measured = study.measure(&scene, accel.as_ref(), &reference, v, |_| {}, Some(&|p| bar.update(p)));
        bar.finish();
        let points = measured?;
        let secs: f64 = points.iter().map(|m| m.seconds).sum::<f64>() * study.repeats as f64;
        let (first, last) = (&points[0], &points[points.len() - 1]);
        say!(
            "{:<28} {:>4}..{} spp in {:>6.1} s: relMSE {:.3e} -> {:.3e}, FLIP {:.4} -> {:.4}",
            v.name(),
            first.spp,
            last.spp,
            secs,
            first.error.rel_mse,
            last.error.rel_mse,
            first.error.flip,
            last.error.flip
        );
        all.extend(points.iter().cloned());
        per_variant.push(points);
    }

    let csv = args.out.join("converge.csv");
    write_file(&csv, to_csv(&all, study.max_depth, study.repeats).as_bytes())?;
    let plots = write_plots(&args.out, &all, study.max_depth, args.target, args.target_flip)?;

    out!("{}", time_to_reach_table(&per_variant, largest, args.target, args.target_flip).trim_end_matches('\n'));
    let files: Vec<String> = std::iter::once(&csv).chain(&plots).map(|p| p.display().to_string()).collect();
    say!("wrote {}", files.join(", "));
    Ok(())
}

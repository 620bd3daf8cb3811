//! `ember render`: load the scene, check memory, plan, build the accelerator, render (with
//! signals, checkpoints and resumption), write the image and say what was done.

mod args;
mod summary;

pub use args::RenderArgs;
pub(crate) use args::parse_exposure;
pub(crate) use summary::denoised as denoised_summary;

use super::interrupt::{self, Interrupted, Phase};
use super::progress::ProgressBar;
use crate::film::shard::ShardHeader;
use crate::film::{Accumulator, Checkpoint, Film, ImageFormat, Look, RenderImages, checkpoint_path};
use crate::integrator::{RenderControl, RenderPlan, render_controlled};
use crate::memory::{self, LoadBudget, MemoryLimit};
use crate::output_lock::{OutputLock, lock_path};
use crate::scene::Scene;
use crate::tools::say;
use std::os::unix::fs::MetadataExt;
use std::path::Path;

/// Why a scene without light renders black, and what to do about it.
pub(super) const UNLIT: &str =
    "nothing in the scene emits light: the image will be black; add a light, an emissive material or a [background]";

pub fn run(args: RenderArgs) -> anyhow::Result<()> {
    // A shard file holds the linear sums for `ember merge`; an image has its format.
    let format = if args.shard.is_some() {
        if !args.output.extension().is_some_and(|e| e.eq_ignore_ascii_case("shard")) {
            anyhow::bail!(
                "{}: --shard writes a shard file for `ember merge`: give the output a name ending in .shard",
                args.output.display()
            );
        }
        None
    } else {
        Some(ImageFormat::from_path(&args.output)?)
    };
    if args.aux && format.is_some_and(|f| f != ImageFormat::Exr) {
        anyhow::bail!(
            "{}: --aux writes the albedo, normal and sample count as EXR layers; a PNG cannot hold them (use .exr)",
            args.output.display()
        );
    }
    let limit = MemoryLimit::from_env().map_err(anyhow::Error::msg)?;
    let checkpoint = checkpoint_path(&args.output);
    let lock = lock_path(&args.output);
    crate::atomic_write::check_name_length(&args.output, &[(&checkpoint, "its checkpoint"), (&lock, "its lock file")])?;
    crate::atomic_write::check_writable(&args.output)?;
    // From here a signal ends ember without writing anything until the render starts, then
    // stops it cleanly (see `interrupt`).
    interrupt::install_handler(&args.output, "render");
    let embree = args.accel == crate::accel::AccelKind::Embree;
    let budget =
        LoadBudget::for_render(limit, embree, args.width, args.height).with_external_files(args.allow_external_files);
    let mut scene = Scene::load_within(&args.scene, &budget)?;
    if let Some(env) = &args.env {
        let (strength, rotate) = (args.env_strength.unwrap_or(1.0), args.env_rotate.unwrap_or(0.0));
        scene.set_environment(env, strength, rotate, &budget).map_err(|e| anyhow::anyhow!("--env: {e}"))?;
    }
    for w in &scene.warnings {
        say!("warning: {w}");
    }
    let settings = args::settings(&args, &scene)?;
    if settings.adaptive && settings.shard.is_some() && !args.first_round && args.plan_from.is_empty() {
        anyhow::bail!("{}: {}", args.scene.display(), crate::integrator::RenderError::AdaptiveShard);
    }
    // The library is loaded before rendering: a render is not spent on a denoise that fails.
    // A shard is not a whole image: it keeps the albedo and normal sums, and `ember merge`
    // denoises the merged image.
    let denoise = args::denoise(&args, &scene);
    let denoiser = if denoise && settings.shard.is_none() {
        Some(crate::oidn::Denoiser::new()?.cancel_when(&interrupt::STOP))
    } else {
        None
    };
    // The film is counted already; what this render keeps beside it is counted here.
    let (w, h) = (settings.width, settings.height);
    let extra = memory::render_extra_bytes(w, h, settings.aux, settings.adaptive, denoiser.is_some());
    let what = format!("image {w}x{h}'s auxiliary images, adaptive plan and denoiser buffers");
    budget.admit(what, extra).map_err(|e| anyhow::anyhow!("{}: {e}", args.scene.display()))?;
    budget.keep(extra);
    // Every emitting triangle is a light to sample: its own record and a light tree's share.
    let emitting = scene.emitting_primitives();
    let lights = crate::light::LightSet::bytes_for(emitting);
    budget
        .admit(format!("the lights of {emitting} emitting triangles and spheres"), lights)
        .map_err(|e| anyhow::anyhow!("{}: {e}", args.scene.display()))?;
    budget.keep(lights);
    let denoiser = match denoiser {
        Some(d) => {
            let scratch = memory::denoiser_scratch_bytes(budget.available()).ok_or_else(|| {
                let e = budget.admit("the denoiser's scratch memory (200 MB at least)", 200_000_000).err();
                anyhow::anyhow!("{}: {}", args.scene.display(), e.map_or_else(String::new, |e| e.to_string()))
            })?;
            budget.keep(scratch);
            Some(d.scratch_memory(scratch))
        }
        None => None,
    };
    let aspect = settings.width as f32 / settings.height as f32;
    let camera = args::camera_override(&args);
    let automatic = scene.camera.is_none();
    scene
        .override_camera(&camera, aspect)
        .map_err(|e| anyhow::anyhow!("{}: {e} (--camera-position, --look-at)", args.scene.display()))?;
    // Said when the camera is not the scene file's: a scene file can then take it.
    let given = (!camera.is_empty()).then_some("the command line");
    let camera_text = (automatic || given.is_some()).then(|| super::info::camera_lines(&scene, aspect, given));
    let look = args::look(&args, &scene);
    if format != Some(ImageFormat::Png) && !look.is_default() {
        say!(
            "note: exposure {} and tone curve {} apply to 8-bit output only; {} is linear, unscaled radiance",
            look.exposure,
            look.tonemap,
            args.output.display()
        );
    }
    refuse_overwriting_inputs(
        &scene.inputs,
        "the scene reads this file",
        &[
            (&args.output, "the image of the render"),
            (&checkpoint, "the checkpoint of the render"),
            (&lock, "the lock file of the render"),
        ],
    )?;
    let plan = RenderPlan::new(&scene, &settings);
    if plan.caustics {
        let light = memory::light_paths_bytes(w, h);
        budget
            .admit(format!("image {w}x{h}'s caustic light paths"), light)
            .map_err(|e| anyhow::anyhow!("{}: {e}", args.scene.display()))?;
        budget.keep(light);
    }
    if !plan.effects.lit {
        // Said before anything is rendered or written, on its own line.
        if args.strict {
            anyhow::bail!(
                "{}: {UNLIT}; --strict refuses a black image, so {} was not written",
                args.scene.display(),
                args.output.display()
            );
        }
        say!("warning: {}: {UNLIT}", args.scene.display());
    }
    // Held until this function returns, whichever way; removes OUT.lock then.
    let _lock = OutputLock::acquire(&args.output)?;
    // The plan's build: the quality the scene calls for unless told (`build_quality_for`).
    let bvh = plan.bvh;
    let resume = if args.resume {
        // Checked against this render before anything is read: size, scene, settings,
        // accelerator, contents.
        let key = plan.checkpoint_key(scene.fingerprint(), &args.accel.image_key(bvh));
        let c = Checkpoint::load(&checkpoint, &key)?;
        let (_, mean, _) = c.accum.spp_range();
        say!("resuming from {} ({mean:.1} spp on average done, --spp {})", checkpoint.display(), settings.spp);
        Some((checkpoint.as_path(), c))
    } else {
        if is_file(&checkpoint) {
            say!(
                "warning: {} holds an interrupted render; this render starts over (use --resume to continue it)",
                checkpoint.display()
            );
        }
        None
    };
    // What a shard file of this render says of itself (a first round keeps the plan's data).
    let shard_header = |shard, first_round: bool, nonfinite: u64, elapsed| ShardHeader {
        scene: scene.fingerprint(),
        settings: plan.image_key(&args.accel.image_key(bvh)),
        shard,
        width: settings.width,
        height: settings.height,
        spp: plan.max_pixel_spp(),
        nonfinite,
        elapsed,
        aux: settings.aux,
        denoise,
        first_round,
        plan: first_round && settings.adaptive,
        light: plan.caustics && !first_round,
        light_pixels: 0, // counted when saved
    };
    // Stage 2 of a shard: the whole image's first round, from every shard's stage 1.
    let first_rounds = match settings.shard {
        Some(shard) if !args.plan_from.is_empty() => {
            let expected = shard_header(shard, true, 0, std::time::Duration::ZERO);
            let limits = (settings.spp, plan.max_rays_per_sample());
            Some(read_first_rounds(&args.plan_from, &expected, &args.output, limits)?)
        }
        _ => None,
    };
    let accel = args.accel.build_with(&scene.geometry, bvh)?;
    say!("{}", plan.effects);
    say!("{plan}");
    if let Some(text) = &camera_text {
        say!("{}", text.trim_end());
    }
    interrupt::set_phase(Phase::Rendering);
    if interrupt::stop_requested() {
        return Err(Interrupted::by_signal("interrupted before rendering started; nothing was written".into()).into());
    }
    let bar = ProgressBar::new("");
    // Through the final image's own writer: the same format, look and atomic replacement.
    let preview = |film: &Film| -> Result<(), String> {
        let images = RenderImages { image: film, denoised: None, albedo: None, normal: None, sample_count: None };
        images.save_with(&args.output, &look).map_err(|e| e.to_string())
    };
    let control = RenderControl {
        stop: Some(&interrupt::STOP),
        checkpoint: Some((checkpoint.as_path(), args.checkpoint_every.map(|d| d.0))),
        resume,
        progress: Some(&|p| bar.update(p)),
        preview: args.preview_every.map(|d| (d.0, &preview as &crate::integrator::PreviewFn)),
        first_round_only: args.first_round,
        first_rounds,
    };
    let result = render_controlled(&scene, accel.as_ref(), &plan, control);
    bar.finish();
    if let Err(crate::integrator::RenderError::StoppedInLightPaths) = result {
        return Err(Interrupted::by_signal(
            "interrupted while tracing the caustics' light paths, before the first pixel; nothing was written".into(),
        )
        .into());
    }
    let result = result?;
    for w in &result.warnings {
        say!("warning: {w}");
    }
    let stats = result.stats;
    let elapsed = stats.elapsed + stats.earlier_sessions;
    let resume_with = || format!("resume with: {}", interrupt::resume_command());
    if !result.complete {
        let (_, mean, _) = stats.spp;
        // What the bar showed, in the same words.
        let share = bar.fraction().map_or(String::new(), |f| format!(", {:.0}% of the render done", 100.0 * f));
        return Err(Interrupted::by_signal(format!(
            "interrupted after {:.1} s{share} ({mean:.1} spp on average so far, --spp {}); checkpoint written to {}\n{}",
            elapsed.as_secs_f64(),
            settings.spp,
            checkpoint.display(),
            resume_with()
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
    let denoised = match &denoiser {
        Some(d) => {
            interrupt::set_phase(Phase::Denoising);
            // It can take a while: said before, so that the wait is not a mystery.
            say!("denoising {w}x{h} with Open Image Denoise ({})…", args.denoise_aux.describe());
            let start = std::time::Instant::now();
            match crate::film::denoise(d, &result.accum, args.denoise_aux) {
                Ok(image) => Some((image, start.elapsed())),
                Err(crate::oidn::DenoiseError::Cancelled) => {
                    // The render is complete: its checkpoint, resumed, only denoises and writes.
                    let key = plan.checkpoint_key(scene.fingerprint(), &args.accel.image_key(bvh));
                    let nonfinite = stats.nonfinite;
                    let c = Checkpoint {
                        scene: key.scene,
                        settings: key.settings,
                        nonfinite,
                        elapsed,
                        accum: result.accum,
                    };
                    c.save(&checkpoint)?;
                    return Err(Interrupted::by_signal(format!(
                        "{} while denoising: the render was complete; checkpoint written to {} (resuming it only denoises and writes the image)\n{}",
                        interrupt::name(interrupt::signal()),
                        checkpoint.display(),
                        resume_with()
                    ))
                    .into());
                }
                Err(e) => return Err(e.into()),
            }
        }
        None => None,
    };
    interrupt::set_phase(Phase::Writing);
    match settings.shard {
        Some(shard) => {
            let header = shard_header(shard, args.first_round, stats.nonfinite, elapsed);
            crate::film::shard::save(&args.output, &header, &result.accum)?;
        }
        None => write_images(&result.accum, &film, denoised.as_ref().map(|(d, _)| d), &args.output, &look)?,
    }
    // Only a regular file: a folder or a link someone put there is not ours to remove.
    if is_file(&checkpoint) {
        std::fs::remove_file(&checkpoint)
            .map_err(|e| anyhow::anyhow!("{}: cannot remove finished checkpoint: {e}", checkpoint.display()))?;
    }
    let accel_text = match args.accel {
        crate::accel::AccelKind::Embree => format!("embree accel, {bvh}"),
        crate::accel::AccelKind::Naive => "naive accel".to_string(),
    };
    say!("{}", summary::rendered(&stats, &accel_text, &args.output));
    for line in summary::adaptive(&stats)
        .into_iter()
        .chain(summary::clamped(&stats))
        .chain(summary::light_visibility(&stats))
        .chain(summary::surface_light_vertices(&stats))
    {
        say!("{line}");
    }
    if let (Some((_, took)), Some(d), Some(format)) = (&denoised, &denoiser, format) {
        say!("{}", summary::denoised(*took, d, args.denoise_aux, format));
    }
    say!("{}", summary::error_estimate(&stats));
    if interrupt::stop_requested() {
        return Err(Interrupted::by_signal(format!(
            "{} while {} was written: it was written in full; the render is finished",
            interrupt::name(interrupt::signal()),
            args.output.display()
        ))
        .into());
    }
    Ok(())
}

/// The whole image's first round for stage 2 of shard `expected.shard`: the first-round files
/// `paths` (every shard's once, each of this render: `expected` but for the shard index and the
/// time and non-finite count), put together; with the time and non-finite count of the shard's
/// own first round. None of them may be `output`.
fn read_first_rounds(
    paths: &[std::path::PathBuf],
    expected: &ShardHeader,
    output: &Path,
    (spp, rays_per_sample): (u32, u64),
) -> anyhow::Result<crate::integrator::FirstRounds> {
    use crate::film::shard::{ShardReader, incomplete, mismatch};
    let this = Path::new("this render");
    let readers = paths.iter().map(|p| ShardReader::open(p)).collect::<Result<Vec<_>, _>>()?;
    let out_id = file_id(output);
    for r in &readers {
        if !r.header.first_round {
            anyhow::bail!("--plan-from {}: not a first-round file (rendered without --first-round)", r.path.display());
        }
        if out_id.is_some() && file_id(&r.path) == out_id {
            anyhow::bail!("{}: --plan-from reads this file; the shard's output must go elsewhere", output.display());
        }
        if let Some(why) = mismatch(expected, this, &r.header, &r.path) {
            anyhow::bail!("--plan-from: {why}");
        }
    }
    if let Some(why) = incomplete(&readers) {
        anyhow::bail!("--plan-from: {why}");
    }
    let own = readers.iter().find(|r| r.header.shard == expected.shard).expect("every shard is there");
    let (elapsed, nonfinite) = (own.header.elapsed, own.header.nonfinite);
    let (w, h) = (expected.width, expected.height);
    let mut accum = Accumulator::empty(w, h, expected.aux, expected.plan);
    let owners: Vec<(crate::settings::Shard, std::path::PathBuf)> =
        readers.iter().map(|r| (r.header.shard, r.path.clone())).collect();
    for r in readers {
        r.read_into(&mut accum).map_err(|e| anyhow::anyhow!("--plan-from: {e}"))?;
    }
    // Each pixel's part of the plan could have come from this render.
    if let Some(stored) = &accum.adaptive
        && let Some((pixel, why)) =
            crate::integrator::adaptive::stored_plan_problem(&accum.pixels, stored, w, h, spp, rays_per_sample)
    {
        let (x, y) = pixel.map_or((0, 0), |i| (i as u32 % w, i as u32 / w));
        let file = owners.iter().find(|(s, _)| pixel.is_some() && s.owns_pixel(x, y)).map(|(_, p)| p.display());
        match file {
            Some(file) => anyhow::bail!("--plan-from {file}: not a valid ember shard file ({why})"),
            None => anyhow::bail!("--plan-from: the first rounds could not have come from this render ({why})"),
        }
    }
    Ok(crate::integrator::FirstRounds { accum, elapsed, nonfinite })
}

/// Whether `path` is a regular file itself (not a link to one).
fn is_file(path: &Path) -> bool {
    std::fs::symlink_metadata(path).is_ok_and(|m| m.is_file())
}

/// The device and inode of the file at `p` (links followed), if there is one: the same file
/// whatever the spelling of its path.
fn file_id(p: &Path) -> Option<(u64, u64)> {
    std::fs::metadata(p).ok().map(|m| (m.dev(), m.ino()))
}

/// Refuses to write any of `outputs` (path, what it would hold) that is one of `inputs` (the
/// same file, whatever the spelling, links followed): writing would destroy it. `reads` says
/// who reads it, e.g. `the scene reads this file`.
pub(super) fn refuse_overwriting_inputs(
    inputs: &[std::path::PathBuf],
    reads: &str,
    outputs: &[(&Path, &str)],
) -> anyhow::Result<()> {
    for &(out, what) in outputs {
        let Some(out_id) = file_id(out) else { continue };
        if let Some(input) = inputs.iter().find(|i| file_id(i) == Some(out_id)) {
            anyhow::bail!(
                "{}: {reads} ({}); writing {what} there would destroy it: choose another output",
                out.display(),
                input.display()
            );
        }
    }
    Ok(())
}

/// Writes a finished image: `film` (the accumulator's estimate), or its `denoised` image with
/// the noisy one as a layer, with the albedo, normal and sample-count images when the
/// accumulator kept them (EXR layers; a PNG holds the main image only).
pub(crate) fn write_images(
    accum: &Accumulator,
    film: &Film,
    denoised: Option<&Film>,
    output: &Path,
    look: &Look,
) -> anyhow::Result<()> {
    let (albedo, normal) = (accum.albedo(), accum.normal());
    let counts = accum.aux.is_some().then(|| accum.sample_counts());
    let images = RenderImages {
        image: film,
        denoised,
        albedo: albedo.as_ref(),
        normal: normal.as_ref(),
        sample_count: counts.as_deref(),
    };
    images.save_with(output, look)?;
    Ok(())
}

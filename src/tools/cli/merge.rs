//! `ember merge`: the shard files of one image (`ember render --shard K/N`) put back together
//! into the image a whole render gives, bit for bit. Every shard file's header is read and
//! checked against the others before any pixel is: a missing or duplicate shard, a shard of
//! another scene or other settings, or a damaged file is refused, naming the files, and
//! nothing is written. Memory: one image's accumulator, the files read one at a time.
//!
//! Shards rendered with `--aux` or `--denoise` hold the albedo and normal sums too: the merge
//! writes them as layers of an EXR, as a whole render does, and denoises the merged image when
//! the shards were rendered with `--denoise` or the merge is given it.

use super::render::parse_exposure;
use crate::film::shard::{ShardHeader, ShardReader, incomplete, mismatch};
use crate::film::{Accumulator, AuxMode, ImageFormat, Look, Tonemap};
use crate::memory::{self, MemoryLimit};
use crate::output_lock::{OutputLock, lock_path};
use crate::tools::say;
use clap::Args;
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct MergeArgs {
    /// The shard files, every shard of one image once (any order).
    #[arg(required = true)]
    pub shards: Vec<PathBuf>,
    /// Output image: .png (8-bit sRGB) or .exr (linear float).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Fail (exit 2, no image written) if a shard dropped NaN or infinite samples or a pixel
    /// is not finite.
    #[arg(long)]
    pub strict: bool,
    /// Exposure in stops for PNG output, as `ember render --exposure` (a scene's
    /// render.exposure is not in the shards: give it here) [0].
    #[arg(long, value_name = "EV", allow_negative_numbers = true, value_parser = parse_exposure)]
    pub exposure: Option<f32>,
    /// Tone curve for PNG output, as `ember render --tonemap`: clamp, aces or neutral [clamp].
    #[arg(long)]
    pub tonemap: Option<Tonemap>,
    /// Denoise the merged image with Intel Open Image Denoise, as `ember render --denoise`
    /// (the shards must have been rendered with --aux or --denoise, which keep the albedo and
    /// normal sums) [on if the shards were rendered with --denoise].
    #[arg(long)]
    pub denoise: bool,
    /// How the denoiser uses the albedo and normal images, as `ember render --denoise-aux`.
    #[arg(long, default_value = "prefilter")]
    pub denoise_aux: AuxMode,
}

pub fn run(args: MergeArgs) -> anyhow::Result<()> {
    let format = ImageFormat::from_path(&args.output)?;
    let look = Look { exposure: args.exposure.unwrap_or(0.0), tonemap: args.tonemap.unwrap_or_default() };
    if format != ImageFormat::Png && !look.is_default() {
        say!(
            "note: exposure {} and tone curve {} apply to 8-bit output only; {} is linear, unscaled radiance",
            look.exposure,
            look.tonemap,
            args.output.display()
        );
    }
    let limit = MemoryLimit::from_env().map_err(anyhow::Error::msg)?;
    let lock = lock_path(&args.output);
    crate::atomic_write::check_name_length(&args.output, &[(&lock, "its lock file")])?;
    crate::atomic_write::check_writable(&args.output)?;
    // The shards are the merge's state: a signal ends it at once, having written nothing.
    super::interrupt::install_handler(&args.output, "merge");
    super::render::refuse_overwriting_inputs(
        &args.shards,
        "the merge reads this file",
        &[(&args.output, "the merged image"), (&lock, "the lock file of the merge")],
    )?;
    // Held until this function returns, whichever way: a render or another merge to the same
    // output is refused meanwhile.
    let _lock = OutputLock::acquire(&args.output)?;
    // Every header first: refuse a wrong set before reading a pixel.
    let readers = args.shards.iter().map(|p| ShardReader::open(p)).collect::<Result<Vec<_>, _>>()?;
    let first = &readers[0];
    for r in &readers[1..] {
        if let Some(why) = mismatch(&first.header, &first.path, &r.header, &r.path) {
            anyhow::bail!("{why}; nothing was written");
        }
    }
    if let Some(why) = incomplete(&readers) {
        anyhow::bail!("{why}; nothing was written");
    }
    if first.header.first_round {
        anyhow::bail!(
            "{} is the first round of a shard (ember render --first-round), not a finished one: render each shard's second stage with --plan-from the first-round files, then merge those; nothing was written",
            first.path.display()
        );
    }
    let count = first.header.shard.count;
    let ShardHeader { width, height, aux, .. } = first.header;
    let denoise = args.denoise || first.header.denoise;
    if denoise && !aux {
        anyhow::bail!(
            "{}: --denoise needs the albedo and normal sums, which shards keep only when rendered with --aux or --denoise; nothing was written",
            first.path.display()
        );
    }
    // Loaded before the pixels are read: a missing library fails at once.
    let denoiser = if denoise { Some(crate::oidn::Denoiser::new()?) } else { None };
    let light = if first.header.light { memory::light_paths_bytes(width, height) } else { 0 };
    let bytes = memory::film_bytes(width, height)
        .saturating_add(memory::render_extra_bytes(width, height, aux, false, denoise))
        .saturating_add(light);
    limit
        .check(format!("image {width}x{height}"), "of film memory", bytes)
        .map_err(|e| anyhow::anyhow!("{}: {e}", first.path.display()))?;
    let denoiser = match denoiser {
        Some(d) => {
            let left = limit.bytes.map(|l| l.saturating_sub(bytes));
            let scratch = memory::denoiser_scratch_bytes(left).ok_or_else(|| {
                let need = bytes.saturating_add(200_000_000);
                let e = limit.check(format!("image {width}x{height} denoised"), "of film memory", need).err();
                anyhow::anyhow!("{}: {}", first.path.display(), e.map_or_else(String::new, |e| e.to_string()))
            })?;
            Some(d.scratch_memory(scratch))
        }
        None => None,
    };
    let nonfinite: u64 = readers.iter().map(|r| r.header.nonfinite).sum();
    let elapsed: std::time::Duration = readers.iter().map(|r| r.header.elapsed).sum();
    let mut accum = Accumulator::empty(width, height, aux, false);
    for r in readers {
        r.read_into(&mut accum).map_err(|e| anyhow::anyhow!("{e}; nothing was written"))?;
    }
    let film = accum.film();
    let bad_pixels = film.pixels.iter().filter(|p| !p.is_finite()).count();
    if args.strict && (nonfinite > 0 || bad_pixels > 0) {
        anyhow::bail!(
            "the shards dropped {nonfinite} NaN or infinite samples and {bad_pixels} pixels are not finite; --strict allows none, so {} was not written",
            args.output.display()
        );
    }
    let start = std::time::Instant::now();
    let denoised = denoiser.as_ref().map(|d| crate::film::denoise(d, &accum, args.denoise_aux)).transpose()?;
    let took = start.elapsed();
    // From here a signal lets the image be completed (a signal before the rename would
    // otherwise quit saying it was not written, as it would be true; after it, false).
    super::interrupt::set_phase(super::interrupt::Phase::Writing);
    super::render::write_images(&accum, &film, denoised.as_ref(), &args.output, &look)?;
    let (min, mean, max) = accum.spp_range();
    say!(
        "merged {count} shards into {width}x{height} at {} ({:.2} s of rendering in all), {nonfinite} non-finite samples dropped -> {}",
        if min == max { format!("{max} spp") } else { format!("{min}..{max} spp (mean {mean:.1})") },
        elapsed.as_secs_f64(),
        args.output.display()
    );
    if let (Some(_), Some(d)) = (denoised, &denoiser) {
        say!("{}", super::render::denoised_summary(took, d, args.denoise_aux, format));
    }
    if super::interrupt::stop_requested() {
        return Err(super::interrupt::Interrupted::by_signal(format!(
            "{} while {} was written: it was written in full; the merge is finished",
            super::interrupt::name(super::interrupt::signal()),
            args.output.display()
        ))
        .into());
    }
    Ok(())
}

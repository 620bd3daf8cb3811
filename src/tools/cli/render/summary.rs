//! The lines `ember render` prints when it is done.

use crate::integrator::RenderStats;
use std::path::Path;

/// `rendered WxH at N spp in T s: R Mrays/s (…, ACCEL), K non-finite samples dropped -> OUT`;
/// an adaptive render says `at M spp on average (adaptive: MIN..MAX per pixel)`, a target
/// error `at MIN..MAX spp per pixel (M on average)`.
pub(super) fn rendered(stats: &RenderStats, accel: &str, output: &Path) -> String {
    let settings = &stats.plan.settings;
    let (min_spp, mean_spp, max_spp) = stats.spp;
    let spp = if min_spp == max_spp {
        format!("{max_spp} spp")
    } else if settings.adaptive {
        format!("{} spp on average (adaptive: {min_spp}..{max_spp} per pixel)", mean(mean_spp))
    } else {
        format!("{min_spp}..{max_spp} spp per pixel ({} on average)", mean(mean_spp))
    };
    let earlier = if stats.earlier_sessions.is_zero() {
        String::new()
    } else {
        // An interrupted session resumed, or a shard's first round (`--first-round`).
        format!(" (plus {:.2} s earlier)", stats.earlier_sessions.as_secs_f64())
    };
    format!(
        "rendered {}x{} at {spp} in {:.2} s{earlier}: {:.2} Mrays/s ({} rays, {accel}), {} non-finite samples dropped -> {}",
        settings.width,
        settings.height,
        stats.elapsed.as_secs_f64(),
        stats.mrays_per_s(),
        stats.rays,
        stats.nonfinite,
        output.display()
    )
}

/// A mean spp: `64` when it is a whole number to the first decimal, else `63.7`.
fn mean(spp: f64) -> String {
    if (spp - spp.round()).abs() < 0.05 { format!("{}", spp.round()) } else { format!("{spp:.1}") }
}

/// Where an adaptive render's mean spp is more than 5% from the `--spp` asked, why: the line
/// `adaptive: 16.3 spp on average for --spp 32: …`.
pub(super) fn adaptive(stats: &RenderStats) -> Option<String> {
    let settings = &stats.plan.settings;
    let (_, mean_spp, _) = stats.spp;
    let asked = settings.spp as f64;
    if !settings.adaptive || (mean_spp / asked - 1.0).abs() <= 0.05 {
        return None;
    }
    let why = match stats.added_sample_cost {
        Some(c) if (c - 1.0).abs() > 0.05 => format!(
            "the noisy pixels it went to cost {c:.2}× the image's mean sample ({} bounces), so {} samples fit",
            if c > 1.0 { "more" } else { "fewer" },
            if c > 1.0 { "fewer" } else { "more" }
        ),
        _ => "its cap of 16× --spp per pixel and its rounding to packets of 8 samples left part of it unspent"
            .to_string(),
    };
    let spp = settings.spp;
    Some(format!(
        "adaptive: {} spp on average for --spp {spp}: the render takes about the time of {spp} samples in every pixel and spends it where the image is noisy; {why} (--uniform: {spp} in every pixel)",
        mean(mean_spp),
    ))
}

/// With a sample clamp, the line that says so and how many samples (and light-path splats)
/// it scaled down: `clamp 10 (biased): 1234 of 1966080 samples (0.063%) scaled down to it`.
pub(super) fn clamped(stats: &RenderStats) -> Option<String> {
    let limit = stats.plan.settings.clamp?;
    let samples = if stats.earlier_sessions.is_zero() {
        let percent = 100.0 * stats.clamped as f64 / stats.samples.max(1) as f64;
        let percent = if percent > 0.0 && percent < 0.001 { "< 0.001".to_string() } else { format!("{percent:.3}") };
        format!("{} of {} samples ({percent}%)", stats.clamped, stats.samples)
    } else {
        format!("{} samples of this session", stats.clamped)
    };
    let splats = match stats.clamped_splats {
        0 => String::new(),
        1 => ", and 1 splat of the caustics' light paths".to_string(),
        n => format!(", and {n} splats of the caustics' light paths"),
    };
    Some(format!(
        "clamp {limit} (biased: darker where light is concentrated): {samples}{splats} had a channel above it and were scaled down to it"
    ))
}

/// `denoised in T s (Open Image Denoise 2.5.1, albedo + normal, prefiltered; the EXR's main
/// layer, the noisy image in layer noisy)`
pub(crate) fn denoised(
    took: std::time::Duration,
    denoiser: &crate::oidn::Denoiser,
    mode: crate::film::AuxMode,
    format: crate::film::ImageFormat,
) -> String {
    let whereto = match format {
        crate::film::ImageFormat::Png => "the PNG holds the denoised image",
        crate::film::ImageFormat::Exr => "the EXR's main layer; the noisy image is layer noisy",
    };
    format!(
        "denoised in {:.2} s (Open Image Denoise {}, {}; {whereto})",
        took.as_secs_f64(),
        denoiser.version(),
        mode.describe()
    )
}

/// `estimated relative error: mean M, max X` (with the target, if adaptive).
pub(super) fn error_estimate(stats: &RenderStats) -> String {
    let settings = &stats.plan.settings;
    let (mean_err, max_err) = stats.error_estimate;
    if stats.spp.0 < 2 {
        // One sample says nothing of its error.
        return format!(
            "estimated relative error: none (it takes at least 2 samples a pixel; {} has {})",
            if stats.spp.0 == stats.spp.2 { "every pixel" } else { "some pixel" },
            stats.spp.0
        );
    }
    match settings.target_error {
        Some(e) if settings.aux => format!(
            "estimated relative error of the noisy image: mean {mean_err:.4}, max {max_err:.4} (target {e}; pixels stop at {} spp at most)",
            settings.spp
        ),
        Some(e) => format!(
            "estimated relative error: mean {mean_err:.4}, max {max_err:.4} (target {e}; pixels stop at {} spp at most)",
            settings.spp
        ),
        None => format!("estimated relative error: mean {mean_err:.4}, max {max_err:.4}"),
    }
}

/// Where the light choice was weighed by visibility (`--light-visibility`): `light choice: by
/// importance × the share of light samples that got through, learned in N cells`.
pub(super) fn surface_light_vertices(stats: &RenderStats) -> Option<String> {
    stats.surface_light_vertices.map(|v| {
        let escaped = 100.0 * v.escaped;
        match v.pool {
            Some((kept, traced)) => format!(
                "light vertices: {kept} from the area lights, kept where the pass's paths went ({traced} light paths \
                 traced); {escaped:.0}% of the pass's bounces left the scene"
            ),
            None => format!(
                "light vertices: off: {escaped:.0}% of the pass's bounces left the scene (they pay where most stay \
                 in it; --light-vertices on connects anyway)"
            ),
        }
    })
}

pub(super) fn light_visibility(stats: &RenderStats) -> Option<String> {
    stats.light_visibility_cells.map(|n| {
        format!(
            "light choice: by importance × the share of light samples that got through, learned in {n} cells \
             (most light samples were blocked; --light-visibility off: by importance alone)"
        )
    })
}

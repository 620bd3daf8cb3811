//! The lines `ember render` prints when it is done.

use crate::integrator::RenderStats;
use std::path::Path;

/// `rendered WxH at N spp in T s: R Mrays/s (…, ACCEL), K non-finite samples dropped -> OUT`
pub(super) fn rendered(stats: &RenderStats, accel: &str, output: &Path) -> String {
    let settings = &stats.plan.settings;
    let (min_spp, mean_spp, max_spp) = stats.spp;
    let spp = if min_spp == max_spp {
        format!("{max_spp} spp")
    } else if settings.adaptive {
        format!("{min_spp}..{max_spp} spp (mean {mean_spp:.1}; adaptive, at the cost of {} spp)", settings.spp)
    } else {
        format!("{min_spp}..{max_spp} spp (mean {mean_spp:.1})")
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

/// With a sample clamp, the line that says so and how many samples it scaled down: `clamp 10
/// (biased): 1234 of 1966080 samples (0.063%) scaled down to it`.
pub(super) fn clamped(stats: &RenderStats) -> Option<String> {
    let limit = stats.plan.settings.clamp?;
    let samples = if stats.earlier_sessions.is_zero() {
        format!(
            "{} of {} samples ({:.3}%)",
            stats.clamped,
            stats.samples,
            100.0 * stats.clamped as f64 / stats.samples.max(1) as f64
        )
    } else {
        format!("{} samples of this session", stats.clamped)
    };
    Some(format!(
        "clamp {limit} (biased: darker where light is concentrated): {samples} had a channel above it and were scaled down to it"
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

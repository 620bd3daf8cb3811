//! Running a study: the spp ladder, the seeds, the renders of the reference and of each
//! variant at each rung, and the error of each render against the reference.
//!
//! Seeds: the reference is rendered with the study's seed itself; the render at rung k,
//! repeat j uses an unrelated seed derived from it ([`Study::render_seed`]), so no render
//! shares random numbers with the reference (a render whose samples were a prefix of the
//! reference's would look more accurate than it is). All variants use the same seed at the
//! same rung (common random numbers), which makes their curves easier to compare.
//!
//! A denoised variant renders as its noisy twin does (taking the auxiliary images changes no
//! random number, so its noisy image is the twin's, bit for bit), then denoises; its time is
//! the render's plus the denoiser's.

use super::metrics::{ImageDifference, SizeMismatch, image_difference};
use super::variant::Variant;
use crate::accel::Accel;
use crate::film::{Accumulator, AuxMode, Film};
use crate::integrator::{
    Estimator, Progress, RenderControl, RenderError, RenderPlan, RenderSettings, RenderStats, RrDepth,
    render_controlled,
};
use crate::light::{Background, Light};
use crate::oidn::{DenoiseError, Denoiser};
use crate::sampler::mix64;
use crate::scene::Scene;
use std::borrow::Cow;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Where a study reports the progress of its renders (called from the worker threads): for the
/// reference, its render's; for a variant, one count over all the renders of its ladder and
/// repeats (samples done of all of them, rays and time since the first began), so that a
/// progress bar of it runs once from 0 to 100%. The study draws nothing itself.
pub type ProgressFn<'a> = &'a (dyn Fn(Progress) + Sync);

/// The renders of a study already done when the next one starts, for [`ProgressFn`].
#[derive(Clone, Copy)]
struct Done {
    samples: u64,
    rays: u64,
    planned: u64,
    since: Instant,
}

/// 1, 2, 4, … up to `max_spp` (and `max_spp` itself when it is not a power of two).
pub fn spp_ladder(max_spp: u32) -> Vec<u32> {
    let mut ladder: Vec<u32> = (0..32).map(|k| 1u32 << k).take_while(|&s| s <= max_spp).collect();
    if ladder.last() != Some(&max_spp) && max_spp > 0 {
        ladder.push(max_spp);
    }
    ladder
}

/// What a study renders and how.
#[derive(Clone, Debug, PartialEq)]
pub struct Study {
    pub width: u32,
    pub height: u32,
    /// The full depth: that of the reference and of every variant without its own depth.
    pub max_depth: u32,
    /// Where Russian roulette starts when a variant has it on (and for the reference).
    pub rr_depth: u32,
    pub seed: u64,
    pub threads: Option<usize>,
    /// The spp of the measured renders, increasing.
    pub ladder: Vec<u32>,
    /// Renders per rung with different seeds; their errors and times are averaged.
    pub repeats: u32,
}

/// One point of a variant's convergence curve: its error and cost at one spp, averaged over
/// the study's repeats.
#[derive(Clone, Debug, PartialEq)]
pub struct ConvergencePoint {
    pub variant: Variant,
    pub spp: u32,
    /// Mean time to the image: the render ([`RenderStats::elapsed`], not the BVH build) and,
    /// for a denoised variant, the denoiser (`denoise_seconds`).
    pub seconds: f64,
    /// Of `seconds`, the mean time the denoiser took (0 for a noisy variant).
    pub denoise_seconds: f64,
    /// Mean rays traced per render.
    pub rays: f64,
    /// Mean error against the reference.
    pub error: ImageDifference,
    /// Non-finite samples the renders dropped, in total.
    pub nonfinite: u64,
}

#[cfg(test)]
impl ConvergencePoint {
    /// A full-depth NEE+MIS point with relMSE `rel_mse` (and nothing else measured), for the
    /// tests of what reads points.
    pub(crate) fn nee_mis(spp: u32, seconds: f64, rel_mse: f64) -> ConvergencePoint {
        ConvergencePoint {
            variant: Variant::new(Estimator::NeeMis),
            spp,
            seconds,
            denoise_seconds: 0.0,
            rays: 0.0,
            error: ImageDifference { rel_mse, mae: 0.0, flip: 0.0 },
            nonfinite: 0,
        }
    }
}

/// Why a study could not run.
#[derive(Debug, thiserror::Error)]
pub enum ConvergeError {
    #[error("{}: reference is {}x{} pixels but the study renders {}x{}", path.display(), found.0, found.1, expected.0, expected.1)]
    ReferenceSize { path: PathBuf, found: (u32, u32), expected: (u32, u32) },
    #[error("{}: reference pixel ({x}, {y}) is not finite", path.display())]
    ReferenceNotFinite { path: PathBuf, x: u32, y: u32 },
    #[error(transparent)]
    Render(#[from] RenderError),
    #[error(transparent)]
    Size(#[from] SizeMismatch),
    #[error(transparent)]
    Denoise(#[from] DenoiseError),
}

impl Study {
    /// The render settings of `variant` at `spp` with `seed`.
    pub fn settings(&self, variant: &Variant, spp: u32, seed: u64) -> RenderSettings {
        RenderSettings {
            width: self.width,
            height: self.height,
            spp,
            max_depth: variant.max_depth.unwrap_or(self.max_depth),
            rr_depth: if variant.russian_roulette { RrDepth::After(self.rr_depth) } else { RrDepth::Off },
            seed,
            threads: self.threads,
            estimator: variant.estimator,
            aux: matches!(variant.denoise, Some(AuxMode::With(_))),
            sampler: variant.sampler.unwrap_or_default(),
            adaptive: variant.adaptive,
            light_vertices: variant.light_vertices.unwrap_or_default(),
            light_tree: variant.light_tree.unwrap_or_default(),
            clamp: variant.clamp.map(|c| c.0),
            ..RenderSettings::default()
        }
    }

    /// The reference's settings: NEE+MIS at full depth with Russian roulette, the study's seed.
    pub fn reference_settings(&self, spp: u32) -> RenderSettings {
        self.settings(&Variant::new(Estimator::NeeMis), spp, self.seed)
    }

    /// The seed of the render at rung `rung` (index into the ladder), repeat `repeat`.
    pub fn render_seed(&self, rung: usize, repeat: u32) -> u64 {
        // "converge" in ASCII: the derived seeds are unrelated to small seeds given by hand.
        mix64(self.seed ^ 0x636f_6e76_6572_6765).wrapping_add(rung as u64 * self.repeats as u64 + repeat as u64)
    }

    /// Renders the reference at `spp`, reporting its progress to `progress`.
    pub fn render_reference(
        &self,
        scene: &Scene,
        accel: &dyn Accel,
        spp: u32,
        progress: Option<ProgressFn>,
    ) -> Result<(Film, RenderStats), RenderError> {
        let planned = self.width as u64 * self.height as u64 * spp as u64;
        let done = Done { samples: 0, rays: 0, planned, since: Instant::now() };
        let (accum, stats) =
            render_reporting(scene, accel, &self.reference_settings(spp), progress.map(|p| (p, done)))?;
        Ok((accum.film(), stats))
    }

    /// Refuses a reference (read from `path`) that does not fit the study: another size, or a
    /// non-finite pixel.
    pub fn check_reference(&self, path: &Path, reference: &Film) -> Result<(), ConvergeError> {
        if (reference.width, reference.height) != (self.width, self.height) {
            return Err(ConvergeError::ReferenceSize {
                path: path.to_path_buf(),
                found: (reference.width, reference.height),
                expected: (self.width, self.height),
            });
        }
        if let Some(i) = reference.pixels.iter().position(|p| !p.is_finite()) {
            let (x, y) = (i as u32 % reference.width, i as u32 / reference.width);
            return Err(ConvergeError::ReferenceNotFinite { path: path.to_path_buf(), x, y });
        }
        Ok(())
    }

    /// Renders `variant` at every rung of the ladder and measures it against `reference`;
    /// `on_point` sees each point as it is measured, `progress` the progress of all the
    /// variant's renders together. A denoised variant loads Open Image Denoise (and fails with
    /// [`ConvergeError::Denoise`] without it).
    pub fn measure(
        &self,
        scene: &Scene,
        accel: &dyn Accel,
        reference: &Film,
        variant: Variant,
        mut on_point: impl FnMut(&ConvergencePoint),
        progress: Option<ProgressFn>,
    ) -> Result<Vec<ConvergencePoint>, ConvergeError> {
        let repeats = self.repeats.max(1);
        let denoiser = match variant.denoise {
            Some(_) => Some(Denoiser::new()?),
            None => None,
        };
        let pixels = self.width as u64 * self.height as u64;
        let planned = self.ladder.iter().map(|&spp| spp as u64 * pixels * repeats as u64).sum();
        let mut done = Done { samples: 0, rays: 0, planned, since: Instant::now() };
        let scene = variant_scene(scene, &variant);
        let mut out = Vec::with_capacity(self.ladder.len());
        for (rung, &spp) in self.ladder.iter().enumerate() {
            let mut m = ConvergencePoint {
                variant,
                spp,
                seconds: 0.0,
                denoise_seconds: 0.0,
                rays: 0.0,
                error: ImageDifference::default(),
                nonfinite: 0,
            };
            for repeat in 0..repeats {
                let settings = self.settings(&variant, spp, self.render_seed(rung, repeat));
                let (accum, stats) = render_reporting(&scene, accel, &settings, progress.map(|p| (p, done)))?;
                done.samples += stats.samples;
                done.rays += stats.rays;
                let film = match (&denoiser, variant.denoise) {
                    (Some(d), Some(mode)) => {
                        let start = std::time::Instant::now();
                        let film = crate::film::denoise(d, &accum, mode)?;
                        m.denoise_seconds += start.elapsed().as_secs_f64();
                        film
                    }
                    _ => accum.film(),
                };
                let e = image_difference(&film, reference)?;
                m.seconds += stats.elapsed.as_secs_f64();
                m.rays += stats.rays as f64;
                m.error.rel_mse += e.rel_mse;
                m.error.mae += e.mae;
                m.error.flip += e.flip;
                m.nonfinite += stats.nonfinite;
            }
            let r = repeats as f64;
            m.seconds += m.denoise_seconds;
            (m.seconds, m.denoise_seconds, m.rays) = (m.seconds / r, m.denoise_seconds / r, m.rays / r);
            (m.error.rel_mse, m.error.mae, m.error.flip) = (m.error.rel_mse / r, m.error.mae / r, m.error.flip / r);
            on_point(&m);
            out.push(m);
        }
        Ok(out)
    }
}

/// Renders `scene` with `settings`, reporting progress (offset by the renders `Done` before
/// it) to the function given, if any; returns the accumulated samples (with the auxiliary
/// images if the settings take them).
fn render_reporting(
    scene: &Scene,
    accel: &dyn Accel,
    settings: &RenderSettings,
    progress: Option<(ProgressFn, Done)>,
) -> Result<(Accumulator, RenderStats), RenderError> {
    let report = |p: Progress| {
        if let Some((report, done)) = progress {
            report(Progress {
                work_done: done.samples as f64 + p.work_done,
                work_before: 0.0,
                work_planned: done.planned as f64,
                rays: done.rays + p.rays,
                elapsed: done.since.elapsed(),
                round: 1,
                rounds: 1,
                light_paths: None,
            })
        }
    };
    let control = RenderControl {
        progress: progress.is_some().then_some(&report as &(dyn Fn(Progress) + Sync)),
        ..RenderControl::default()
    };
    let r = render_controlled(scene, accel, &RenderPlan::new(scene, settings), control)?;
    Ok((r.accum, r.stats))
}

/// The scene `variant` renders: `scene` itself, or for `/env-uniform` a copy whose
/// environment image is sampled uniformly over the sphere (the lights in the same order, so
/// the choice among them is the same; the geometry, and so `accel`, unchanged).
fn variant_scene<'a>(scene: &'a Scene, variant: &Variant) -> Cow<'a, Scene> {
    if !variant.uniform_environment || !matches!(scene.background(), Background::Image(_)) {
        return Cow::Borrowed(scene);
    }
    let mut s = scene.clone();
    for light in &mut s.lights {
        if let Light::Background(Background::Image(env)) = light {
            *env = std::sync::Arc::new(env.uniformly_sampled());
        }
    }
    Cow::Owned(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ladder_is_powers_of_two_up_to_the_maximum() {
        assert_eq!(spp_ladder(1), vec![1]);
        assert_eq!(spp_ladder(16), vec![1, 2, 4, 8, 16]);
        assert_eq!(spp_ladder(20), vec![1, 2, 4, 8, 16, 20]);
    }
}

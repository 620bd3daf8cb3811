//! One run of a case: the Embree device, quality and seed it runs with, helpers that render
//! its scenes, and the count of non-finite values seen (every case must see none).

use super::{CheckError, Quality};
use crate::accel::{Accel, EmbreeAccel, NaiveAccel};
use crate::embree::{BuildOptions, Device};
use crate::film::Film;
use crate::geometry::Geometry;
use crate::integrator::{Estimator, RenderSettings, RrDepth, render};
use crate::scene::Scene;
use glam::Vec3;
use std::cell::Cell;

/// The state of one run of a case, handed to the case's check ([`super::Case::run_seeded`]
/// makes one per run).
pub struct CaseRun {
    pub device: Device,
    pub quality: Quality,
    /// The seed of the case's renders ([`CaseRun::settings`]; [`CaseRun::render_seeds`] derives its own
    /// from it).
    pub seed: u64,
    nonfinite: Cell<u64>,
}

impl CaseRun {
    pub fn new(quality: Quality, seed: u64) -> Result<CaseRun, CheckError> {
        Ok(CaseRun { device: Device::new()?, quality, seed, nonfinite: Cell::new(0) })
    }

    /// `quick` for `--quick`, else `full`.
    pub fn by_quality<T>(&self, quick: T, full: T) -> T {
        match self.quality {
            Quality::Quick => quick,
            Quality::Full => full,
        }
    }

    /// Non-finite samples, pixels or hit values seen so far.
    pub fn nonfinite(&self) -> u64 {
        self.nonfinite.get()
    }

    /// Records `count` non-finite values found by a case's own queries.
    pub fn add_nonfinite(&self, count: u64) {
        self.nonfinite.set(self.nonfinite.get() + count);
    }

    /// Settings for a `width` × `height` image at `spp`; the run's seed, all threads, no
    /// progress bar, the default Russian roulette (chosen from the scene).
    pub fn settings(&self, width: u32, height: u32, spp: u32) -> RenderSettings {
        RenderSettings { width, height, spp, seed: self.seed, ..RenderSettings::default() }
    }

    /// One-bounce furnace settings: BSDF sampling only, one bounce, no Russian roulette.
    pub fn bsdf_settings(&self, width: u32, height: u32, spp: u32, max_depth: u32) -> RenderSettings {
        RenderSettings {
            estimator: Estimator::BsdfOnly,
            max_depth,
            rr_depth: RrDepth::Off,
            ..self.settings(width, height, spp)
        }
    }

    pub fn embree(&self, scene: &Scene) -> Result<EmbreeAccel, CheckError> {
        self.embree_geometry(&scene.geometry)
    }

    pub fn embree_geometry(&self, geometry: &[Geometry]) -> Result<EmbreeAccel, CheckError> {
        Ok(EmbreeAccel::new(&self.device, geometry, BuildOptions::default())?)
    }

    /// Renders through `accel`, counting dropped samples and non-finite pixels.
    pub fn render_with(&self, scene: &Scene, accel: &dyn Accel, settings: &RenderSettings) -> Result<Film, CheckError> {
        let (film, stats) = render(scene, accel, settings)?;
        let bad_pixels = film.pixels.iter().filter(|p| !p.is_finite()).count() as u64;
        self.add_nonfinite(stats.nonfinite + bad_pixels);
        Ok(film)
    }

    /// Renders with Embree.
    pub fn render(&self, scene: &Scene, settings: &RenderSettings) -> Result<Film, CheckError> {
        let accel = self.embree(scene)?;
        self.render_with(scene, &accel, settings)
    }

    /// Renders with the naive all-primitive loop.
    pub fn render_naive(&self, scene: &Scene, settings: &RenderSettings) -> Result<Film, CheckError> {
        self.render_with(scene, &NaiveAccel::new(&scene.geometry), settings)
    }

    /// Renders with `seeds` seeds; returns the per-pixel mean and the standard error of that
    /// mean (grey values), for statistical tolerances. The seeds are the run's + 993 + 0 …
    /// seeds − 1: 1000 … at the default seed [`super::DEFAULT_SEED`], none of them the run's
    /// own.
    pub fn render_seeds(
        &self,
        scene: &Scene,
        settings: &RenderSettings,
        seeds: u64,
    ) -> Result<(Film, Vec<f64>), CheckError> {
        let accel = self.embree(scene)?;
        let first = self.seed.wrapping_add(1000 - super::DEFAULT_SEED);
        let films: Vec<Film> = (0..seeds)
            .map(|i| {
                self.render_with(scene, &accel, &RenderSettings { seed: first.wrapping_add(i), ..settings.clone() })
            })
            .collect::<Result<_, _>>()?;
        let n = seeds as f64;
        let mut mean = Film::new(settings.width, settings.height);
        let mut se = vec![0.0; mean.pixels.len()];
        for (i, (m_px, se_px)) in mean.pixels.iter_mut().zip(&mut se).enumerate() {
            let vals: Vec<f64> = films.iter().map(|f| super::pixel::grey(f.pixels[i])).collect();
            let m = vals.iter().sum::<f64>() / n;
            let var = vals.iter().map(|v| (v - m) * (v - m)).sum::<f64>() / (n - 1.0).max(1.0);
            *se_px = (var / n).sqrt();
            *m_px = films.iter().map(|f| f.pixels[i]).sum::<Vec3>() / seeds as f32;
        }
        Ok((mean, se))
    }
}

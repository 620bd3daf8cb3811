//! Acceleration structures: one trait, two strategies.
//!
//! [`EmbreeAccel`] registers the scene's geometry with Embree (meshes as triangle geometry,
//! spheres and cylinders as user geometry); [`NaiveAccel`] tests every primitive for every
//! ray, the baseline every benchmark compares against. Both number geometries by their index
//! in the scene's geometry list, so their hits are directly comparable.

mod embree;
mod naive;

pub use self::embree::{EmbreeAccel, build_options_for, build_options_with, build_quality_for};
pub use naive::NaiveAccel;

use crate::embree::EmbreeError;
pub use crate::geometry::LANES;
use crate::geometry::{Hit, Ray, RayPacket};

/// Why a query or a build failed.
#[derive(Debug, thiserror::Error)]
pub enum AccelError {
    #[error(transparent)]
    Embree(#[from] EmbreeError),
}

/// Closest-hit and occlusion queries for single rays.
pub trait Accel: Send + Sync {
    /// A short name for reports ("embree", "naive").
    fn name(&self) -> &'static str;
    /// What about this accelerator can change the image (hits differ in the last bits between
    /// strategies and build options), as `key=value` words for checkpoint keys:
    /// [`AccelKind::image_key`]. A wrapper that queries another accelerator should return
    /// that one's.
    fn image_key(&self) -> String {
        format!("accel={}", self.name())
    }
    /// The closest hit with `tmin < t < tmax` (Embree: `<=` at both ends), or `None`.
    fn intersect(&self, ray: &Ray, tmin: f32, tmax: f32) -> Result<Option<Hit>, AccelError> {
        let hit = self.intersect_deferred(ray, tmin, tmax);
        self.deferred_error()?;
        Ok(hit)
    }
    /// Whether anything lies between `tmin` and `tmax` along the ray.
    fn occluded(&self, ray: &Ray, tmin: f32, tmax: f32) -> Result<bool, AccelError> {
        let blocked = self.occluded_deferred(ray, tmin, tmax);
        self.deferred_error()?;
        Ok(blocked)
    }
    /// [`Accel::intersect`] for tight loops: an error is not returned here but by the next
    /// [`Accel::deferred_error`] (a loop checks once per path, not once per ray). After an
    /// error the answers are meaningless; they are discarded with the path.
    fn intersect_deferred(&self, ray: &Ray, tmin: f32, tmax: f32) -> Option<Hit>;
    /// [`Accel::occluded`] for tight loops (see [`Accel::intersect_deferred`]).
    fn occluded_deferred(&self, ray: &Ray, tmin: f32, tmax: f32) -> bool;
    /// Closest hits of the `active` lanes of a packet of [`LANES`] rays on
    /// `[tmin, tmax]`, errors deferred (inactive lanes give `None`). Meant for coherent rays
    /// (the samples of one pixel): Embree traces them together. The default asks lane by
    /// lane.
    fn intersect_packet_deferred(
        &self,
        rays: &RayPacket,
        active: [bool; LANES],
        tmin: f32,
        tmax: f32,
    ) -> [Option<Hit>; LANES] {
        std::array::from_fn(|i| if active[i] { self.intersect_deferred(&rays.ray(i), tmin, tmax) } else { None })
    }
    /// [`Accel::occluded_deferred`] for a packet, lane i on `[tmin, tmax[i]]` (inactive lanes
    /// give `false`).
    fn occluded_packet_deferred(
        &self,
        rays: &RayPacket,
        active: [bool; LANES],
        tmin: f32,
        tmax: [f32; LANES],
    ) -> [bool; LANES] {
        std::array::from_fn(|i| active[i] && self.occluded_deferred(&rays.ray(i), tmin, tmax[i]))
    }
    /// The error of any deferred query so far (errors are sticky).
    fn deferred_error(&self) -> Result<(), AccelError>;
    /// This accelerator as Embree's, if it is: render kernels are compiled for
    /// [`EmbreeAccel`] directly, so its queries inline into the path loop instead of going
    /// through the trait object.
    fn as_embree(&self) -> Option<&EmbreeAccel> {
        None
    }
}

/// Which strategy to build.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum AccelKind {
    #[default]
    Embree,
    Naive,
}

crate::choice::named_choice!(AccelKind, "accelerator");

impl AccelKind {
    pub const ALL: [AccelKind; 2] = [AccelKind::Embree, AccelKind::Naive];

    /// The name on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            AccelKind::Embree => "embree",
            AccelKind::Naive => "naive",
        }
    }

    /// Builds this accelerator over `geometry` as `ember render` does by default (Embree: on a
    /// new default device, with [`build_options_for`] the geometry; the scene keeps its device
    /// alive).
    pub fn build(self, geometry: &[crate::geometry::Geometry]) -> Result<Box<dyn Accel>, crate::embree::EmbreeError> {
        self.build_with(geometry, build_options_for(geometry))
    }

    /// [`AccelKind::build`] with Embree's build `options` (ignored by the naive loop).
    pub fn build_with(
        self,
        geometry: &[crate::geometry::Geometry],
        options: crate::embree::BuildOptions,
    ) -> Result<Box<dyn Accel>, crate::embree::EmbreeError> {
        Ok(match self {
            AccelKind::Embree => {
                let device = crate::embree::Device::with_kernels(options.kernels)?;
                Box::new(EmbreeAccel::new(&device, geometry, options)?)
            }
            AccelKind::Naive => Box::new(NaiveAccel::new(geometry)),
        })
    }
}

impl AccelKind {
    /// What about this accelerator built with `options` can change the image, as `key=value`
    /// words: `accel=embree bvh=medium robust=on compact=off kernels=avx2`, or `accel=naive`
    /// (which has no build options). [`Accel::image_key`] of what [`AccelKind::build_with`]
    /// returns.
    pub fn image_key(self, options: crate::embree::BuildOptions) -> String {
        let on = |b: bool| if b { "on" } else { "off" };
        match self {
            AccelKind::Embree => format!(
                "accel=embree bvh={} robust={} compact={} kernels={}",
                options.quality,
                on(options.robust),
                on(options.compact),
                options.kernels
            ),
            AccelKind::Naive => "accel=naive".to_string(),
        }
    }
}

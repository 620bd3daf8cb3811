//! The intersection strategies compared by the matrix.

use super::measure::Batch;
use super::rays::RayKind;
use crate::accel::{Accel, EmbreeAccel, NaiveAccel};
use crate::embree::{BuildOptions, BuildQuality, Device, EmbreeError};
use crate::geometry::Geometry;
use std::time::Duration;

/// One way of answering ray queries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Strategy {
    /// Every primitive for every ray ([`NaiveAccel`]).
    Naive,
    /// Embree; `tessellated`: spheres and cylinders as triangles instead of user geometry;
    /// `packets`: queries 8 at a time (`rtcIntersect8`/`rtcOccluded8`, consecutive queries of
    /// the workload: neighbouring pixels for camera rays; hinted coherent for camera rays
    /// only) instead of one by one.
    Embree { quality: BuildQuality, robust: bool, tessellated: bool, packets: bool },
}

impl Strategy {
    /// The strategies for a scene: the naive loop, Embree at low, medium and high build
    /// quality, medium with the robust flag, medium in packets of 8, and, when the scene has
    /// spheres or cylinders, medium with them tessellated.
    pub fn for_scene(has_shapes: bool) -> Vec<Strategy> {
        let e = |quality, robust, tessellated, packets| Strategy::Embree { quality, robust, tessellated, packets };
        let mut v = vec![
            Strategy::Naive,
            e(BuildQuality::Low, false, false, false),
            e(BuildQuality::Medium, false, false, false),
            e(BuildQuality::High, false, false, false),
            e(BuildQuality::Medium, true, false, false),
            e(BuildQuality::Medium, false, false, true),
        ];
        if has_shapes {
            v.push(e(BuildQuality::Medium, false, true, false));
        }
        v
    }

    /// How queries of `kind` are asked: 8 at a time for the packet strategy (camera rays hinted
    /// coherent, the others not), else one by one.
    pub fn batch(self, kind: RayKind) -> Batch {
        match self {
            Strategy::Embree { packets: true, .. } => Batch::Packets { coherent: kind == RayKind::Coherent },
            _ => Batch::Single,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Strategy::Naive => "naive",
            Strategy::Embree { tessellated: true, .. } => "embree-tess",
            Strategy::Embree { packets: true, .. } => "embree-packet8",
            Strategy::Embree { robust: true, .. } => "embree-robust",
            Strategy::Embree { quality: BuildQuality::Low, .. } => "embree-low",
            Strategy::Embree { quality: BuildQuality::Medium, .. } => "embree-medium",
            Strategy::Embree { quality: BuildQuality::High, .. } => "embree-high",
        }
    }

    pub fn tessellated(self) -> bool {
        matches!(self, Strategy::Embree { tessellated: true, .. })
    }

    /// Builds the accelerator over `geometry` (already tessellated if the strategy says so).
    /// Embree's build time (registration and BVH) is returned; the naive loop has none.
    pub fn build(
        self,
        device: &Device,
        geometry: &[Geometry],
    ) -> Result<(Box<dyn Accel>, Option<Duration>), EmbreeError> {
        Ok(match self {
            Strategy::Naive => (Box::new(NaiveAccel::new(geometry)), None),
            Strategy::Embree { quality, robust, .. } => {
                let a =
                    EmbreeAccel::new(device, geometry, BuildOptions { quality, robust, ..BuildOptions::default() })?;
                let t = a.build_time();
                (Box::new(a), Some(t))
            }
        })
    }
}

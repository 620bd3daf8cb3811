use super::{Accel, AccelError, LANES};
use crate::embree::{BuildOptions, Device, EmbreeError, Scene, SceneBuilder};
use crate::geometry::{Geometry, Hit, Ray};
use std::time::{Duration, Instant};

/// Intersection through Intel Embree: meshes as triangle geometry, spheres and cylinders as
/// user geometry calling back into [`crate::geometry::Shape`].
pub struct EmbreeAccel {
    scene: Scene,
    build_time: Duration,
    options: BuildOptions,
}

impl EmbreeAccel {
    /// Registers `geometry` (geometry id = list index) and builds the BVH.
    pub fn new(device: &Device, geometry: &[Geometry], options: BuildOptions) -> Result<Self, EmbreeError> {
        let start = Instant::now();
        let mut b = SceneBuilder::new(device, options)?;
        for (i, g) in geometry.iter().enumerate() {
            let id = match g {
                Geometry::Mesh(m) => b.add_triangles(&m.positions, &m.indices),
                Geometry::Spheres(s) => b.add_shapes(s.clone()),
                Geometry::Cylinders(c) => b.add_shapes(c.clone()),
            }
            .map_err(|e| match e {
                EmbreeError::InvalidInput(m) => EmbreeError::InvalidInput(format!("geometry {i}: {m}")),
                e => e,
            })?;
            debug_assert_eq!(id as usize, i);
        }
        let scene = b.commit()?;
        Ok(EmbreeAccel { scene, build_time: start.elapsed(), options })
    }

    /// Time spent registering geometry and building the BVH.
    pub fn build_time(&self) -> Duration {
        self.build_time
    }

    /// The underlying Embree scene.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }
}

impl Accel for EmbreeAccel {
    fn name(&self) -> &'static str {
        "embree"
    }

    fn image_key(&self) -> String {
        super::AccelKind::Embree.image_key(self.options)
    }

    #[inline(always)]
    fn intersect_deferred(&self, ray: &Ray, tmin: f32, tmax: f32) -> Option<Hit> {
        self.scene.intersect_deferred(ray, tmin, tmax)
    }

    #[inline(always)]
    fn occluded_deferred(&self, ray: &Ray, tmin: f32, tmax: f32) -> bool {
        self.scene.occluded_deferred(ray, tmin, tmax)
    }

    #[inline(always)]
    fn intersect_packet_deferred(
        &self,
        rays: &[Ray; LANES],
        active: [bool; LANES],
        tmin: f32,
        tmax: f32,
    ) -> [Option<Hit>; LANES] {
        self.scene.intersect8_deferred(rays, active, tmin, tmax)
    }

    #[inline(always)]
    fn occluded_packet_deferred(
        &self,
        rays: &[Ray; LANES],
        active: [bool; LANES],
        tmin: f32,
        tmax: f32,
    ) -> [bool; LANES] {
        self.scene.occluded8_deferred(rays, active, tmin, tmax)
    }

    #[inline(always)]
    fn deferred_error(&self) -> Result<(), AccelError> {
        Ok(self.scene.callback_failure()?)
    }

    fn as_embree(&self) -> Option<&EmbreeAccel> {
        Some(self)
    }
}

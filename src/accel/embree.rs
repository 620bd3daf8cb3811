use super::{Accel, AccelError, LANES};
use crate::embree::{BuildOptions, BuildQuality, Device, EmbreeError, Scene, SceneBuilder};
use crate::geometry::{Geometry, Hit, Ray, RayPacket};
use std::time::{Duration, Instant};

/// Intersection through Intel Embree: meshes as triangle geometry (placed meshes as instances
/// of a scene holding the mesh once), spheres and cylinders as user geometry calling back
/// into [`crate::geometry::Shape`].
pub struct EmbreeAccel {
    scene: Scene,
    build_time: Duration,
    options: BuildOptions,
}

impl EmbreeAccel {
    /// Registers `geometry` (geometry id = list index) and builds the BVH. The kernel set is
    /// `device`'s, whatever `options` says.
    pub fn new(device: &Device, geometry: &[Geometry], options: BuildOptions) -> Result<Self, EmbreeError> {
        let options = BuildOptions { kernels: device.kernels(), ..options };
        let start = Instant::now();
        let mut b = SceneBuilder::new(device, options)?;
        for (i, g) in geometry.iter().enumerate() {
            let id = match g {
                Geometry::Mesh(m) => b.add_mesh(m),
                Geometry::Instance(inst) => b.add_instance(&inst.mesh, &inst.to_world),
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

/// Scenes of at most this many triangles, and no spheres or cylinders, are built with
/// [`BuildQuality::Low`] unless told otherwise ([`build_quality_for`]).
pub const SMALL_SCENE_TRIANGLES: usize = 1_000;

/// The BVH build quality `ember render` uses when `--bvh-quality` is not given. Embree's
/// Morton builder (`low`) gives the small all-triangle scenes a BVH that costs 15–22% fewer
/// instructions per render than `medium`'s (the Cornell boxes, 34 triangles; callgrind,
/// docs/performance.md), while on the 6,320-triangle teapot the two are level and on spheres
/// and cylinders (user geometry) `low` is 1.3–1.7× slower: `medium` for everything else.
/// Which build does not change the image (the same hits, bit for bit, in these scenes).
pub fn build_quality_for(geometry: &[Geometry]) -> BuildQuality {
    let mut triangles = 0;
    for g in geometry {
        match g {
            Geometry::Mesh(m) => triangles += m.indices.len(),
            Geometry::Instance(i) => triangles += i.mesh.indices.len(),
            Geometry::Spheres(_) | Geometry::Cylinders(_) => return BuildQuality::Medium,
        }
    }
    if triangles <= SMALL_SCENE_TRIANGLES { BuildQuality::Low } else { BuildQuality::Medium }
}

/// The build options `ember render` (and `ember info`, `ember converge`) use unless told
/// otherwise: Embree's defaults (robust) at the quality [`build_quality_for`] the geometry.
pub fn build_options_for(geometry: &[Geometry]) -> BuildOptions {
    build_options_with(geometry, None, true)
}

/// The build options of `ember render`'s `--bvh-quality` (`quality`; `None`: the one
/// [`build_quality_for`] the geometry) and `--no-robust` (`robust` false).
pub fn build_options_with(geometry: &[Geometry], quality: Option<BuildQuality>, robust: bool) -> BuildOptions {
    BuildOptions { quality: quality.unwrap_or_else(|| build_quality_for(geometry)), robust, ..BuildOptions::default() }
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
        rays: &RayPacket,
        active: [bool; LANES],
        tmin: f32,
        tmax: f32,
    ) -> [Option<Hit>; LANES] {
        self.scene.intersect8_deferred(rays, active, tmin, tmax)
    }

    #[inline(always)]
    fn occluded_packet_deferred(
        &self,
        rays: &RayPacket,
        active: [bool; LANES],
        tmin: f32,
        tmax: [f32; LANES],
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Sphere, TriMesh};
    use glam::Vec3;
    use std::sync::Arc;

    fn mesh(triangles: usize) -> Geometry {
        let positions = vec![Vec3::ZERO, Vec3::X, Vec3::Y];
        Geometry::Mesh(Arc::new(TriMesh { positions, indices: vec![[0, 1, 2]; triangles], ..TriMesh::default() }))
    }

    #[test]
    fn small_triangle_scenes_get_the_morton_build() {
        assert_eq!(build_quality_for(&[mesh(34)]), BuildQuality::Low);
        assert_eq!(build_quality_for(&[mesh(600), mesh(400)]), BuildQuality::Low);
        assert_eq!(build_quality_for(&[mesh(600), mesh(401)]), BuildQuality::Medium);
        assert_eq!(build_quality_for(&[mesh(6320)]), BuildQuality::Medium);
        let sphere = Geometry::Spheres(vec![Sphere::new(Vec3::ZERO, 1.0)].into());
        assert_eq!(build_quality_for(&[mesh(34), sphere]), BuildQuality::Medium);
        assert_eq!(build_quality_for(&[]), BuildQuality::Low);
    }
}

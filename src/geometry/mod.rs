//! Geometry: rays, hits, bounds and the primitive intersection routines shared by both
//! acceleration structures. Knows nothing of materials, lights or Embree.

mod bounds;
mod cutout;
mod cylinder;
mod frame;
mod grid;
mod instance;
mod mesh;
mod packet;
mod ray;
mod spawn;
mod sphere;
mod triangle;

pub use bounds::Aabb;
pub use cutout::Cutout;
pub use cylinder::{Cylinder, CylinderPart};
pub use frame::Frame;
pub use grid::Grid;
pub use instance::MeshInstance;
pub use mesh::{MeshError, TriMesh};
pub use packet::{LANES, RayPacket};
pub use ray::{Hit, Ray, ShapeHit};
pub use spawn::{
    POINT_ERROR_ULPS, offset_ray_origin, offset_ray_origin_bounded, offset_toward, offset_toward_bounded, point_error,
};
pub use sphere::Sphere;
pub use triangle::{TriangleTest, WatertightRay};

use std::sync::Arc;

/// An analytic primitive that both the naive loop and Embree's user geometry can query.
///
/// Implementations must be pure functions of their inputs (no interior mutability), so that
/// Embree may call them from any thread.
pub trait Shape: Send + Sync + 'static {
    /// A conservative bounding box. Non-finite boxes mark the primitive as invalid.
    fn bounds(&self) -> Aabb;
    /// The closest hit with `tmin < t < tmax`, or `None`.
    fn intersect(&self, ray: &Ray, tmin: f32, tmax: f32) -> Option<ShapeHit>;
    /// Whether any hit with `tmin < t < tmax` exists.
    fn occludes(&self, ray: &Ray, tmin: f32, tmax: f32) -> bool {
        self.intersect(ray, tmin, tmax).is_some()
    }
}

/// Bounding box of every (valid) primitive of a geometry list.
pub fn bounds_of(geometry: &[Geometry]) -> Aabb {
    geometry.iter().fold(Aabb::EMPTY, |b, g| b.union(&g.bounds()))
}

/// One entry of the scene's geometry list. Its index in the list is its geometry id, the same
/// in every acceleration structure.
#[derive(Clone, Debug)]
pub enum Geometry {
    /// A triangle mesh: one geometry id, primitive id = triangle index.
    Mesh(Arc<TriMesh>),
    /// A triangle mesh placed by a transform, its data shared with every other instance of
    /// it: one geometry id, primitive id = triangle index.
    Instance(Arc<MeshInstance>),
    /// A set of spheres: one geometry id, primitive id = sphere index.
    Spheres(Arc<[Sphere]>),
    /// A set of capped cylinders: one geometry id, primitive id = cylinder index.
    Cylinders(Arc<[Cylinder]>),
}

impl Geometry {
    /// Number of primitives.
    pub fn len(&self) -> usize {
        match self {
            Geometry::Mesh(m) => m.triangle_count(),
            Geometry::Instance(i) => i.mesh.triangle_count(),
            Geometry::Spheres(s) => s.len(),
            Geometry::Cylinders(c) => c.len(),
        }
    }

    /// Whether the geometry has no primitive.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The triangle mesh of a mesh, or of a placed mesh (in its own space); `None` for
    /// spheres and cylinders.
    pub fn mesh(&self) -> Option<&Arc<TriMesh>> {
        match self {
            Geometry::Mesh(m) => Some(m),
            Geometry::Instance(i) => Some(&i.mesh),
            Geometry::Spheres(_) | Geometry::Cylinders(_) => None,
        }
    }

    /// The world corners of triangle `i` of a mesh or a placed mesh.
    ///
    /// # Panics
    /// For spheres and cylinders.
    pub fn triangle(&self, i: usize) -> [glam::Vec3; 3] {
        match self {
            Geometry::Mesh(m) => m.triangle(i),
            Geometry::Instance(inst) => inst.triangle(i),
            Geometry::Spheres(_) | Geometry::Cylinders(_) => panic!("spheres and cylinders have no triangles"),
        }
    }

    /// Bounding box of all (valid) primitives.
    pub fn bounds(&self) -> Aabb {
        match self {
            Geometry::Mesh(m) => m.bounds(),
            Geometry::Instance(i) => i.bounds(),
            Geometry::Spheres(s) => s.iter().fold(Aabb::EMPTY, |b, p| b.union(&p.bounds())),
            Geometry::Cylinders(c) => c.iter().fold(Aabb::EMPTY, |b, p| b.union(&p.bounds())),
        }
    }
}

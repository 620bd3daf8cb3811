use super::{Aabb, Ray, TriMesh};
use glam::{Affine3A, Mat3A, Vec3};
use std::sync::Arc;

/// A triangle mesh placed in the scene by an affine transform. Every instance of a mesh
/// shares its data: Embree builds one BVH for the mesh and places it with an instance
/// geometry per use, and shading reads the shared vertices and moves the result into place.
/// A glTF mesh that several nodes use is loaded this way.
#[derive(Clone, Debug)]
pub struct MeshInstance {
    /// The mesh in its own space.
    pub mesh: Arc<TriMesh>,
    /// From the mesh's space to the world.
    pub to_world: Affine3A,
    /// From the world to the mesh's space.
    pub to_object: Affine3A,
    /// Normals from the mesh's space to the world: the inverse transpose of the linear part.
    /// A mesh copied into place by a mirroring transform has its winding turned (so its
    /// front faces stay in front); with this matrix an instance's geometric normals are those
    /// of such a copy.
    pub normal_to_world: Mat3A,
}

impl MeshInstance {
    /// `mesh` placed by `to_world`, or `None` if the transform is not finite or cannot be
    /// inverted (it flattens the mesh).
    pub fn new(mesh: Arc<TriMesh>, to_world: Affine3A) -> Option<MeshInstance> {
        let det = to_world.matrix3.determinant();
        if !(to_world.is_finite() && det.is_normal()) {
            return None;
        }
        let to_object = to_world.inverse();
        let normal_to_world = to_world.matrix3.inverse().transpose();
        (to_object.is_finite() && normal_to_world.is_finite()).then_some(MeshInstance {
            mesh,
            to_world,
            to_object,
            normal_to_world,
        })
    }

    /// The world corners of triangle `i`.
    #[inline]
    pub fn triangle(&self, i: usize) -> [Vec3; 3] {
        self.mesh.triangle(i).map(|p| self.to_world.transform_point3(p))
    }

    /// The world positions of the mesh's vertices.
    pub fn positions(&self) -> impl Iterator<Item = Vec3> + '_ {
        self.mesh.positions.iter().map(|&p| self.to_world.transform_point3(p))
    }

    /// `ray` in the mesh's space, with the same parameter `t` for the same point.
    #[inline]
    pub fn ray_to_object(&self, ray: &Ray) -> Ray {
        Ray { o: self.to_object.transform_point3(ray.o), d: self.to_object.transform_vector3(ray.d) }
    }

    /// A unit world normal from `n` in the mesh's space (zero stays zero).
    #[inline]
    pub fn normal(&self, n: Vec3) -> Vec3 {
        (self.normal_to_world * n).normalize_or_zero()
    }

    /// The mesh copied into place, as a loader that does not instance would make it:
    /// positions, normals and tangents transformed, and the winding turned by a mirroring
    /// transform (so the copy's faces are this instance's).
    pub fn placed_copy(&self) -> TriMesh {
        let mut m = (*self.mesh).clone();
        m.transform(self.to_world);
        if self.to_world.matrix3.determinant() < 0.0 {
            for t in &mut m.indices {
                t.swap(1, 2);
            }
            for t in &mut m.tangents {
                t.swap(1, 2);
            }
        }
        m
    }

    /// The box of the mesh's box's corners placed in the world: holds every placed triangle.
    pub fn bounds(&self) -> Aabb {
        let b = self.mesh.bounds();
        if !b.is_valid() {
            return b;
        }
        b.corners().fold(Aabb::EMPTY, |acc, c| acc.grow(self.to_world.transform_point3(c)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn triangle() -> Arc<TriMesh> {
        Arc::new(TriMesh::new("t", vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]], vec![], vec![]).unwrap())
    }

    #[test]
    fn rays_keep_their_parameter_and_normals_match_a_copy() {
        let to_world = Affine3A::from_scale_rotation_translation(
            Vec3::new(2.0, -0.5, 3.0),
            glam::Quat::from_rotation_y(0.7),
            Vec3::new(1.0, 2.0, -3.0),
        );
        let inst = MeshInstance::new(triangle(), to_world).unwrap();
        let ray = Ray::new(Vec3::new(0.3, 0.4, 5.0), Vec3::new(0.1, -0.2, -1.0));
        let obj = inst.ray_to_object(&ray);
        for t in [0.0, 1.0, 4.5] {
            let back = to_world.transform_point3(obj.at(t));
            assert!((back - ray.at(t)).length() < 1e-4, "t = {t}: {back} vs {}", ray.at(t));
        }
        // A copy made by a mirroring transform turns its winding to keep the front in front:
        // its normal is the placed normal, not the placed winding's.
        let [a, b, c] = inst.triangle(0);
        let copy = (c - a).cross(b - a).normalize();
        assert!(to_world.matrix3.determinant() < 0.0);
        assert!((inst.normal(Vec3::Z) - copy).length() < 1e-5, "{} vs {copy}", inst.normal(Vec3::Z));
    }

    #[test]
    fn flattening_or_infinite_transforms_are_refused() {
        assert!(MeshInstance::new(triangle(), Affine3A::from_scale(Vec3::new(1.0, 0.0, 1.0))).is_none());
        assert!(MeshInstance::new(triangle(), Affine3A::from_translation(Vec3::splat(f32::INFINITY))).is_none());
        assert!(MeshInstance::new(triangle(), Affine3A::IDENTITY).is_some());
    }
}

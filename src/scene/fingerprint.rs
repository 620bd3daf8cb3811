//! A fingerprint of a loaded scene: a 64-bit hash of everything that affects the image
//! (geometry, bindings, materials with their texture pixels, lights, background, camera), so a
//! checkpoint can refuse to resume against a different scene. Computed from the loaded data,
//! not the file bytes: editing a comment does not invalidate a checkpoint, editing a referenced
//! mesh or texture does. Each material and light kind feeds its own parameters.

use super::{MaterialBinding, Scene};
use crate::geometry::Geometry;
use crate::hash::Fingerprint;

impl Scene {
    /// See the module documentation.
    pub fn fingerprint(&self) -> u64 {
        let mut h = Fingerprint::default();
        let mesh = |h: &mut Fingerprint, m: &crate::geometry::TriMesh| {
            h.v3(&m.positions);
            h.u32(m.indices.len() as u32);
            m.indices.iter().for_each(|t| t.iter().for_each(|&i| h.u32(i)));
            h.v3(&m.normals);
            h.v2(&m.uvs);
        };
        // A placed mesh is hashed the first time, and named by that place after.
        let mut placed = std::collections::HashMap::new();
        for (k, g) in self.geometry.iter().enumerate() {
            match g {
                Geometry::Mesh(m) => {
                    h.u32(0);
                    mesh(&mut h, m);
                }
                Geometry::Instance(i) => {
                    h.u32(3);
                    h.f32s(&i.to_world.to_cols_array());
                    match placed.get(&std::sync::Arc::as_ptr(&i.mesh)) {
                        Some(&first) => h.u32(first),
                        None => {
                            placed.insert(std::sync::Arc::as_ptr(&i.mesh), k as u32);
                            h.u32(u32::MAX);
                            mesh(&mut h, &i.mesh);
                        }
                    }
                }
                Geometry::Spheres(s) => {
                    h.u32(1);
                    s.iter().for_each(|s| h.f32s(&[s.center.x, s.center.y, s.center.z, s.radius]));
                }
                Geometry::Cylinders(c) => {
                    h.u32(2);
                    c.iter().for_each(|c| h.f32s(&[c.p0.x, c.p0.y, c.p0.z, c.p1.x, c.p1.y, c.p1.z, c.radius]));
                }
            }
        }
        for b in &self.bindings {
            match b {
                MaterialBinding::Uniform(m) => {
                    h.u32(0);
                    h.u32(*m);
                }
                MaterialBinding::PerPrim(v) => {
                    h.u32(1);
                    h.u32(v.len() as u32);
                    v.iter().for_each(|&m| h.u32(m));
                }
            }
        }
        self.materials.iter().for_each(|m| m.fingerprint(&mut h));
        self.lights.iter().for_each(|l| l.fingerprint(&mut h));
        h.str(&format!("{:?}", self.camera));
        h.finish()
    }
}

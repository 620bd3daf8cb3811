use super::Aabb;
use glam::{Vec2, Vec3};

/// A triangle mesh with optional per-vertex normals and texture coordinates (sharing the
/// position indices).
#[derive(Clone, Debug, Default)]
pub struct TriMesh {
    pub name: String,
    pub positions: Vec<Vec3>,
    pub indices: Vec<[u32; 3]>,
    /// Per-vertex shading normals, empty when the source had none.
    pub normals: Vec<Vec3>,
    /// Per-vertex texture coordinates, empty when the source had none.
    pub uvs: Vec<Vec2>,
}

/// Why a mesh could not be built.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum MeshError {
    #[error("triangle {tri} uses vertex {index}, but the mesh has {count} vertices")]
    IndexOutOfRange { tri: usize, index: u32, count: usize },
    #[error("{what} has {got} entries for {count} vertices")]
    AttributeLength { what: &'static str, got: usize, count: usize },
    #[error("mesh has {0} vertices; at most 2^32 - 1 are supported")]
    TooManyVertices(usize),
}

impl TriMesh {
    /// A mesh after checking that every index is in range and attributes match the vertices.
    pub fn new(
        name: impl Into<String>,
        positions: Vec<Vec3>,
        indices: Vec<[u32; 3]>,
        normals: Vec<Vec3>,
        uvs: Vec<Vec2>,
    ) -> Result<Self, MeshError> {
        let count = positions.len();
        if count >= u32::MAX as usize {
            return Err(MeshError::TooManyVertices(count));
        }
        for (tri, idx) in indices.iter().enumerate() {
            if let Some(&index) = idx.iter().find(|&&i| i as usize >= count) {
                return Err(MeshError::IndexOutOfRange { tri, index, count });
            }
        }
        if !normals.is_empty() && normals.len() != count {
            return Err(MeshError::AttributeLength { what: "normals", got: normals.len(), count });
        }
        if !uvs.is_empty() && uvs.len() != count {
            return Err(MeshError::AttributeLength { what: "texture coordinates", got: uvs.len(), count });
        }
        Ok(TriMesh { name: name.into(), positions, indices, normals, uvs })
    }

    pub fn triangle_count(&self) -> usize {
        self.indices.len()
    }

    /// Bytes held by the vertex and index arrays.
    pub fn heap_bytes(&self) -> u64 {
        (self.positions.capacity() * size_of::<Vec3>()
            + self.indices.capacity() * size_of::<[u32; 3]>()
            + self.normals.capacity() * size_of::<Vec3>()
            + self.uvs.capacity() * size_of::<Vec2>()) as u64
    }

    /// The three corners of triangle `i`.
    #[inline]
    pub fn triangle(&self, i: usize) -> [Vec3; 3] {
        let [a, b, c] = self.indices[i];
        [self.positions[a as usize], self.positions[b as usize], self.positions[c as usize]]
    }

    /// Whether triangle `i` cannot be hit: a corner is NaN or infinite, or its area is exactly
    /// zero (a repeated corner, or three collinear corners).
    pub fn is_degenerate(&self, i: usize) -> bool {
        let [a, b, c] = self.triangle(i);
        if !(a.is_finite() && b.is_finite() && c.is_finite()) {
            return true;
        }
        (b - a).cross(c - a) == glam::Vec3::ZERO
    }

    /// Drops the degenerate triangles (see [`is_degenerate`](Self::is_degenerate)) and
    /// returns their indices as they were before. Vertices are kept, so normals and texture
    /// coordinates stay valid.
    pub fn remove_degenerate(&mut self) -> Vec<usize> {
        let bad: Vec<usize> = (0..self.triangle_count()).filter(|&i| self.is_degenerate(i)).collect();
        if !bad.is_empty() {
            let mut k = 0;
            self.indices.retain(|_| {
                let keep = bad.binary_search(&k).is_err();
                k += 1;
                keep
            });
        }
        bad
    }

    /// Bounds of the vertices used by triangles (finite ones only).
    pub fn bounds(&self) -> Aabb {
        self.indices
            .iter()
            .flatten()
            .map(|&i| self.positions[i as usize])
            .filter(|p| p.is_finite())
            .fold(Aabb::EMPTY, |b, p| b.grow(p))
    }

    /// Applies an affine transform to positions (normals by the inverse transpose).
    pub fn transform(&mut self, m: glam::Affine3A) {
        for p in &mut self.positions {
            *p = m.transform_point3(*p);
        }
        let nm = glam::Mat3::from(m.matrix3).inverse().transpose();
        for n in &mut self.normals {
            *n = (nm * *n).normalize_or_zero();
        }
    }
}

impl TriMesh {
    /// Angle-weighted vertex normals (Thürmer and Wüthrich 1998) from the faces sharing each
    /// vertex index; replaces any normals present. Degenerate faces contribute nothing.
    pub fn compute_vertex_normals(&mut self) {
        let mut acc = vec![Vec3::ZERO; self.positions.len()];
        for idx in &self.indices {
            let p = idx.map(|i| self.positions[i as usize]);
            let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
            if n == Vec3::ZERO || !n.is_finite() {
                continue;
            }
            for k in 0..3 {
                let e1 = (p[(k + 1) % 3] - p[k]).normalize_or_zero();
                let e2 = (p[(k + 2) % 3] - p[k]).normalize_or_zero();
                let angle = e1.dot(e2).clamp(-1.0, 1.0).acos();
                acc[idx[k] as usize] += n * angle;
            }
        }
        self.normals = acc.into_iter().map(|n| n.normalize_or_zero()).collect();
    }
}

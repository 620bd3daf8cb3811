use super::Aabb;
use glam::{Vec2, Vec3, Vec4};

/// A triangle mesh with optional per-vertex normals and texture coordinates (sharing the
/// position indices), and optional tangents per triangle corner.
#[derive(Clone, Debug, Default)]
pub struct TriMesh {
    pub name: String,
    pub positions: Vec<Vec3>,
    pub indices: Vec<[u32; 3]>,
    /// Per-vertex shading normals, empty when the source had none.
    pub normals: Vec<Vec3>,
    /// Per-vertex texture coordinates, empty when the source had none. v runs up the image
    /// (OBJ's convention; glTF's are flipped when read).
    pub uvs: Vec<Vec2>,
    /// A second set of per-vertex texture coordinates (glTF's `TEXCOORD_1`), empty if none.
    pub uvs1: Vec<Vec2>,
    /// Per triangle, the tangent frame at each corner for normal maps: xyz the tangent (along
    /// increasing u), w = ±1 such that w (n × tangent) is the bitangent (along increasing v,
    /// up the image). Empty when no normal map needs them.
    pub tangents: Vec<[Vec4; 3]>,
    /// Where the surface has holes (its material's alpha), if it has any.
    pub cutout: Option<std::sync::Arc<super::Cutout>>,
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
        Ok(TriMesh { name: name.into(), positions, indices, normals, uvs, ..TriMesh::default() })
    }

    pub fn triangle_count(&self) -> usize {
        self.indices.len()
    }

    /// Bytes held by the vertex and index arrays.
    pub fn heap_bytes(&self) -> u64 {
        (self.positions.capacity() * size_of::<Vec3>()
            + self.indices.capacity() * size_of::<[u32; 3]>()
            + self.normals.capacity() * size_of::<Vec3>()
            + (self.uvs.capacity() + self.uvs1.capacity()) * size_of::<Vec2>()
            + self.tangents.capacity() * size_of::<[Vec4; 3]>()) as u64
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
            let keep = |k: usize| bad.binary_search(&k).is_err();
            let mut k = 0;
            self.indices.retain(|_| {
                k += 1;
                keep(k - 1)
            });
            if !self.tangents.is_empty() {
                let mut k = 0;
                self.tangents.retain(|_| {
                    k += 1;
                    keep(k - 1)
                });
            }
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
        let (linear, handedness) = (glam::Mat3::from(m.matrix3), m.matrix3.determinant().signum());
        for t in self.tangents.iter_mut().flatten() {
            *t = (linear * t.truncate()).normalize_or_zero().extend(t.w * handedness);
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

/// The mesh as MikkTSpace sees it: triangles, corner by corner, with the texture coordinates
/// of one set; the tangents it generates are written per corner.
struct Mikk<'a> {
    mesh: &'a TriMesh,
    uvs: &'a [Vec2],
    /// The unit normal of each triangle, for meshes without vertex normals.
    faces: Vec<Vec3>,
    out: Vec<[Vec4; 3]>,
}

impl bevy_mikktspace::Geometry for Mikk<'_> {
    fn num_faces(&self) -> usize {
        self.mesh.indices.len()
    }
    fn num_vertices_of_face(&self, _face: usize) -> usize {
        3
    }
    fn position(&self, face: usize, vert: usize) -> [f32; 3] {
        self.mesh.positions[self.mesh.indices[face][vert] as usize].to_array()
    }
    fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
        match self.mesh.normals.get(self.mesh.indices[face][vert] as usize) {
            Some(n) => n.to_array(),
            None => self.faces[face].to_array(),
        }
    }
    fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
        self.uvs[self.mesh.indices[face][vert] as usize].to_array()
    }
    fn set_tangent_encoded(&mut self, tangent: [f32; 4], face: usize, vert: usize) {
        self.out[face][vert] = Vec4::from(tangent);
    }
}

impl TriMesh {
    /// Computes [`TriMesh::tangents`] with MikkTSpace (what glTF asks for when a file gives
    /// none, and what Blender computes) from texture coordinate set `set` (0 or 1). Returns
    /// false, leaving the mesh without tangents, if it has no such coordinates.
    pub fn generate_tangents(&mut self, set: usize) -> bool {
        let uvs = if set == 1 { &self.uvs1 } else { &self.uvs };
        if uvs.is_empty() {
            return false;
        }
        let faces = if self.normals.is_empty() {
            (0..self.triangle_count())
                .map(|i| {
                    let [a, b, c] = self.triangle(i);
                    (b - a).cross(c - a).normalize_or(Vec3::Z)
                })
                .collect()
        } else {
            Vec::new()
        };
        let mut g = Mikk { mesh: self, uvs, faces, out: vec![[Vec4::ZERO; 3]; self.indices.len()] };
        // Faces MikkTSpace cannot give a frame (no area in uv) keep zero tangents, which the
        // shading reads as "no normal map here".
        bevy_mikktspace::generate_tangents(&mut g);
        self.tangents = g.out;
        true
    }
}

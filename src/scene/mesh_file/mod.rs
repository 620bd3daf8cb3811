//! The door for mesh files: one call, [`load`], reads any mesh format ember knows (chosen by
//! extension) into ember's own types — world-space triangle meshes, materials, a camera and
//! point lights where the format has them. PLY (`ply.rs`) and glTF 2.0 / GLB (`gltf.rs`);
//! `scene.rs` turns a [`MeshFile`] into a scene, or adds it to a TOML scene's.
//!
//! Every format follows the loaders' rules: errors name the file and where in it (line, JSON
//! path or element), memory is checked against [`crate::limits::MemoryLimit`] before the big
//! allocations, only regular files are opened, and triangles that cannot be hit are dropped
//! with a warning.

mod gltf;
mod ply;
pub(super) mod scene;

pub use scene::VERTEX_COLOURS_WARNING;

use super::SceneError;
use crate::geometry::TriMesh;
use std::path::Path;

/// What a mesh file holds, in ember's own types.
#[derive(Clone, Debug, Default)]
pub struct MeshFile {
    pub meshes: Vec<FileMesh>,
    pub materials: Vec<crate::scene::Material>,
    /// A camera the file defines (glTF), if any.
    pub camera: Option<crate::scene::CameraSpec>,
    pub point_lights: Vec<crate::light::PointLight>,
    pub warnings: Vec<String>,
}

/// One mesh of a [`MeshFile`].
#[derive(Clone, Debug)]
pub struct FileMesh {
    /// Already in world space (node transforms applied).
    pub mesh: TriMesh,
    /// Index into [`MeshFile::materials`].
    pub material: Option<usize>,
    /// Per-vertex linear RGB colours, empty if none.
    pub colors: Vec<glam::Vec3>,
}

impl MeshFile {
    pub fn triangle_count(&self) -> usize {
        self.meshes.iter().map(|m| m.mesh.triangle_count()).sum()
    }
}

/// A mesh format [`load`] reads, and its extensions (lower case).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Ply,
    Gltf,
}

impl Format {
    /// Every format with its extensions.
    pub const ALL: [(Format, &'static [&'static str]); 2] = [(Format::Ply, &["ply"]), (Format::Gltf, &["gltf", "glb"])];

    /// The format of `path`, by its (case-insensitive) extension.
    pub fn of(path: &Path) -> Option<Format> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        Self::ALL.iter().find(|(_, exts)| exts.contains(&ext.as_str())).map(|(f, _)| *f)
    }
}

/// Whether [`load`] reads `path` (by its extension).
pub fn is_mesh_file(path: &Path) -> bool {
    Format::of(path).is_some()
}

/// Loads the mesh file `path`, its format picked by the (case-insensitive) extension.
pub fn load(path: &Path) -> Result<MeshFile, SceneError> {
    match Format::of(path) {
        Some(Format::Ply) => ply::load(path),
        Some(Format::Gltf) => gltf::load(path),
        None => {
            let known: Vec<String> = Format::ALL.iter().flat_map(|(_, e)| e.iter()).map(|e| format!(".{e}")).collect();
            Err(SceneError::new(path, None, format!("not a mesh file ember reads ({})", known.join(", "))))
        }
    }
}

/// `mesh` without the triangles that cannot be hit (a warning names them), or `None` when
/// none is left.
fn keep_hittable(path: &Path, mut mesh: TriMesh, warnings: &mut Vec<String>) -> Option<TriMesh> {
    let dropped = mesh.remove_degenerate();
    if !dropped.is_empty() {
        warnings.push(super::obj::degenerate_warning(path, &mesh.name, &dropped, mesh.triangle_count()));
    }
    (mesh.triangle_count() > 0).then_some(mesh)
}

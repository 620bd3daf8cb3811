//! Mesh files: the one door through which meshes enter a scene, whatever their format. A
//! format is a file here that reads its files into a [`MeshFile`] of ember's own types (no
//! format library's types leave its file); [`load`] picks it by extension. A mesh file is
//! rendered on its own ([`scene_of`]) or named by a scene file's `[[meshes]]`
//! (`scene.rs`). Adding a format: its file and a line in [`FORMATS`].
//!
//! Every format follows the loaders' rules: errors name the file and where in it (line, JSON
//! path or element), memory is counted in the load's [`LoadBudget`] before the big
//! allocations, only regular files are opened, and triangles that cannot be hit are dropped
//! with a warning.

pub mod gltf;
mod meshopt;
pub mod obj;
pub mod ply;
mod scene;

pub(in crate::scene) use scene::add_to_scene;
pub use scene::{CLAY, STUDIO_GROUND, STUDIO_SKY, VERTEX_COLOURS_WARNING, scene_of};

use crate::geometry::{Geometry, MeshInstance, TriMesh};
use crate::light::PointLight;
use crate::material::Material;
use crate::memory::LoadBudget;
use crate::scene::format::MAX_COORDINATE;
use crate::scene::{CameraSpec, SceneError};
use glam::{Affine3A, Vec3};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// What a mesh file holds, in ember's own types.
#[derive(Clone, Debug, Default)]
pub struct MeshFile {
    pub meshes: Vec<FileMesh>,
    pub materials: Vec<Material>,
    /// A camera the file defines, if any.
    pub camera: Option<CameraSpec>,
    pub point_lights: Vec<PointLight>,
    /// Problems that did not stop loading, for the user to see.
    pub warnings: Vec<String>,
    /// The files read: the mesh file and those it names (MTL libraries, buffers, images).
    pub inputs: Vec<PathBuf>,
}

/// One mesh of a mesh file.
#[derive(Clone, Debug)]
pub struct FileMesh {
    /// In world space (any transforms of the file applied), or, when `instances` is not
    /// empty, in its own space.
    pub mesh: TriMesh,
    /// Where the file places a mesh it uses more than once: one transform (the mesh's space
    /// to the world) per use. The mesh is then loaded once and placed as instances
    /// ([`crate::geometry::MeshInstance`]). Empty: the mesh is in world space, used once.
    pub instances: Vec<Affine3A>,
    /// Index into [`MeshFile::materials`].
    pub material: Option<usize>,
    /// Per-vertex linear RGB colours, empty if none.
    pub colors: Vec<Vec3>,
}

impl MeshFile {
    /// Triangles placed (an instanced mesh's once per instance).
    pub fn triangle_count(&self) -> usize {
        self.meshes.iter().map(|m| m.mesh.triangle_count() * m.instances.len().max(1)).sum()
    }

    /// The meshes as geometry, without materials (for benchmarks and tests); instances whose
    /// transform flattens the mesh are left out.
    pub fn geometry(self) -> Vec<Geometry> {
        let mut out = Vec::new();
        for m in self.meshes {
            if m.instances.is_empty() {
                out.push(Geometry::Mesh(Arc::new(m.mesh)));
                continue;
            }
            let mesh = Arc::new(m.mesh);
            out.extend(
                m.instances
                    .iter()
                    .filter_map(|&xf| MeshInstance::new(mesh.clone(), xf))
                    .map(|i| Geometry::Instance(Arc::new(i))),
            );
        }
        out
    }
}

/// A format's loader.
type Loader = fn(&Path, &LoadBudget) -> Result<MeshFile, SceneError>;

/// The formats ember reads: their extensions (lower case) and loaders.
const FORMATS: [(&[&str], Loader); 3] = [(&["obj"], obj::load), (&["ply"], ply::load), (&["gltf", "glb"], gltf::load)];

/// The loader of a mesh file, by its (case-insensitive) extension.
fn format_of(path: &Path) -> Option<Loader> {
    let ext = path.extension()?.to_str()?.to_ascii_lowercase();
    FORMATS.iter().find(|(exts, _)| exts.contains(&ext.as_str())).map(|(_, load)| *load)
}

/// Whether `path` names a mesh file of a format ember reads.
pub fn is_mesh_file(path: &Path) -> bool {
    format_of(path).is_some()
}

/// The extensions of the formats ember reads, for messages: `.obj, .ply, .gltf, .glb`.
pub fn extensions() -> String {
    FORMATS.iter().flat_map(|(exts, _)| exts.iter()).map(|e| format!(".{e}")).collect::<Vec<_>>().join(", ")
}

/// Loads the mesh file `path`, in the format its extension names, within `budget`. Every finite vertex
/// coordinate must lie within ±[`MAX_COORDINATE`] (non-finite ones make their triangles
/// degenerate: the formats drop those with a warning).
pub fn load(path: &Path, budget: &LoadBudget) -> Result<MeshFile, SceneError> {
    let Some(load) = format_of(path) else {
        return Err(SceneError::new(path, None, format!("not a mesh file (expected {})", extensions())));
    };
    let mut file = load(path, budget)?;
    file.inputs.insert(0, path.to_path_buf());
    for m in &file.meshes {
        let identity = [Affine3A::IDENTITY];
        let places = if m.instances.is_empty() { &identity[..] } else { &m.instances[..] };
        let far = places.iter().find_map(|xf| {
            m.mesh
                .positions
                .iter()
                .map(|&p| xf.transform_point3(p))
                .enumerate()
                .find(|(_, p)| p.to_array().iter().any(|c| c.is_finite() && c.abs() > MAX_COORDINATE))
        });
        if let Some((i, p)) = far {
            return Err(SceneError::new(
                path,
                None,
                format!(
                    "mesh {:?}: vertex {} at {p} is beyond ±{MAX_COORDINATE:e}, the range ember renders",
                    m.mesh.name,
                    i + 1
                ),
            ));
        }
    }
    Ok(file)
}

/// `mesh` without the triangles that cannot be hit (a warning names them), or `None` when
/// none is left.
fn keep_hittable(path: &Path, mut mesh: TriMesh, warnings: &mut Vec<String>) -> Option<TriMesh> {
    let dropped = mesh.remove_degenerate();
    if !dropped.is_empty() {
        warnings.push(obj::degenerate_warning(path, &mesh.name, &dropped, mesh.triangle_count()));
    }
    (mesh.triangle_count() > 0).then_some(mesh)
}

//! Mesh files: the one door through which meshes enter a scene, whatever their format. A
//! format is a file here that reads its files into a [`MeshFile`] of ember's own types (no
//! format library's types leave its file); [`load`] picks it by extension. A mesh file is
//! rendered on its own ([`scene_of`]) or named by a scene file's `[[meshes]]`.
//!
//! Formats: `obj` (Wavefront OBJ with MTL materials).

pub mod obj;

use crate::geometry::{Geometry, TriMesh};
use crate::light::{Background, Light, PointLight};
use crate::material::Material;
use crate::scene::{CameraSpec, MaterialBinding, Scene, SceneError};
use glam::Vec3;
use std::path::Path;
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
}

/// One mesh of a mesh file.
#[derive(Clone, Debug)]
pub struct FileMesh {
    /// In world space (any transforms of the file applied).
    pub mesh: TriMesh,
    /// Index into [`MeshFile::materials`].
    pub material: Option<usize>,
    /// Per-vertex linear RGB colours, empty if none.
    pub colors: Vec<Vec3>,
}

impl MeshFile {
    pub fn triangle_count(&self) -> usize {
        self.meshes.iter().map(|m| m.mesh.triangle_count()).sum()
    }

    /// The meshes as geometry, without materials (for benchmarks and tests).
    pub fn geometry(self) -> Vec<Geometry> {
        self.meshes.into_iter().map(|m| Geometry::Mesh(Arc::new(m.mesh))).collect()
    }
}

/// The format of a mesh file, by its (case-insensitive) extension.
fn format_of(path: &Path) -> Option<fn(&Path) -> Result<MeshFile, SceneError>> {
    match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
        Some("obj") => Some(obj::load),
        _ => None,
    }
}

/// Whether `path` names a mesh file of a format ember reads.
pub fn is_mesh_file(path: &Path) -> bool {
    format_of(path).is_some()
}

/// The extensions of the formats ember reads, for messages: `.obj`.
pub fn extensions() -> &'static str {
    ".obj"
}

/// Loads the mesh file `path`, in the format its extension names.
pub fn load(path: &Path) -> Result<MeshFile, SceneError> {
    match format_of(path) {
        Some(load) => load(path),
        None => Err(SceneError::new(path, None, format!("not a mesh file (expected {})", extensions()))),
    }
}

/// A mesh file rendered on its own: its materials (or a light grey), its camera or one that
/// frames it, its lights, and, when nothing in it emits, a sky.
pub fn scene_of(path: &Path) -> Result<Scene, SceneError> {
    let file = load(path)?;
    let mut scene = Scene::empty(path);
    scene.warnings = file.warnings;
    scene.inputs.push(path.to_path_buf());
    let first = scene.materials.len() as u32;
    scene.materials.extend(file.materials);
    for m in file.meshes {
        let id = m.material.map(|i| first + i as u32).unwrap_or_else(|| scene.default_material());
        scene.geometry.push(Geometry::Mesh(Arc::new(m.mesh)));
        scene.bindings.push(MaterialBinding::Uniform(id));
    }
    scene.camera = file.camera;
    scene.lights.extend(file.point_lights.into_iter().map(Light::Point));
    // Only materials in use count: Embree's cornell_box.obj defines an emissive "light"
    // material but its light face is commented out.
    if !scene.effects().lit {
        scene.set_background(Background::Gradient {
            zenith: Vec3::new(0.9, 0.95, 1.0),
            horizon: Vec3::splat(0.8),
            ground: Vec3::splat(0.25),
        });
    }
    Ok(scene)
}

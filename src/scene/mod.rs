//! Scene description: input files (OBJ/MTL, TOML) and the loaded scene.

mod error;
mod obj;

pub use error::SceneError;
pub use obj::{ObjFile, ObjMesh, load_obj};

use crate::geometry::{Aabb, Geometry};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// A loaded scene: the geometry list (index = geometry id in every accelerator) and what is
/// needed to look at it.
#[derive(Clone, Debug)]
pub struct Scene {
    pub source: PathBuf,
    pub geometry: Vec<Geometry>,
    /// Problems that did not stop loading.
    pub warnings: Vec<String>,
}

impl Scene {
    /// Loads a scene file by extension (`.obj`).
    pub fn load(path: &Path) -> Result<Scene, SceneError> {
        match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
            Some("obj") => {
                let obj = load_obj(path)?;
                Ok(Scene {
                    source: path.to_path_buf(),
                    geometry: obj.meshes.into_iter().map(|m| Geometry::Mesh(Arc::new(m.mesh))).collect(),
                    warnings: obj.warnings,
                })
            }
            _ => Err(SceneError::new(path, None, "unknown scene format (expected .obj)")),
        }
    }

    pub fn bounds(&self) -> Aabb {
        self.geometry.iter().fold(Aabb::EMPTY, |b, g| b.union(&g.bounds()))
    }

    /// (triangles, spheres, cylinders)
    pub fn primitive_counts(&self) -> (usize, usize, usize) {
        let mut c = (0, 0, 0);
        for g in &self.geometry {
            match g {
                Geometry::Mesh(m) => c.0 += m.triangle_count(),
                Geometry::Spheres(s) => c.1 += s.len(),
                Geometry::Cylinders(s) => c.2 += s.len(),
            }
        }
        c
    }
}

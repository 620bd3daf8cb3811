//! The scenes of the intersection matrix: the sample models, the procedural family and the
//! shape fields, by name, or any scene/mesh file.

use super::BenchError;
use super::procedural::{blob, blob_resolution, shape_field};
use super::tessellate::{tessellate_cylinders, tessellate_spheres};
use crate::geometry::Geometry;
use crate::scene::Scene;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// What a benchmark scene is, for grouping in reports.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Family {
    /// A sample model from `scenes/` (teapot, bunny) or a file given by the user.
    Model,
    /// A bumpy sphere of a chosen triangle count (the scaling study).
    Procedural,
    /// Spheres and cylinders (Embree user geometry, or tessellated).
    Shapes,
}

/// Geometry to benchmark, with its name.
#[derive(Clone, Debug)]
pub struct BenchScene {
    pub name: String,
    pub family: Family,
    pub geometry: Vec<Geometry>,
}

/// Built-in scene names, in the order of the full run.
pub const BUILTIN: [&str; 8] =
    ["teapot", "bunny", "blob-1k", "blob-10k", "blob-100k", "blob-1m", "shapes-100", "shapes-1k"];
/// The default run.
pub const DEFAULT_SET: [&str; 7] = ["teapot", "bunny", "blob-1k", "blob-10k", "blob-100k", "blob-1m", "shapes-1k"];
/// The `--quick` run.
pub const QUICK_SET: [&str; 4] = ["teapot", "blob-1k", "blob-10k", "shapes-100"];

/// Segments around each sphere and cylinder when tessellated (960 triangles per sphere,
/// 128 per cylinder).
pub const TESSELLATION_SEGMENTS: u32 = 32;

impl BenchScene {
    /// A built-in scene by name, or a `.obj`/`.toml` file (its geometry only, without a bare
    /// mesh's studio ground). OBJ models are
    /// read from `scenes_dir`.
    pub fn load(name: &str, scenes_dir: &Path) -> Result<BenchScene, BenchError> {
        let procedural = |target: usize| BenchScene {
            name: name.to_string(),
            family: Family::Procedural,
            geometry: vec![Geometry::Mesh(Arc::new(blob(blob_resolution(target))))],
        };
        let shapes = |spheres: usize, cylinders: usize| {
            let (s, c) = shape_field(spheres, cylinders, 1);
            BenchScene {
                name: name.to_string(),
                family: Family::Shapes,
                geometry: vec![Geometry::Spheres(s.into()), Geometry::Cylinders(c.into())],
            }
        };
        Ok(match name {
            "teapot" | "bunny" => BenchScene {
                name: name.to_string(),
                family: Family::Model,
                geometry: Scene::load(&scenes_dir.join(format!("{name}.obj")))?.into_subject_geometry(),
            },
            "blob-1k" => procedural(1_000),
            "blob-10k" => procedural(10_000),
            "blob-100k" => procedural(100_000),
            "blob-1m" => procedural(1_000_000),
            "shapes-100" => shapes(80, 20),
            "shapes-1k" => shapes(800, 200),
            _ if name.ends_with(".obj") || name.ends_with(".toml") => {
                let path = PathBuf::from(name);
                let scene = Scene::load(&path)?;
                let family = if scene.primitive_counts().0 == 0 { Family::Shapes } else { Family::Model };
                let name = path.file_stem().map_or(name.to_string(), |s| s.to_string_lossy().into_owned());
                BenchScene { name, family, geometry: scene.into_subject_geometry() }
            }
            _ => {
                return Err(BenchError::Invalid(format!(
                    "unknown bench scene {name:?} (expected {} or a .obj/.toml file)",
                    BUILTIN.join(", ")
                )));
            }
        })
    }

    pub fn triangles(&self) -> usize {
        self.geometry.iter().map(|g| if let Geometry::Mesh(_) | Geometry::Instance(_) = g { g.len() } else { 0 }).sum()
    }

    /// Spheres plus cylinders.
    pub fn shapes(&self) -> usize {
        self.geometry
            .iter()
            .map(|g| if let Geometry::Spheres(_) | Geometry::Cylinders(_) = g { g.len() } else { 0 })
            .sum()
    }

    /// Primitives of every kind: what the naive loop tests per ray.
    pub fn primitives(&self) -> usize {
        self.geometry.iter().map(Geometry::len).sum()
    }

    /// The same list with spheres and cylinders replaced by meshes ([`TESSELLATION_SEGMENTS`]);
    /// list positions, and so geometry ids, are kept. `None` when there is nothing to
    /// tessellate.
    pub fn tessellated(&self) -> Option<Vec<Geometry>> {
        if self.shapes() == 0 {
            return None;
        }
        Some(
            self.geometry
                .iter()
                .map(|g| match g {
                    Geometry::Mesh(_) | Geometry::Instance(_) => g.clone(),
                    Geometry::Spheres(s) => Geometry::Mesh(Arc::new(tessellate_spheres(s, TESSELLATION_SEGMENTS).mesh)),
                    Geometry::Cylinders(c) => {
                        Geometry::Mesh(Arc::new(tessellate_cylinders(c, TESSELLATION_SEGMENTS).mesh))
                    }
                })
                .collect(),
        )
    }
}

/// `scenes/` under the working directory if it exists, else the one in the source tree this
/// binary was built from.
pub fn default_scenes_dir() -> PathBuf {
    let here = PathBuf::from("scenes");
    if here.is_dir() { here } else { Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes") }
}

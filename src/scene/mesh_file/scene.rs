//! Mesh files in scenes: rendered on their own ([`from_mesh_file`], like an OBJ: the file's
//! materials or a light grey, its camera or one that frames it, a sky when nothing in it
//! lights the scene), or as a TOML scene's `[[meshes]]` ([`add_to_scene`]).

use super::{MeshFile, load};
use crate::geometry::Geometry;
use crate::light::{Background, PointLight};
use crate::scene::{MaterialBinding, Scene, SceneError};
use glam::{Affine3A, Vec3};
use std::path::Path;
use std::sync::Arc;

/// Said once per file whose meshes carry vertex colours, until the renderer uses them.
pub const VERTEX_COLOURS_WARNING: &str = "vertex colours are read but not rendered yet";

/// A mesh file rendered on its own.
pub(in crate::scene) fn from_mesh_file(path: &Path) -> Result<Scene, SceneError> {
    let file = load(path)?;
    let mut scene = Scene::empty(path);
    scene.camera = file.camera;
    add(&mut scene, path, file, Affine3A::IDENTITY, None, false);
    // Only materials in use count, as for OBJ files; point lights light the scene too.
    if !scene.effects().emissive && scene.point_lights.is_empty() {
        scene.background = Background::Gradient {
            zenith: Vec3::new(0.9, 0.95, 1.0),
            horizon: Vec3::splat(0.8),
            ground: Vec3::splat(0.25),
        };
    }
    Ok(scene)
}

/// Adds the meshes (placed by `transform`) and point lights of the mesh file `path` to a TOML
/// scene, with material `material` on every mesh, or else the file's own. The file's camera
/// is not used: the scene's `[camera]` (or the framing camera) is.
pub(in crate::scene) fn add_to_scene(
    scene: &mut Scene,
    path: &Path,
    transform: Affine3A,
    material: Option<u32>,
    smooth: bool,
) -> Result<(), SceneError> {
    let file = load(path)?;
    add(scene, path, file, transform, material, smooth);
    Ok(())
}

fn add(scene: &mut Scene, path: &Path, file: MeshFile, transform: Affine3A, over: Option<u32>, smooth: bool) {
    scene.warnings.extend(file.warnings);
    let ids: Vec<u32> = match over {
        Some(_) => Vec::new(),
        None => file
            .materials
            .into_iter()
            .map(|m| {
                scene.materials.push(m);
                scene.materials.len() as u32 - 1
            })
            .collect(),
    };
    let moved = transform != Affine3A::IDENTITY;
    let mut colours = false;
    for fm in file.meshes {
        let mut mesh = fm.mesh;
        if moved {
            mesh.transform(transform);
            // A transform can collapse triangles too (a tiny scale underflows to zero area).
            let dropped = mesh.remove_degenerate();
            if !dropped.is_empty() {
                let w = crate::scene::obj::degenerate_warning(path, &mesh.name, &dropped, mesh.triangle_count());
                scene.warnings.push(format!("{w}, after the scene's scale/rotate/translate"));
                if mesh.triangle_count() == 0 {
                    continue;
                }
            }
        }
        if smooth && mesh.normals.is_empty() {
            mesh.compute_vertex_normals();
        }
        colours |= !fm.colors.is_empty();
        let id =
            over.or_else(|| fm.material.and_then(|i| ids.get(i).copied())).unwrap_or_else(|| default_material(scene));
        scene.geometry.push(Geometry::Mesh(Arc::new(mesh)));
        scene.bindings.push(MaterialBinding::Uniform(id));
    }
    for l in file.point_lights {
        scene
            .point_lights
            .push(PointLight { position: transform.transform_point3(l.position), intensity: l.intensity });
    }
    if colours {
        scene.warnings.push(format!("{}: {VERTEX_COLOURS_WARNING}", path.display()));
    }
}

/// The scene's light grey "default" material (added the first time), as for OBJ meshes
/// without materials.
fn default_material(scene: &mut Scene) -> u32 {
    if let Some(i) = scene.materials.iter().position(|m| m.name == "default") {
        return i as u32;
    }
    scene.materials.push(crate::scene::Material::diffuse("default", Vec3::splat(0.8)));
    scene.materials.len() as u32 - 1
}

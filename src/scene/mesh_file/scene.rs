//! Mesh files in scenes: rendered on their own ([`scene_of`]: the file's materials or a light
//! grey, its camera or one that frames it, a sky when nothing in it lights the scene), or as a
//! TOML scene's `[[meshes]]` ([`add_to_scene`]).

use super::{MeshFile, load};
use crate::geometry::Geometry;
use crate::light::{Background, Light, PointLight};
use crate::memory::LoadBudget;
use crate::scene::format::MAX_COORDINATE;
use crate::scene::{MaterialBinding, Scene, SceneError};
use crate::settings::RenderSettings;
use glam::{Affine3A, Vec3};
use std::path::Path;
use std::sync::Arc;

/// Said once per file whose meshes carry vertex colours, until the renderer uses them.
pub const VERTEX_COLOURS_WARNING: &str = "vertex colours are read but not rendered yet";

/// A mesh file rendered on its own, loaded within `budget`.
pub fn scene_of(path: &Path, budget: &LoadBudget) -> Result<Scene, SceneError> {
    budget
        .keep_film(None, None, RenderSettings::default().size())
        .map_err(|e| SceneError::new(path, None, e.to_string()))?;
    let file = load(path, budget)?;
    let mut scene = Scene::empty(path);
    scene.camera = file.camera;
    add_to_scene(&mut scene, path, file, None, None, false).map_err(|message| SceneError::new(path, None, message))?;
    // Only materials in use count: Embree's cornell_box.obj defines an emissive "light"
    // material but its light face is commented out. Point lights light the scene too.
    if !scene.effects().lit {
        scene.set_background(Background::Gradient {
            zenith: Vec3::new(0.9, 0.95, 1.0),
            horizon: Vec3::splat(0.8),
            ground: Vec3::splat(0.25),
        });
    }
    Ok(scene)
}

/// Adds the meshes, materials and point lights of the mesh file `path` to `scene`, placed by
/// `transform` (a scene file's scale/rotate/translate: applied even when it is the identity,
/// which renormalises vertex normals; `None`: as in the file), with material `over` on every
/// mesh, or else the file's own (a light grey where it has none); with `smooth`, meshes
/// without normals get smooth vertex normals. The file's camera is not used. An error (a
/// vertex placed out of range) is the message alone.
pub(in crate::scene) fn add_to_scene(
    scene: &mut Scene,
    path: &Path,
    file: MeshFile,
    transform: Option<Affine3A>,
    over: Option<u32>,
    smooth: bool,
) -> Result<(), String> {
    scene.warnings.extend(file.warnings);
    scene.inputs.extend(file.inputs);
    let first = scene.materials.len() as u32;
    scene.materials.extend(file.materials);
    let placed = if transform.is_some() { ", after the scene's scale/rotate/translate" } else { "" };
    let mut colours = false;
    for fm in file.meshes {
        let mut mesh = fm.mesh;
        let Some(transform) = transform else {
            colours |= !fm.colors.is_empty();
            let id = fm.material.map(|i| first + i as u32).unwrap_or_else(|| scene.default_material());
            scene.geometry.push(Geometry::Mesh(Arc::new(mesh)));
            scene.bindings.push(MaterialBinding::Uniform(id));
            continue;
        };
        mesh.transform(transform);
        if let Some(far) =
            mesh.positions.iter().flat_map(|p| p.to_array()).find(|c| c.is_finite() && c.abs() > MAX_COORDINATE)
        {
            return Err(format!("a coordinate is {far:e}{placed}, beyond ±{MAX_COORDINATE:e}"));
        }
        // A transform can collapse triangles too (a tiny scale underflows to zero area).
        let dropped = mesh.remove_degenerate();
        if !dropped.is_empty() {
            let warning = super::obj::degenerate_warning(path, &mesh.name, &dropped, mesh.triangle_count());
            scene.warnings.push(format!("{warning}{placed}"));
            if mesh.triangle_count() == 0 {
                continue;
            }
        }
        if smooth && mesh.normals.is_empty() {
            mesh.compute_vertex_normals();
        }
        colours |= !fm.colors.is_empty();
        let id =
            over.unwrap_or_else(|| fm.material.map(|i| first + i as u32).unwrap_or_else(|| scene.default_material()));
        scene.geometry.push(Geometry::Mesh(Arc::new(mesh)));
        scene.bindings.push(MaterialBinding::Uniform(id));
    }
    for l in file.point_lights {
        let position = transform.map_or(l.position, |t| t.transform_point3(l.position));
        if position.abs().max_element() > MAX_COORDINATE {
            return Err(format!("a point light is at {position}{placed}, beyond ±{MAX_COORDINATE:e}"));
        }
        scene.lights.push(Light::Point(PointLight { position, intensity: l.intensity }));
    }
    if colours {
        scene.warnings.push(format!("{}: {VERTEX_COLOURS_WARNING}", path.display()));
    }
    Ok(())
}

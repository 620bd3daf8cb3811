//! Mesh files in scenes: rendered on their own ([`scene_of`]: the file's materials or a clay
//! colour, its camera or one that frames it, and a studio — a sky and a ground plane — when
//! nothing in it lights the scene), or as a TOML scene's `[[meshes]]` ([`add_to_scene`]).

use super::{FileMesh, MeshFile, load};
use crate::geometry::{Geometry, MeshInstance, TriMesh};
use crate::light::{Background, Light, PointLight};
use crate::material::Material;
use crate::memory::LoadBudget;
use crate::scene::format::{MAX_COORDINATE, Override};
use crate::scene::{MaterialBinding, Scene, SceneError};
use crate::settings::RenderSettings;
use crate::texture::Texture;
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
    // Found by `Scene::default_material` for the meshes the file gives no material.
    scene.materials.push(Material::diffuse("default", CLAY));
    add_to_scene(&mut scene, path, file, None, None, false).map_err(|message| SceneError::new(path, None, message))?;
    if !lights_itself(&scene) {
        add_studio(&mut scene);
    }
    Ok(scene)
}

/// The colour of a bare mesh's surfaces that the file gives no material: a light warm clay,
/// which reads against the studio's blue-white sky and grey ground.
pub const CLAY: Vec3 = Vec3::new(0.75, 0.68, 0.6);

/// The studio's sky: white-blue above, light grey at the horizon.
pub const STUDIO_SKY: Background =
    Background::Gradient { zenith: Vec3::new(0.9, 0.95, 1.0), horizon: Vec3::splat(0.8), ground: Vec3::splat(0.25) };

/// The reflectance of the studio's ground.
pub const STUDIO_GROUND: Vec3 = Vec3::splat(0.5);

/// Whether a mesh file lights itself: a point light, or a surface in use whose material
/// emits a constant colour (a lamp). Only materials in use count: Embree's cornell_box.obj
/// defines an emissive "light" material but its light face is commented out. A textured
/// emitter (a helmet's lit visor, a screen) glows but is not what an author lights a model
/// with: such a model gets the studio too.
fn lights_itself(scene: &Scene) -> bool {
    let lamp = |m: u32| matches!(scene.materials[m as usize].emission, Texture::Constant(c) if c.max_element() > 0.0);
    scene.lights.iter().any(|l| matches!(l, Light::Point(_)))
        || scene.bindings.iter().any(|b| match b {
            MaterialBinding::Uniform(m) => lamp(*m),
            MaterialBinding::PerPrim(ms) => ms.iter().any(|&m| lamp(m)),
        })
}

/// Puts a bare mesh in a studio: [`STUDIO_SKY`] all round, and a ground of [`STUDIO_GROUND`]
/// under its lowest point (+Y is up), a square 100 times the model's size across, so its
/// edge lies at the horizon from any camera that frames the model. The automatic camera
/// frames the model alone ([`Scene::ground`]).
fn add_studio(scene: &mut Scene) {
    scene.set_background(STUDIO_SKY);
    let b = scene.bounds();
    let size = b.diagonal().length();
    if !(size.is_finite() && size > 0.0) {
        return;
    }
    // A hair below the lowest point: a flat base does not coincide with the ground.
    let (y, half, c) = (b.min.y - 1e-4 * size, 50.0 * size, b.center());
    let corners = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
    let positions = corners.iter().map(|&(dx, dz)| Vec3::new(c.x + dx * half, y, c.z + dz * half)).collect();
    // Wound so that the geometric normal is +Y.
    let ground = TriMesh::new("studio ground", positions, vec![[0, 2, 1], [0, 3, 2]], Vec::new(), Vec::new())
        .expect("four corners, two triangles");
    scene.materials.push(Material::diffuse("studio ground", STUDIO_GROUND));
    let id = scene.materials.len() as u32 - 1;
    scene.ground = Some(scene.geometry.len());
    scene.geometry.push(Geometry::Mesh(Arc::new(ground)));
    scene.bindings.push(MaterialBinding::Uniform(id));
}

/// Adds the meshes, materials and point lights of the mesh file `path` to `scene`, placed by
/// `transform` (a scene file's scale/rotate/translate: applied even when it is the identity,
/// which renormalises vertex normals; `None`: as in the file), with material `over` on the
/// meshes its [`Override`] says (the others keep the file's own), or else the file's own (the
/// scene's default material where it has none); with `smooth`, meshes
/// without normals get smooth vertex normals. The file's camera is not used. An error (a
/// vertex placed out of range) is the message alone.
pub(in crate::scene) fn add_to_scene(
    scene: &mut Scene,
    path: &Path,
    file: MeshFile,
    transform: Option<Affine3A>,
    over: Option<(u32, Override)>,
    smooth: bool,
) -> Result<(), String> {
    scene.warnings.extend(file.warnings);
    scene.inputs.extend(file.inputs);
    let first = scene.materials.len() as u32;
    scene.materials.extend(file.materials);
    let placed = if transform.is_some() { PLACED } else { "" };
    let mut colours = false;
    for fm in file.meshes {
        if !fm.instances.is_empty() {
            colours |= !fm.colors.is_empty();
            place_instances(scene, path, fm, first, transform, over, smooth)?;
            continue;
        }
        let mut mesh = fm.mesh;
        let Some(transform) = transform else {
            colours |= !fm.colors.is_empty();
            let id = fm.material.map(|i| first + i as u32).unwrap_or_else(|| scene.default_material());
            mesh.cutout = scene.materials[id as usize].cutout().map(Arc::new);
            scene.geometry.push(Geometry::Mesh(Arc::new(mesh)));
            scene.bindings.push(MaterialBinding::Uniform(id));
            continue;
        };
        mesh.transform(transform);
        within_range(mesh.positions.iter().copied(), placed)?;
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
        let id = material_of(scene, fm.material.map(|i| first + i as u32), over);
        mesh.cutout = scene.materials[id as usize].cutout().map(Arc::new);
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

/// Said of a coordinate out of range after a scene file's transform.
const PLACED: &str = ", after the scene's scale/rotate/translate";

/// An error naming the first finite coordinate of `points` beyond ±[`MAX_COORDINATE`], if
/// one is, with `placed` saying how it got there.
fn within_range(points: impl Iterator<Item = Vec3>, placed: &str) -> Result<(), String> {
    match points.flat_map(|p| p.to_array()).find(|c| c.is_finite() && c.abs() > MAX_COORDINATE) {
        Some(far) => Err(format!("a coordinate is {far:e}{placed}, beyond ±{MAX_COORDINATE:e}")),
        None => Ok(()),
    }
}

/// The material of a mesh whose file gives it `own`: the override `over` where its scope
/// takes the mesh, else `own`, else the scene's default.
fn material_of(scene: &mut Scene, own: Option<u32>, over: Option<(u32, Override)>) -> u32 {
    let textured = own.is_some_and(|m| scene.materials[m as usize].has_texture_map());
    match (over, own) {
        (Some((m, Override::All)), _) => m,
        (Some((m, Override::Untextured)), _) if !textured => m,
        (_, Some(m)) => m,
        (_, None) => scene.default_material(),
    }
}

/// Adds a mesh the file places more than once ([`FileMesh::instances`]): its data once, and
/// an instance per place, each after the scene file's `transform`. A place that flattens the
/// mesh is left out with a warning.
fn place_instances(
    scene: &mut Scene,
    path: &Path,
    fm: FileMesh,
    first: u32,
    transform: Option<Affine3A>,
    over: Option<(u32, Override)>,
    smooth: bool,
) -> Result<(), String> {
    let id = material_of(scene, fm.material.map(|i| first + i as u32), over);
    let mut mesh = fm.mesh;
    if transform.is_some() && smooth && mesh.normals.is_empty() {
        mesh.compute_vertex_normals();
    }
    mesh.cutout = scene.materials[id as usize].cutout().map(Arc::new);
    let mesh = Arc::new(mesh);
    let mut flat = 0;
    for &place in &fm.instances {
        let to_world = transform.map_or(place, |t| t * place);
        // The file's own places were checked as it loaded.
        if transform.is_some() {
            within_range(mesh.positions.iter().map(|&p| to_world.transform_point3(p)), PLACED)?;
        }
        match MeshInstance::new(mesh.clone(), to_world) {
            Some(inst) => {
                scene.geometry.push(Geometry::Instance(Arc::new(inst)));
                scene.bindings.push(MaterialBinding::Uniform(id));
            }
            None => flat += 1,
        }
    }
    if flat > 0 {
        scene.warnings.push(format!(
            "{}: mesh {:?}: {flat} of its {} places flatten it (a zero scale); those are left out",
            path.display(),
            mesh.name,
            fm.instances.len()
        ));
    }
    Ok(())
}

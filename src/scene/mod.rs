//! Scene description: input files (TOML scene files, `toml_file.rs` with the schema in
//! `format.rs`; mesh files through one door, `mesh_file/`) and the loaded [`Scene`]; what the
//! scene calls for (`effects.rs`) and its fingerprint (`fingerprint.rs`).

mod effects;
mod error;
mod fingerprint;
pub mod format;
mod input;
pub mod mesh_file;
mod toml_file;

pub use effects::{DepthLimit, Effects};
pub use error::SceneError;
pub use mesh_file::{FileMesh, MeshFile};

use crate::camera::Camera;
use crate::geometry::{Aabb, Geometry, Shape, bounds_of};
use crate::light::{Background, Light, LightSet};
use crate::material::Material;
use crate::memory::{LoadBudget, MemoryLimit};
use crate::settings::RenderDefaults;
use crate::texture::{MipImage, Texture};
use glam::Vec3;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Which material each primitive of a geometry uses.
#[derive(Clone, Debug, PartialEq)]
pub enum MaterialBinding {
    /// Every primitive uses this material.
    Uniform(u32),
    /// Material of primitive i is entry i.
    PerPrim(Arc<[u32]>),
}

impl MaterialBinding {
    #[inline]
    pub fn material(&self, prim: u32) -> u32 {
        match self {
            MaterialBinding::Uniform(m) => *m,
            MaterialBinding::PerPrim(v) => v[prim as usize],
        }
    }
}

/// The camera as described, before the image aspect is known. `None` frames the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraSpec {
    pub position: Vec3,
    pub look_at: Vec3,
    pub up: Vec3,
    pub fov: f32,
    pub aperture: f32,
    pub focus_distance: Option<f32>,
}

/// The vertical field of view, in degrees, of a camera that does not say (and of the camera
/// that frames a scene without one).
pub const DEFAULT_FOV: f32 = 40.0;

/// Parts of a camera given over a scene's (`ember render --camera-position`, `--look-at`,
/// `--up`, `--fov`): each part given replaces the scene's; see [`Scene::override_camera`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CameraOverride {
    pub position: Option<Vec3>,
    pub look_at: Option<Vec3>,
    pub up: Option<Vec3>,
    /// Vertical field of view, degrees.
    pub fov: Option<f32>,
}

impl CameraOverride {
    /// Whether nothing is overridden.
    pub fn is_empty(&self) -> bool {
        *self == CameraOverride::default()
    }
}

/// A loaded scene.
#[derive(Clone, Debug)]
pub struct Scene {
    pub source: PathBuf,
    /// Index = geometry id in every accelerator.
    pub geometry: Vec<Geometry>,
    /// One entry per geometry.
    pub bindings: Vec<MaterialBinding>,
    pub materials: Vec<Material>,
    /// The lights the scene describes (area lights are surfaces whose material emits); the
    /// background, if any, is one of them ([`Scene::background`]).
    pub lights: Vec<Light>,
    pub camera: Option<CameraSpec>,
    pub render: RenderDefaults,
    /// Problems that did not stop loading.
    pub warnings: Vec<String>,
    /// The files the scene was read from, as named (the scene file, meshes, textures), so
    /// that an output that would overwrite one can be refused. (A mesh's MTL files are not
    /// listed yet.)
    pub inputs: Vec<PathBuf>,
}

impl Scene {
    /// A scene with nothing in it (black background, framing camera), named by `source`.
    pub fn empty(source: impl Into<PathBuf>) -> Scene {
        Scene {
            source: source.into(),
            geometry: Vec::new(),
            bindings: Vec::new(),
            materials: Vec::new(),
            lights: Vec::new(),
            camera: None,
            render: RenderDefaults::default(),
            warnings: Vec::new(),
            inputs: Vec::new(),
        }
    }

    /// Loads a scene by extension: `.toml` (scene file) or a mesh file (rendered on its own:
    /// [`mesh_file::scene_of`]).
    pub fn load(path: &Path) -> Result<Scene, SceneError> {
        Scene::load_within(path, &LoadBudget::new(MemoryLimit::current()))
    }

    /// [`Scene::load`] within `budget`: the scene file, meshes, MTL files and textures are
    /// counted together as they load, with the film and accelerator it may count too.
    pub fn load_within(path: &Path, budget: &LoadBudget) -> Result<Scene, SceneError> {
        let toml = path.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("toml"));
        if toml {
            toml_file::load(path, budget)
        } else if mesh_file::is_mesh_file(path) {
            mesh_file::scene_of(path, budget)
        } else if !path.exists() {
            Err(SceneError::new(path, None, "no such file"))
        } else {
            let formats = mesh_file::extensions();
            Err(SceneError::new(path, None, format!("unknown scene format (expected .toml or a mesh file: {formats})")))
        }
    }

    /// Parses the text of a TOML scene file. `path` names the file in messages, and the files
    /// the scene refers to (meshes, textures) are found relative to its folder. [`Scene::load`]
    /// reads `path` and calls this for `.toml` files.
    pub fn from_toml_str(text: &str, path: &Path) -> Result<Scene, SceneError> {
        toml_file::from_str(text, path, &LoadBudget::new(MemoryLimit::current()))
    }

    pub fn bounds(&self) -> Aabb {
        bounds_of(&self.geometry)
    }

    /// Points whose convex hull holds every surface: mesh vertices, and the corners of each
    /// sphere's and cylinder's box.
    fn outline_points(&self) -> impl Iterator<Item = Vec3> + '_ {
        self.geometry.iter().flat_map(move |g| -> Box<dyn Iterator<Item = Vec3> + '_> {
            match g {
                Geometry::Mesh(m) => Box::new(m.positions.iter().copied()),
                Geometry::Spheres(s) => Box::new(s.iter().flat_map(|p| p.bounds().corners())),
                Geometry::Cylinders(c) => Box::new(c.iter().flat_map(|p| p.bounds().corners())),
            }
        })
    }

    /// Bytes held by the geometry arrays, the texture and environment images (each image once)
    /// and the environment's sampling distribution.
    pub fn data_bytes(&self) -> u64 {
        let geometry: u64 = self
            .geometry
            .iter()
            .map(|g| match g {
                Geometry::Mesh(m) => m.heap_bytes(),
                Geometry::Spheres(s) => std::mem::size_of_val(&s[..]) as u64,
                Geometry::Cylinders(c) => std::mem::size_of_val(&c[..]) as u64,
            })
            .sum();
        let mut maps: Vec<&Arc<MipImage>> = self
            .materials
            .iter()
            .flat_map(|m| m.textures())
            .filter_map(|t| match t {
                Texture::Map { map, .. } => Some(&map.image),
                _ => None,
            })
            .collect();
        maps.sort_by_key(|i| Arc::as_ptr(i));
        maps.dedup_by(|a, b| Arc::ptr_eq(a, b));
        let textures: u64 = maps.iter().map(|i| i.heap_bytes()).sum();
        let environment = match self.background() {
            Background::Image(env) => env.sampling_bytes() + (env.image().pixels.capacity() * size_of::<Vec3>()) as u64,
            _ => 0,
        };
        geometry + textures + environment
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

    /// The camera for an image of aspect `width / height`.
    pub fn camera(&self, aspect: f32) -> Camera {
        match self.camera {
            Some(c) => {
                let focus = c.focus_distance.unwrap_or_else(|| (c.look_at - c.position).length());
                Camera::look_at(c.position, c.look_at, c.up, c.fov, aspect, c.aperture, focus)
            }
            None => Camera::fitting(self.outline_points(), &self.bounds(), DEFAULT_FOV, aspect),
        }
    }

    /// Puts the parts of `o` over the scene's camera. A scene without a camera first gets the
    /// one that would frame it in an image of aspect `aspect` (with `o`'s field of view, if
    /// given): it looks at the centre of the bounds, up is +Y. The result is the scene's camera
    /// (so it is part of the fingerprint). Refused: a position equal to the point looked at.
    /// The parts' ranges (coordinates within ±[`format::MAX_COORDINATE`], 0 < fov < 180) are
    /// checked where they are read.
    pub fn override_camera(&mut self, o: &CameraOverride, aspect: f32) -> Result<(), String> {
        if o.is_empty() {
            return Ok(());
        }
        let base = match self.camera {
            Some(c) => c,
            None => {
                let fov = o.fov.unwrap_or(DEFAULT_FOV);
                let framing = Camera::fitting(self.outline_points(), &self.bounds(), fov, aspect);
                CameraSpec {
                    position: framing.position,
                    look_at: self.bounds().center(),
                    up: Vec3::Y,
                    fov,
                    aperture: 0.0,
                    focus_distance: None,
                }
            }
        };
        let c = CameraSpec {
            position: o.position.unwrap_or(base.position),
            look_at: o.look_at.unwrap_or(base.look_at),
            up: o.up.unwrap_or(base.up),
            fov: o.fov.unwrap_or(base.fov),
            ..base
        };
        if c.position == c.look_at {
            return Err(format!(
                "the camera position and the point it looks at are the same point ({}, {}, {})",
                c.position.x, c.position.y, c.position.z
            ));
        }
        self.camera = Some(c);
        Ok(())
    }

    /// What rays leaving the scene see (black if the scene has no background).
    pub fn background(&self) -> &Background {
        static BLACK: Background = Background::Black;
        self.lights
            .iter()
            .find_map(|l| match l {
                Light::Background(b) => Some(b),
                _ => None,
            })
            .unwrap_or(&BLACK)
    }

    /// Sets what rays leaving the scene see, replacing any background it had.
    pub fn set_background(&mut self, background: Background) {
        self.lights.retain(|l| !matches!(l, Light::Background(_)));
        self.lights.push(Light::Background(background));
    }

    /// The scene's lights, ready for sampling.
    pub fn light_set(&self) -> LightSet {
        LightSet::new(&self.geometry, &|g, p| &self.material(g, p).emission, &self.lights)
    }

    /// The id of the material named "default" (a light grey diffuse), added if missing.
    pub fn default_material(&mut self) -> u32 {
        if let Some(i) = self.materials.iter().position(|m| m.name == "default") {
            return i as u32;
        }
        self.materials.push(Material::diffuse("default", Vec3::splat(0.8)));
        self.materials.len() as u32 - 1
    }

    /// The effects this scene calls for.
    pub fn effects(&self) -> Effects {
        Effects::of(self)
    }

    /// The material of primitive `prim` of geometry `geom`.
    #[inline]
    pub fn material(&self, geom: u32, prim: u32) -> &Material {
        &self.materials[self.bindings[geom as usize].material(prim) as usize]
    }
}

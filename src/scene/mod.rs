//! Scene description: input files (TOML scenes, OBJ/MTL meshes) and the loaded [`Scene`].

mod build;
mod effects;
mod error;
mod fingerprint;
pub mod format;
mod input;
mod material;
pub mod mesh_file;
mod obj;
mod roulette;

pub use effects::{DepthLimit, Effects};
pub use error::SceneError;
pub use material::{Material, MaterialKind};
pub use obj::{ObjFile, ObjMesh, load_obj, parse_obj};
pub use roulette::{RR_THROUGHPUT, RrDepth, throughput_depth};

use crate::camera::Camera;
use crate::geometry::{Aabb, Geometry, Shape, bounds_of};
use crate::light::{Background, LightSet, PointLight};
use crate::texture::{Image, Texture};
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

/// Render settings a scene file may suggest (the command line overrides them).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RenderDefaults {
    pub width: Option<u32>,
    pub height: Option<u32>,
    pub spp: Option<u32>,
    pub max_depth: Option<u32>,
    pub rr_depth: Option<RrDepth>,
    pub seed: Option<u64>,
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
    pub point_lights: Vec<PointLight>,
    pub background: Background,
    pub camera: Option<CameraSpec>,
    pub render: RenderDefaults,
    /// Problems that did not stop loading.
    pub warnings: Vec<String>,
}

impl Scene {
    /// A scene with nothing in it (black background, framing camera), named by `source`.
    pub fn empty(source: impl Into<PathBuf>) -> Scene {
        Scene {
            source: source.into(),
            geometry: Vec::new(),
            bindings: Vec::new(),
            materials: Vec::new(),
            point_lights: Vec::new(),
            background: Background::Black,
            camera: None,
            render: RenderDefaults::default(),
            warnings: Vec::new(),
        }
    }

    /// Loads a scene by extension: `.toml` (scene file), or a mesh file — `.obj`, `.ply`, `.gltf`,
    /// `.glb` — with its own camera or one that frames it, lit by a default sky when nothing in
    /// it emits.
    pub fn load(path: &Path) -> Result<Scene, SceneError> {
        match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
            Some("toml") => build::from_toml(path),
            Some("obj") => build::from_obj(path),
            _ if mesh_file::is_mesh_file(path) => mesh_file::scene::from_mesh_file(path),
            _ => {
                if !path.exists() {
                    return Err(SceneError::new(path, None, "no such file"));
                }
                Err(SceneError::new(path, None, "unknown scene format (expected .toml, .obj, .ply, .gltf or .glb)"))
            }
        }
    }

    /// Parses the text of a TOML scene file. `path` names the file in messages, and the files
    /// the scene refers to (meshes, textures) are found relative to its folder. [`Scene::load`]
    /// reads `path` and calls this for `.toml` files.
    pub fn from_toml_str(text: &str, path: &Path) -> Result<Scene, SceneError> {
        build::from_toml_str(text, path)
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

    /// Bytes held by the geometry arrays and the texture images (each image once).
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
        let mut images: Vec<&Arc<Image>> = self
            .materials
            .iter()
            .filter_map(|m| match m.texture() {
                Some(Texture::Image(i)) => Some(i),
                _ => None,
            })
            .collect();
        if let Background::Image { image, .. } = &self.background {
            images.push(image);
        }
        images.sort_by_key(|i| Arc::as_ptr(i));
        images.dedup_by(|a, b| Arc::ptr_eq(a, b));
        geometry + images.iter().map(|i| (i.pixels.capacity() * size_of::<Vec3>()) as u64).sum::<u64>()
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
            None => Camera::fitting(self.outline_points(), &self.bounds(), 40.0, aspect),
        }
    }

    /// The scene's lights, ready for sampling.
    pub fn light_set(&self) -> LightSet {
        LightSet::new(&self.geometry, &|g, p| self.material(g, p).emission, &self.point_lights, &self.background)
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

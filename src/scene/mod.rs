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

use crate::camera::{Camera, model_view_dir, orbit_dir};
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
    /// Vertical field of view in degrees (perspective).
    pub fov: f32,
    pub aperture: f32,
    pub focus_distance: Option<f32>,
    /// An orthographic camera's view width, in world units; `None`: perspective.
    pub ortho_width: Option<f32>,
}

impl CameraSpec {
    /// A pinhole camera at `position` looking at `look_at`, vertical field of view `fov`
    /// degrees.
    pub fn pinhole(position: Vec3, look_at: Vec3, up: Vec3, fov: f32) -> CameraSpec {
        CameraSpec { position, look_at, up, fov, aperture: 0.0, focus_distance: None, ortho_width: None }
    }

    /// The `[camera]` table of a scene file that describes this camera, numbers written so
    /// that they read back the same.
    pub fn to_toml(&self) -> String {
        let v = |v: Vec3| format!("[{}, {}, {}]", v.x, v.y, v.z);
        let mut s =
            format!("[camera]\nposition = {}\nlook_at = {}\nup = {}\n", v(self.position), v(self.look_at), v(self.up));
        match self.ortho_width {
            Some(w) => s += &format!("type = \"orthographic\"\nwidth = {w}\n"),
            None => {
                s += &format!("fov = {}\n", self.fov);
                if self.aperture > 0.0 {
                    s += &format!("aperture = {}\n", self.aperture);
                }
                if let Some(f) = self.focus_distance {
                    s += &format!("focus_distance = {f}\n");
                }
            }
        }
        s
    }
}

/// The vertical field of view, in degrees, of a camera that does not say (and of the camera
/// that frames a scene without one).
pub const DEFAULT_FOV: f32 = 40.0;

/// Parts of a camera given over a scene's (`ember render --camera-position`, `--look-at`,
/// `--up`, `--fov`, `--orbit`, `--ortho`): each part given replaces the scene's; see
/// [`Scene::override_camera`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CameraOverride {
    pub position: Option<Vec3>,
    pub look_at: Option<Vec3>,
    pub up: Option<Vec3>,
    /// Vertical field of view, degrees.
    pub fov: Option<f32>,
    /// A camera orbiting the centre of the scene's bounds and looking at it (instead of a
    /// position and a point looked at).
    pub orbit: Option<Orbit>,
    /// An orthographic camera of this view width (world units).
    pub ortho: Option<f32>,
}

/// Where an orbiting camera is: [`crate::camera::orbit_dir`] of the angles (degrees), at
/// `distance` from the centre, or where it frames the scene as the automatic camera does.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Orbit {
    pub azimuth: f32,
    pub elevation: f32,
    pub distance: Option<f32>,
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
    /// The geometry id of the studio ground a bare mesh stands on ([`mesh_file::scene_of`]):
    /// the automatic camera and `--orbit` frame the rest, and an environment given on the
    /// command line ([`Scene::set_environment`]) takes it away.
    pub ground: Option<usize>,
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
            ground: None,
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

    /// The geometry a camera frames: all of it but the studio [`Scene::ground`].
    fn subject(&self) -> impl Iterator<Item = &Geometry> + '_ {
        self.geometry.iter().enumerate().filter(|(i, _)| Some(*i) != self.ground).map(|(_, g)| g)
    }

    /// The geometry but a bare mesh's studio [`Scene::ground`]: the model alone, as the
    /// intersection benchmarks take it.
    pub fn into_subject_geometry(mut self) -> Vec<Geometry> {
        if let Some(g) = self.ground {
            self.geometry.remove(g);
        }
        self.geometry
    }

    /// The bounds of what a camera frames: the whole scene, but a bare mesh's studio ground.
    pub fn subject_bounds(&self) -> Aabb {
        self.subject().fold(Aabb::EMPTY, |b, g| b.union(&g.bounds()))
    }

    /// Points whose convex hull holds every surface a camera frames: mesh vertices, and the
    /// corners of each sphere's and cylinder's box.
    fn outline_points(&self) -> impl Iterator<Item = Vec3> + '_ {
        self.subject().flat_map(move |g| -> Box<dyn Iterator<Item = Vec3> + '_> {
            match g {
                Geometry::Mesh(m) => Box::new(m.positions.iter().copied()),
                Geometry::Instance(i) => Box::new(i.positions()),
                Geometry::Spheres(s) => Box::new(s.iter().flat_map(|p| p.bounds().corners())),
                Geometry::Cylinders(c) => Box::new(c.iter().flat_map(|p| p.bounds().corners())),
            }
        })
    }

    /// Bytes held by the geometry arrays, the texture and environment images (each image once)
    /// and the environment's sampling distribution.
    pub fn data_bytes(&self) -> u64 {
        // A placed mesh's data once, however many times it is placed.
        let mut placed = std::collections::HashSet::new();
        let geometry: u64 = self
            .geometry
            .iter()
            .map(|g| match g {
                Geometry::Mesh(m) => m.heap_bytes(),
                Geometry::Instance(i) => {
                    let once = if placed.insert(Arc::as_ptr(&i.mesh)) { i.mesh.heap_bytes() } else { 0 };
                    once + size_of::<crate::geometry::MeshInstance>() as u64
                }
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
                Geometry::Instance(i) => c.0 += i.mesh.triangle_count(),
                Geometry::Spheres(s) => c.1 += s.len(),
                Geometry::Cylinders(s) => c.2 += s.len(),
            }
        }
        c
    }

    /// The camera for an image of aspect `width / height`.
    pub fn camera(&self, aspect: f32) -> Camera {
        match self.camera {
            Some(c) if let Some(width) = c.ortho_width => {
                Camera::orthographic(c.position, c.look_at, c.up, width, aspect)
            }
            Some(c) => {
                let focus = c.focus_distance.unwrap_or_else(|| (c.look_at - c.position).length());
                Camera::look_at(c.position, c.look_at, c.up, c.fov, aspect, c.aperture, focus)
            }
            None => Camera::fitting(self.outline_points(), &self.subject_bounds(), DEFAULT_FOV, aspect),
        }
    }

    /// The scene's camera, or for a scene without one the camera that frames it in an image
    /// of aspect `aspect` ([`Camera::fitting`]): it looks at the centre of the bounds, up +Y.
    pub fn camera_spec(&self, aspect: f32) -> CameraSpec {
        self.camera.unwrap_or_else(|| self.framing(model_view_dir(), DEFAULT_FOV, aspect))
    }

    /// The camera that frames the scene from direction `dir` (from the centre of the bounds),
    /// as the automatic camera does ([`Camera::fitting_from`]).
    fn framing(&self, dir: Vec3, fov: f32, aspect: f32) -> CameraSpec {
        let bounds = self.subject_bounds();
        let framing = Camera::fitting_from(dir, self.outline_points(), &bounds, fov, aspect);
        CameraSpec::pinhole(framing.position, bounds.center(), Vec3::Y, fov)
    }

    /// Puts the parts of `o` over the scene's camera. A scene without a camera first gets the
    /// one that would frame it in an image of aspect `aspect` (with `o`'s field of view, if
    /// given): it looks at the centre of the bounds, up is +Y. An orbit places the camera
    /// around the centre of the bounds, looking at it, at its distance or at the one that
    /// frames the scene from there; `ortho` makes the camera orthographic (no lens). The
    /// result is the scene's camera (so it is part of the fingerprint). Refused: a position
    /// equal to the point looked at. The parts' ranges (coordinates within
    /// ±[`format::MAX_COORDINATE`], 0 < fov < 180) are checked where they are read.
    pub fn override_camera(&mut self, o: &CameraOverride, aspect: f32) -> Result<(), String> {
        if o.is_empty() {
            return Ok(());
        }
        let fov = o.fov.or(self.camera.map(|c| c.fov)).unwrap_or(DEFAULT_FOV);
        let base = match (o.orbit, self.camera) {
            (Some(orbit), _) => {
                let dir = orbit_dir(orbit.azimuth, orbit.elevation);
                let framed = self.framing(dir, fov, aspect);
                let centre = self.subject_bounds().center();
                let position = orbit.distance.map_or(framed.position, |d| centre + dir * d);
                CameraSpec { position, ..framed }
            }
            (None, Some(c)) => c,
            (None, None) => self.framing(model_view_dir(), fov, aspect),
        };
        let mut c = CameraSpec {
            position: o.position.unwrap_or(base.position),
            look_at: o.look_at.unwrap_or(base.look_at),
            up: o.up.unwrap_or(base.up),
            fov: o.fov.unwrap_or(base.fov),
            ..base
        };
        if let Some(width) = o.ortho {
            (c.ortho_width, c.aperture, c.focus_distance) = (Some(width), 0.0, None);
        }
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

    /// Lights the scene with the equirectangular environment image `path` (8-bit or HDR, as
    /// a scene file's `[background] type = "image"`), radiance times `strength`, turned
    /// `rotate` degrees about +Y; it replaces the scene's background, and a bare mesh's
    /// studio ground goes (the environment's own ground is what it stands on). Loaded and
    /// counted within `budget`; an error is the message alone.
    pub fn set_environment(
        &mut self,
        path: &Path,
        strength: f32,
        rotate: f32,
        budget: &LoadBudget,
    ) -> Result<(), String> {
        let image = crate::texture::Image::load_environment(path, budget)
            .map_err(|e| format!("environment image {}: {e}", path.display()))?;
        let sampling = crate::memory::environment_sampling_bytes(image.width, image.height);
        let what = format!("sampling distribution of the {}x{} environment image", image.width, image.height);
        budget.admit(what, sampling).map_err(|e| format!("environment image {}: {e}", path.display()))?;
        let env = crate::light::Environment::new(Arc::new(image), strength, rotate);
        budget.keep(env.sampling_bytes());
        self.set_background(Background::Image(Arc::new(env)));
        self.inputs.push(path.to_path_buf());
        if let Some(g) = self.ground.take() {
            self.geometry.remove(g);
            self.bindings.remove(g);
        }
        Ok(())
    }

    /// How many triangles and spheres emit (their material's emission is not black anywhere):
    /// the lights of [`Scene::light_set`] beside the described ones.
    pub fn emitting_primitives(&self) -> u64 {
        let mut n = 0u64;
        for (g, geom) in self.geometry.iter().enumerate() {
            let count = match geom {
                Geometry::Mesh(m) => m.triangle_count(),
                Geometry::Instance(i) => i.mesh.triangle_count(),
                Geometry::Spheres(s) => s.len(),
                Geometry::Cylinders(_) => 0,
            };
            n += (0..count).filter(|&p| self.material(g as u32, p as u32).emission.max().max_element() > 0.0).count()
                as u64;
        }
        n
    }

    /// The scene's lights, ready for sampling (a light tree where `mode` and their number
    /// call for one).
    pub fn light_set(&self, mode: crate::settings::LightTreeMode) -> LightSet {
        LightSet::new(&self.geometry, &|g, p| &self.material(g, p).emission, &self.lights, mode)
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A scene of two spheres, bounds (-1, 0, -2)..(3, 2, 0), centre (1, 1, -1), and a camera
    /// given by `camera` (TOML lines, or none).
    fn spheres(camera: &str) -> Scene {
        let text = format!(
            "{camera}\n[materials.m]\ntype = \"diffuse\"\n\
             [[spheres]]\ncenter = [0.0, 1.0, -1.0]\nradius = 1.0\nmaterial = \"m\"\n\
             [[spheres]]\ncenter = [2.0, 1.0, -1.0]\nradius = 1.0\nmaterial = \"m\"\n"
        );
        Scene::from_toml_str(&text, Path::new("spheres.toml")).unwrap()
    }

    #[test]
    fn an_orbit_puts_the_camera_at_its_angles_and_distance_around_the_centre() {
        let centre = Vec3::new(1.0, 1.0, -1.0);
        for (azimuth, elevation, expected_dir) in [
            (0.0f32, 0.0f32, Vec3::Z),
            (90.0, 0.0, Vec3::X),
            (180.0, 0.0, Vec3::NEG_Z),
            (-90.0, 0.0, Vec3::NEG_X),
            (0.0, 90.0, Vec3::Y),
            (0.0, -90.0, Vec3::NEG_Y),
            // cos 60° = 1/2: half the distance across, √3/2 up; split evenly between +X and +Z.
            (45.0, 60.0, Vec3::new(0.25 * 2f32.sqrt(), 0.75f32.sqrt(), 0.25 * 2f32.sqrt())),
        ] {
            let mut scene = spheres("");
            let orbit = Orbit { azimuth, elevation, distance: Some(5.0) };
            scene.override_camera(&CameraOverride { orbit: Some(orbit), ..Default::default() }, 1.5).unwrap();
            let c = scene.camera.unwrap();
            let expected = centre + 5.0 * expected_dir;
            assert!((c.position - expected).length() < 1e-5, "{azimuth},{elevation}: {} vs {expected}", c.position);
            assert_eq!(c.look_at, centre);
            let (a, e) = crate::camera::orbit_angles(c.position - centre);
            assert!((e - elevation).abs() < 1e-3, "{e} vs {elevation}");
            if elevation.abs() < 89.0 {
                assert!(((a - azimuth).rem_euclid(360.0) + 1e-3) % 360.0 < 2e-3, "{a} vs {azimuth}");
            }
        }
    }

    #[test]
    fn an_orbit_without_a_distance_frames_the_scene_as_the_automatic_camera_does() {
        // From the automatic camera's own angles, the automatic camera.
        let (azimuth, elevation) = crate::camera::orbit_angles(model_view_dir());
        assert!((azimuth - 28.81).abs() < 0.01 && (elevation - 21.52).abs() < 0.01, "{azimuth} {elevation}");
        let automatic = spheres("").camera_spec(1.5);
        let mut scene = spheres("");
        let orbit = Orbit { azimuth, elevation, distance: None };
        scene.override_camera(&CameraOverride { orbit: Some(orbit), ..Default::default() }, 1.5).unwrap();
        let orbited = scene.camera.unwrap();
        assert!((orbited.position - automatic.position).length() < 1e-4, "{orbited:?} vs {automatic:?}");
        // From elsewhere, as close as keeps the scene in frame: nearer from above (its
        // footprint, 4 × 2, is smaller than its side, 4 × 2 too but seen at an angle) than
        // the bounding sphere's distance.
        let mut top = spheres("");
        let orbit = Orbit { azimuth: 0.0, elevation: 90.0, distance: None };
        top.override_camera(&CameraOverride { orbit: Some(orbit), ..Default::default() }, 1.5).unwrap();
        let d = (top.camera.unwrap().position - Vec3::new(1.0, 1.0, -1.0)).length();
        let sphere = top.bounds().diagonal().length() / 2.0 / (20f32.to_radians()).sin() * 1.05;
        assert!(d > 0.0 && d < sphere, "{d} vs {sphere}");
    }

    #[test]
    fn a_camera_printed_as_toml_reads_back_the_same() {
        let automatic = spheres("").camera_spec(4.0 / 3.0);
        for spec in [
            automatic,
            CameraSpec { aperture: 0.05, focus_distance: Some(3.25), ..automatic },
            CameraSpec { ortho_width: Some(6.5), ..automatic },
        ] {
            let back = spheres(&spec.to_toml()).camera.unwrap();
            assert_eq!(back, spec, "{}", spec.to_toml());
        }
        // The automatic camera, written out, renders as the scene without a camera does.
        let given = spheres(&automatic.to_toml());
        let (a, b) = (given.camera(4.0 / 3.0), spheres("").camera(4.0 / 3.0));
        let ray = |c: &Camera| c.ray(glam::Vec2::new(0.3, 0.7), glam::Vec2::ZERO);
        assert!((ray(&a).o - ray(&b).o).length() < 1e-6 && (ray(&a).d - ray(&b).d).length() < 1e-6);
    }

    #[test]
    fn ortho_keeps_the_position_and_drops_the_lens() {
        let mut scene = spheres("[camera]\nposition = [1.0, 1.0, 9.0]\nlook_at = [1.0, 1.0, -1.0]\naperture = 0.2\n");
        scene.override_camera(&CameraOverride { ortho: Some(3.0), ..Default::default() }, 2.0).unwrap();
        let c = scene.camera.unwrap();
        assert_eq!((c.position, c.ortho_width, c.aperture), (Vec3::new(1.0, 1.0, 9.0), Some(3.0), 0.0));
        let cam = scene.camera(2.0);
        assert!(cam.is_orthographic());
        // The image's corners are 1.5 across and 0.75 up from the view's centre.
        let corner = cam.ray(glam::Vec2::new(1.0, 0.0), glam::Vec2::ZERO);
        assert_eq!((corner.o, corner.d), (Vec3::new(2.5, 1.75, 9.0), Vec3::NEG_Z));
    }
}

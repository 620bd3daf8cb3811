//! What every path of a render reads: the scene, its accelerator and lights, the camera, the
//! settings and what the render plan decided. Built once per render by the render loop
//! (`progressive.rs`); the kernels (`kernel.rs`), the path tracer (`path.rs`) and the
//! auxiliary images (`aux.rs`) take it.

use super::light_vertex::LightVertexPool;
use super::surface::FaceNormals;
use crate::accel::Accel;
use crate::camera::Camera;
use crate::light::{Emitters, LightSet};
use crate::scene::Scene;
use crate::settings::RenderSettings;

/// Everything one path needs, shared by all pixels.
pub struct PathContext<'a> {
    pub scene: &'a Scene,
    pub accel: &'a dyn Accel,
    pub lights: &'a LightSet,
    pub normals: &'a FaceNormals,
    pub camera: &'a Camera,
    pub settings: &'a RenderSettings,
    /// [`super::RenderPlan::path_depth`]: the most bounces a path takes.
    pub path_depth: u32,
    /// [`super::RenderPlan::roulette_start`]: Russian roulette runs after this many bounces
    /// (`u32::MAX`: never).
    pub roulette_start: u32,
    /// The light vertices paths connect to, if [`super::RenderPlan::light_vertices`].
    pub light_vertices: Option<&'a LightVertexPool>,
    /// With [`super::RenderPlan::caustics`], the lights light paths start from: paths from the
    /// camera leave them the light they carry (see `super::caustic`).
    pub emitters: Option<&'a Emitters<'a>>,
    /// Where diffuse vertices after the first bounce also sample toward caustic light
    /// (`super::guide`); `None`: BSDF sampling only.
    pub guide: Option<&'a super::guide::Guide>,
    /// [`super::RenderPlan::lane_shading`]: the wavefront loop shades vertices in lanes where
    /// no light vertices or guide run.
    pub lanes: bool,
}

impl<'a> PathContext<'a> {
    /// The context of a render of `plan` before its passes (no light vertices, caustic
    /// emitters or guide yet).
    pub fn new(
        scene: &'a Scene,
        accel: &'a dyn Accel,
        lights: &'a LightSet,
        normals: &'a FaceNormals,
        camera: &'a Camera,
        plan: &'a super::RenderPlan,
    ) -> PathContext<'a> {
        PathContext {
            scene,
            accel,
            lights,
            normals,
            camera,
            settings: &plan.settings,
            path_depth: plan.path_depth,
            roulette_start: plan.roulette_start.unwrap_or(u32::MAX),
            light_vertices: None,
            emitters: None,
            guide: None,
            lanes: plan.lane_shading(),
        }
    }
}

//! Awkward cameras: inside a closed mesh, and with the up vector along the view.

use super::super::analytic::{Solid, diffuse_point_light};
use super::super::pixel::Reference;
use super::super::scenes::{CaseSceneBuilder, icosphere};
use super::{CaseRun, CheckError, Verdict, against_reference, camera_of, primary};
use crate::integrator::RenderSettings;
use crate::material::{DiffuseMaterial, MaterialKind};
use crate::scene::Scene;
use crate::texture::Texture;
use glam::{DVec3, Vec3};

/// The enclosure of `inside.rs` made of a closed, watertight triangle mesh (an icosphere of
/// 1280 triangles): every ray starts inside, and one slipping between two triangles would
/// escape to the black background.
pub fn inside_mesh(run: &CaseRun) -> Result<Verdict, CheckError> {
    let mut builder = CaseSceneBuilder::new("inside-mesh");
    let m = builder.material(
        MaterialKind::Diffuse(DiffuseMaterial { color: Texture::Constant(Vec3::splat(0.5)) }),
        Vec3::splat(0.5),
    );
    builder.mesh(icosphere(Vec3::new(0.2, -0.1, 0.3), 2.0, 3), m);
    builder.camera(Vec3::new(0.8, 0.4, -0.2), Vec3::new(-1.0, 0.0, 0.5), Vec3::Y, 90.0);
    super::inside::enclosure(run, &builder.build())
}

/// A diffuse plane (albedo 0.5) under a point light, seen straight down with the up vector
/// parallel (+Y) and anti-parallel (−Y) to the view: the camera must choose another up, and
/// each image must match albedo/π · I cosθ / r² at the points its own rays hit (1% beyond
/// jitter). Also, an up vector 2⁻³⁰ long must give the same image as a unit one (the
/// parallel test must not depend on the up vector's length).
pub fn up_parallel(run: &CaseRun) -> Result<Verdict, CheckError> {
    let light = Vec3::new(0.7, 3.0, -0.4);
    let build = |eye: Vec3, look: Vec3, up: Vec3| -> Scene {
        let mut builder = CaseSceneBuilder::new("up-parallel");
        let m = builder.diffuse(0.5);
        builder.quad(Vec3::new(-5.0, 0.0, -5.0), Vec3::new(0.0, 0.0, 10.0), Vec3::new(10.0, 0.0, 0.0), m);
        builder.point_light(light, 20.0);
        builder.camera(eye, look, up, 60.0);
        builder.build()
    };
    let (w, h, spp) = run.by_quality((24, 16, 8), (48, 32, 16));
    let s = RenderSettings { max_depth: 1, ..run.settings(w, h, spp) };
    let plane = Solid::Quad {
        corner: DVec3::new(-5.0, 0.0, -5.0),
        e1: DVec3::new(0.0, 0.0, 10.0),
        e2: DVec3::new(10.0, 0.0, 0.0),
    };
    let (eye, look) = (Vec3::new(0.2, 4.0, 0.1), Vec3::new(0.2, 0.0, 0.1));
    let mut v: Option<Verdict> = None;
    for up in [Vec3::Y, -Vec3::Y] {
        let scene = build(eye, look, up);
        let film = run.render(&scene, &s)?;
        let cam = camera_of(&scene, w, h);
        let reference = Reference::new(w, h, 8, |film| {
            let (o, d) = primary(&cam, film);
            plane
                .hit(o, d, 0.0)
                .map_or(0.0, |hit| diffuse_point_light(0.5, hit.point, hit.normal, o, light.as_dvec3(), 20.0))
        });
        let this = against_reference(&film, &reference, spp, 0.01, 0.0);
        v = Some(match v {
            Some(prev) if prev.error >= this.error => prev,
            _ => this,
        });
    }
    let v = v.expect("two renders");
    let side = Vec3::new(3.0, 1.0, 4.0);
    let unit = run.render(&build(side, Vec3::ZERO, Vec3::Y), &s)?;
    let tiny = run.render(&build(side, Vec3::ZERO, Vec3::Y * 2f32.powi(-30)), &s)?;
    Ok(v.require(unit == tiny, "an up vector of length 2⁻³⁰ changes the image"))
}

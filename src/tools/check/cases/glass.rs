//! Smooth glass: total internal reflection, IOR 1.0 and 3.0. Glass is lossless here
//! (reflection F, transmission 1 − F, both with weight 1 when sampled in proportion), so
//! under a uniform sky of radiance 1 every path that escapes brings back exactly 1.

use super::super::analytic::Solid;
use super::super::pixel::Reference;
use super::super::scenes::{CaseSceneBuilder, box_mesh};
use super::{CaseRun, CheckError, Verdict, against_reference, camera_of, primary, worst_abs};
use crate::light::Background;
use crate::material::{DiffuseMaterial, MaterialKind};
use crate::texture::Texture;
use glam::Vec3;

/// A camera inside an axis-aligned glass cube (IOR 1.5) under a sky of 1. Reflections in an
/// axis-aligned cube only flip signs of the direction, so a ray escapes (value 1) exactly
/// when some component has d_i² > 1 − 1/η² (it then meets that face below the critical
/// angle, all others above it); otherwise it is trapped by total internal reflection forever
/// (value 0 at the depth limit). Each pixel must hold the fraction of its rays that escape.
pub fn inside_tir(run: &CaseRun) -> Result<Verdict, CheckError> {
    let ior = 1.5f32;
    let mut builder = CaseSceneBuilder::new("inside-glass");
    let glass = builder.glass(ior);
    builder.mesh(box_mesh(Vec3::new(-1.3, -0.8, -1.1), Vec3::new(0.9, 1.2, 1.05)), glass);
    builder.background(Background::Constant(Vec3::ONE));
    builder.camera(Vec3::new(0.1, 0.2, -0.05), Vec3::new(1.0, 0.6, 0.8), Vec3::Y, 100.0);
    let scene = builder.build();
    let (w, h, spp, depth) = run.by_quality((24, 24, 8, 100), (48, 48, 16, 300));
    let film = run.render(&scene, &run.bsdf_settings(w, h, spp, depth))?;
    let cam = camera_of(&scene, w, h);
    let threshold = 1.0 - 1.0 / (ior as f64 * ior as f64);
    let reference = Reference::new(w, h, 16, |film| {
        let (_, d) = primary(&cam, film);
        let d = d.normalize();
        if d.x * d.x > threshold || d.y * d.y > threshold || d.z * d.z > threshold { 1.0 } else { 0.0 }
    });
    // 2%: rays just inside the escape cone meet their face near the critical angle, where F
    // is close to 1, and a few need more bounces than the depth limit allows.
    let v = against_reference(&film, &reference, spp, 0.02, 0.0);
    let trapped = reference.pixels.iter().filter(|p| p.mean == 0.0).count();
    let free = reference.pixels.iter().filter(|p| p.mean == 1.0).count();
    Ok(Verdict { detail: format!("{} ({trapped} px fully trapped, {free} px fully escaping)", v.detail), ..v }
        .require(trapped > 0 && free > 0, "the view must show both trapped and escaping directions"))
}

/// A glass sphere of IOR 1.0 over a checker plane under a sky of 1: it must be invisible,
/// every pixel showing the checker albedo of the point seen straight through it.
pub fn ior_one(run: &CaseRun) -> Result<Verdict, CheckError> {
    let (a, b, scale) = (0.8f32, 0.2f32, 8.0f32);
    let mut builder = CaseSceneBuilder::new("glass-ior-1");
    let plane = builder.material(
        MaterialKind::Diffuse(DiffuseMaterial {
            color: Texture::Checker { a: Vec3::splat(a), b: Vec3::splat(b), scale },
        }),
        Vec3::ZERO,
    );
    let glass = builder.glass(1.0);
    let (corner, e1, e2) = (Vec3::new(-4.0, 0.0, -4.0), Vec3::new(8.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 8.0));
    builder.quad(corner, e1, e2, plane);
    builder.sphere(Vec3::new(0.2, 2.5, -0.3), 1.5, glass);
    builder.background(Background::Constant(Vec3::ONE));
    builder.camera(Vec3::new(0.3, 6.0, 0.2), Vec3::ZERO, Vec3::Z, 60.0);
    let scene = builder.build();
    let (w, h, spp) = run.by_quality((24, 24, 4), (48, 48, 16));
    let film = run.render(&scene, &run.bsdf_settings(w, h, spp, 8))?;
    let cam = camera_of(&scene, w, h);
    let quad = Solid::Quad { corner: corner.as_dvec3(), e1: e1.as_dvec3(), e2: e2.as_dvec3() };
    let reference = Reference::new(w, h, 16, |film| {
        let (o, d) = primary(&cam, film);
        match quad.hit(o, d, 0.0) {
            Some(hit) => {
                let q = hit.point - corner.as_dvec3();
                let (u, v) = (q.x / 8.0, q.z / 8.0);
                let s = (u * scale as f64).floor() + (v * scale as f64).floor();
                if s.rem_euclid(2.0) < 1.0 { a as f64 } else { b as f64 }
            }
            None => 1.0,
        }
    });
    Ok(against_reference(&film, &reference, spp, 1e-3, 0.0))
}

/// A glass sphere of IOR 1.5 and a glass box of IOR 3.0 under a sky of 1, seen from outside:
/// no path entering either can be trapped, so every sample, after any number of Fresnel
/// reflections, refractions and total internal reflections, is exactly 1.
pub fn furnace(run: &CaseRun) -> Result<Verdict, CheckError> {
    let mut builder = CaseSceneBuilder::new("glass-furnace");
    let (g15, g3) = (builder.glass(1.5), builder.glass(3.0));
    builder.sphere(Vec3::new(-1.2, 0.0, 0.0), 1.0, g15);
    builder.mesh(box_mesh(Vec3::new(0.3, -1.0, -1.0), Vec3::new(2.3, 1.0, 1.0)), g3);
    builder.background(Background::Constant(Vec3::ONE));
    builder.camera(Vec3::new(0.5, 1.5, 6.0), Vec3::new(0.5, 0.0, 0.0), Vec3::Y, 45.0);
    let scene = builder.build();
    let (w, h, spp) = run.by_quality((24, 24, 4), (48, 48, 16));
    let film = run.render(&scene, &run.bsdf_settings(w, h, spp, 400))?;
    Ok(Verdict::new(worst_abs(&film, 1.0), 1e-4, "max |px − 1|", "every pixel 1: glass neither gains nor loses energy"))
}

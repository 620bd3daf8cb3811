//! Self-intersection: a diffuse plane and a sphere resting on it under a point light, turned
//! off the axes, direct light only, rendered twice: centred on the origin (where the plane's
//! points are small numbers computed from its large corners) and moved ~900 units away.
//! Every pixel must match the closed-form radiance albedo/π · I cosθ / r² (0 in shadow)
//! averaged over the pixel: fewer than 0.1% of pixels may be off by more than 5% beyond the
//! jitter noise. A shadow ray that hits the surface it starts on blackens its sample, so
//! self-intersection shows at once.

use super::super::analytic::{Solid, blocked, diffuse_point_light, first_hit};
use super::super::pixel::Reference;
use super::super::scenes::CaseSceneBuilder;
use super::{CaseRun, CheckError, Verdict, against_reference, camera_of, primary};
use crate::integrator::RenderSettings;
use glam::{Quat, Vec3};

fn at(run: &CaseRun, shift: Vec3) -> Result<Verdict, CheckError> {
    let rot = Quat::from_axis_angle(Vec3::new(-2.0, 1.0, 0.5).normalize(), 0.45);
    let mv = |p: Vec3| rot * p + shift;
    let (albedo, intensity) = (0.5f32, 60.0f32);
    let (corner, e1, e2) =
        (mv(Vec3::new(-6.0, 0.0, -6.0)), rot * Vec3::new(0.0, 0.0, 12.0), rot * Vec3::new(12.0, 0.0, 0.0));
    let (center, radius) = (mv(Vec3::new(0.8, 1.0, -0.3)), 1.0f32);
    let light = mv(Vec3::new(-2.0, 5.0, 3.0));
    let mut builder = CaseSceneBuilder::new("self-intersection");
    let m = builder.diffuse(albedo);
    builder.quad(corner, e1, e2, m);
    builder.sphere(center, radius, m);
    builder.point_light(light, intensity);
    builder.camera(mv(Vec3::new(0.0, 4.5, 7.5)), mv(Vec3::new(0.0, 0.5, 0.0)), rot * Vec3::Y, 50.0);
    let scene = builder.build();

    let (w, h, spp) = run.by_quality((32, 32, 16), (64, 64, 64));
    let film = run.render(&scene, &RenderSettings { max_depth: 1, ..run.settings(w, h, spp) })?;
    // The reference sees the same f32 shapes, widened to f64.
    let solids = [
        Solid::Quad { corner: corner.as_dvec3(), e1: e1.as_dvec3(), e2: e2.as_dvec3() },
        Solid::Sphere { center: center.as_dvec3(), radius: radius as f64 },
    ];
    let cam = camera_of(&scene, w, h);
    let l = light.as_dvec3();
    let reference = Reference::new(w, h, 16, |film| {
        let (o, d) = primary(&cam, film);
        match first_hit(&solids, o, d) {
            Some((i, hit)) if !blocked(&solids, i, hit.point, l) => {
                diffuse_point_light(albedo as f64, hit.point, hit.normal, o, l, intensity as f64)
            }
            _ => 0.0,
        }
    });
    Ok(against_reference(&film, &reference, spp, 0.05, 0.001))
}

pub fn check(run: &CaseRun) -> Result<Verdict, CheckError> {
    let origin = at(run, Vec3::ZERO)?;
    let away = at(run, Vec3::new(431.7, -287.3, 702.9))?;
    let worst = if origin.error >= away.error { &origin } else { &away };
    Ok(Verdict {
        detail: format!("at the origin: {}; 873 units away: {}", origin.detail, away.detail),
        ..worst.clone()
    })
}

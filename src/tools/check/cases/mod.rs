//! The cases, grouped by what they stress (one file per group), and the checks they share.

mod camera;
mod cylinders;
mod degenerate;
mod glass;
mod grazing;
mod inside;
mod lights;
mod placement;
mod rays;
mod roughness;
mod self_intersection;

use super::pixel::{Reference, grey};
use super::{Case, CaseRun, CheckError, Verdict};
use crate::camera::Camera;
use crate::film::Film;
use crate::scene::Scene;
use glam::{DVec3, Vec2};

macro_rules! case {
    ($name:literal, $promise:literal, $check:path) => {
        Case { name: $name, promise: $promise, check: $check }
    };
}

pub fn all() -> Vec<Case> {
    vec![
        case!("far-1e5", "the teapot scene 1e5 units from the origin renders as at the origin", placement::far_1e5),
        case!("far-1e7", "the teapot scene 1e7 units from the origin renders as at the origin", placement::far_1e7),
        case!("scaled-1e-4", "the teapot scene scaled by 1e-4 renders as at scale 1", placement::scaled_small),
        case!("scaled-1e4", "the teapot scene scaled by 1e4 renders as at scale 1", placement::scaled_large),
        case!(
            "grazing-plane",
            "rays within 0.01 degrees of a plane (two triangles) neither leak nor self-intersect",
            grazing::plane
        ),
        case!("tangent-sphere", "rays tangent to a sphere neither leak nor self-intersect", grazing::sphere),
        case!("tangent-cylinder", "rays tangent to a cylinder neither leak nor self-intersect", grazing::cylinder),
        case!(
            "self-intersection",
            "a plane and a sphere under a point light match the analytic irradiance",
            self_intersection::check
        ),
        case!(
            "thin-cylinder",
            "a cylinder of radius 1e-4 of the scene size is hit where it should be",
            cylinders::thin
        ),
        case!("long-cylinder", "a cylinder 1e4 radii long is hit where it should be", cylinders::long),
        case!(
            "cylinder-seen-from-afar",
            "rays leaving a cylinder seen from 1000 units away do not hit it again",
            cylinders::seen_from_afar
        ),
        case!(
            "degenerate-triangles",
            "zero-area, collinear, repeated-vertex and NaN triangles are skipped with a warning",
            degenerate::check
        ),
        case!(
            "axis-parallel-rays",
            "rays with zero direction components hit what they should, at the right distance",
            rays::axis_parallel
        ),
        case!(
            "inside-sphere",
            "a camera inside a sphere sees the closed-form radiance of the enclosure",
            inside::sphere
        ),
        case!("inside-cylinder", "a camera inside a capped cylinder sees the closed-form radiance", inside::cylinder),
        case!(
            "inside-glass-tir",
            "a camera inside a glass cube sees total internal reflection where Snell says",
            glass::inside_tir
        ),
        case!("glass-ior-1", "glass of IOR 1.0 is invisible", glass::ior_one),
        case!(
            "glass-furnace",
            "glass of IOR 1.5 and 3.0 in a white furnace neither gains nor loses energy",
            glass::furnace
        ),
        case!(
            "roughness-0-1",
            "metal and plastic at roughness exactly 0 and 1 stay finite and within energy bounds",
            roughness::check
        ),
        case!(
            "emitters-1e6-1e-6",
            "an emitter of radiance 1e6 next to one of 1e-6: exact where seen, analytic where lit",
            lights::dynamic_range
        ),
        case!("zero-area-lights", "lights of zero area contribute nothing and break nothing", lights::zero_area),
        case!(
            "sky-and-area-light",
            "a plane under a sky and a close area light gets the analytic direct light wherever either dominates",
            lights::sky_and_area
        ),
        case!(
            "inside-closed-mesh",
            "a camera inside a closed mesh sees the closed-form radiance (no leaks)",
            camera::inside_mesh
        ),
        case!(
            "up-parallel-to-view",
            "a camera whose up vector is parallel to its view renders the analytic image",
            camera::up_parallel
        ),
    ]
}

/// The camera a render of `scene` at `w` × `h` uses.
fn camera_of(scene: &Scene, w: u32, h: u32) -> Camera {
    scene.camera(w as f32 / h as f32)
}

/// The primary ray through `film` in double precision (the renderer's own f32 ray, widened).
fn primary(cam: &Camera, film: Vec2) -> (DVec3, DVec3) {
    let r = cam.ray(film, Vec2::ZERO);
    (r.o.as_dvec3(), r.d.as_dvec3())
}

/// Largest |pixel − value| over the image (grey values).
fn worst_abs(film: &Film, value: f64) -> f64 {
    film.pixels.iter().map(|p| (grey(*p) - value).abs()).fold(0.0, f64::max)
}

/// The one-bounce white furnace: every sample of a white (albedo 1) diffuse surface under a
/// uniform sky of radiance 1, rendered with BSDF sampling and a single bounce, is exactly 1
/// (hit or miss). A continuation ray that hits the surface it leaves ends the path at the
/// depth limit and gives 0, so any self-intersection shows as a pixel below 1.
fn one_bounce_furnace(run: &CaseRun, scene: &Scene, w: u32, h: u32, spp: u32) -> Result<f64, CheckError> {
    let film = run.render(scene, &run.bsdf_settings(w, h, spp, 1))?;
    Ok(worst_abs(&film, 1.0))
}

/// Two renders of the same paths (same seed) compared pixel by pixel: the error of a pixel
/// is |a − b| / max(b, floor · mean(b)) (largest channel). Returns (fraction of pixels over
/// `thr`, worst error, relative difference of the image means).
fn same_image(a: &Film, b: &Film, floor: f64, thr: f64) -> (f64, f64, f64) {
    let mean_b = b.pixels.iter().map(|p| grey(*p)).sum::<f64>() / b.pixels.len() as f64;
    let mean_a = a.pixels.iter().map(|p| grey(*p)).sum::<f64>() / a.pixels.len() as f64;
    let (mut over, mut worst) = (0usize, 0.0f64);
    for (p, q) in a.pixels.iter().zip(&b.pixels) {
        let e = (*p - *q).abs().max_element() as f64 / (q.max_element() as f64).max(floor * mean_b).max(1e-30);
        let e = if e.is_nan() { f64::INFINITY } else { e };
        worst = worst.max(e);
        if e > thr {
            over += 1;
        }
    }
    (over as f64 / a.pixels.len() as f64, worst, (mean_a - mean_b).abs() / mean_b.max(1e-30))
}

/// The probability with which a correct pixel may stray beyond [`super::pixel::compare`]'s
/// jitter allowance. A full suite run compares 18,176 pixels with references, 9,587 of them
/// cut by an edge: under 1% of runs can see a correct pixel off, and as Bernstein's bound is
/// not tight, far fewer do (none in 40 seeds × both sizes).
const JITTER_DELTA: f64 = 1e-6;

/// Compares with a closed-form reference: the verdict is the fraction of pixels off by more
/// than `rel` beyond jitter noise (Bernstein's bound at [`JITTER_DELTA`]), against `max_off`.
fn against_reference(film: &Film, r: &Reference, spp: u32, rel: f64, max_off: f64) -> Verdict {
    let c = super::pixel::compare(film, r, spp, rel, JITTER_DELTA);
    Verdict::new(
        100.0 * c.off_fraction(),
        100.0 * max_off,
        "% px off",
        format!(
            "{} of {} px off by > {}% beyond jitter; worst flat-pixel error {:.2e}",
            c.off,
            c.total,
            100.0 * rel,
            c.worst_flat
        ),
    )
}

//! Lights at the extremes: radiance 1e6 next to 1e-6, lights of zero area, and a close area
//! light under a sky, whose share of the light changes across the image.

use super::super::analytic::{Solid, first_hit};
use super::super::pixel::{Reference, grey};
use super::super::scenes::CaseSceneBuilder;
use super::{CaseRun, CheckError, Verdict, against_reference, camera_of, primary};
use crate::film::Film;
use crate::geometry::TriMesh;
use crate::integrator::RenderSettings;
use crate::light::Background;
use glam::{DVec3, Vec3};
use std::f64::consts::PI;

/// Irradiance at `q` (on the plane y = 0, facing up) from the rectangle
/// [x0, x1] × [z0, z1] at height `c` facing down with radiance `le`: le · π · F, F from the
/// corner form factor of a parallel rectangle, which is odd in both offsets, so any position
/// is a signed sum of four corner rectangles.
fn rect_irradiance(q: DVec3, (x0, x1): (f64, f64), (z0, z1): (f64, f64), c: f64, le: f64) -> f64 {
    let f = |a: f64, b: f64| {
        let (ra, rb) = ((a * a + c * c).sqrt(), (b * b + c * c).sqrt());
        (a / ra * (b / ra).atan() + b / rb * (a / rb).atan()) / (2.0 * PI)
    };
    let (ax, bx, az, bz) = (x0 - q.x, x1 - q.x, z0 - q.z, z1 - q.z);
    le * PI * (f(bx, bz) - f(ax, bz) - f(bx, az) + f(ax, az))
}

/// How a lit plane rendered over several seeds (`mean`, with `se` the standard error of each
/// pixel's mean) compares with its analytic radiance `lit`: the pixels off by more than 5
/// pooled standard errors + 1% of their value, and that pooled (median) relative standard
/// error.
fn off_analytic(mean: &Film, se: &[f64], lit: &Reference) -> (usize, f64) {
    let mut rel_se: Vec<f64> = mean.pixels.iter().zip(se).map(|(p, s)| s / grey(*p).max(1e-30)).collect();
    rel_se.sort_by(f64::total_cmp);
    let pooled = rel_se[rel_se.len() / 2];
    let off = mean
        .pixels
        .iter()
        .zip(&lit.pixels)
        .filter(|(p, e)| !((grey(**p) - e.mean).abs() <= (5.0 * pooled + 0.01) * e.mean))
        .count();
    (off, pooled)
}

/// Two 2 × 2 emitters at height 1, radiance 1e6 (over [-1, 1]²) and 1e-6 (over
/// [2, 4] × [-1, 1]), above a diffuse plane of albedo 0.5; direct light only.
///
/// - Seen from below, every pixel must be the emission it sees: 1e6, 1e-6 or 0 (relative
///   error 1e-4 beyond the jitter at edges).
/// - The plane, seen from above at the edge of the bright emitter, must match the form-factor
///   irradiance: over 8 seeds, at most 0.5% of pixels off by more than 5 pooled standard
///   errors + 1%.
pub fn dynamic_range(run: &CaseRun) -> Result<Verdict, CheckError> {
    let (bright, dim) = (1e6f32, 1e-6f32);
    let build = |eye: Vec3, look: Vec3, fov: f32| {
        let mut builder = CaseSceneBuilder::new("emitters");
        let plane = builder.diffuse(0.5);
        let (b, d) = (builder.emitter(bright), builder.emitter(dim));
        builder.quad(Vec3::new(-6.0, 0.0, -6.0), Vec3::new(0.0, 0.0, 12.0), Vec3::new(12.0, 0.0, 0.0), plane);
        builder.quad(Vec3::new(-1.0, 1.0, -1.0), Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 2.0), b);
        builder.quad(Vec3::new(2.0, 1.0, -1.0), Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 2.0), d);
        builder.camera(eye, look, Vec3::Z, fov);
        builder.build()
    };
    let (w, h, spp, seeds) = run.by_quality((24, 24, 8, 4), (48, 48, 16, 8));
    let s = RenderSettings { max_depth: 1, ..run.settings(w, h, spp) };

    // Emitters seen directly.
    let below = build(Vec3::new(1.5, 0.2, 0.0), Vec3::new(1.5, 1.0, 0.0), 150.0);
    let film = run.render(&below, &s)?;
    let cam = camera_of(&below, w, h);
    let solids = [
        Solid::Quad {
            corner: DVec3::new(-1.0, 1.0, -1.0),
            e1: DVec3::new(2.0, 0.0, 0.0),
            e2: DVec3::new(0.0, 0.0, 2.0),
        },
        Solid::Quad {
            corner: DVec3::new(2.0, 1.0, -1.0),
            e1: DVec3::new(2.0, 0.0, 0.0),
            e2: DVec3::new(0.0, 0.0, 2.0),
        },
    ];
    let seen = Reference::new(w, h, 16, |film| {
        let (o, d) = primary(&cam, film);
        match first_hit(&solids, o, d) {
            Some((0, _)) => bright as f64,
            Some(_) => dim as f64,
            None => 0.0,
        }
    });
    let direct = against_reference(&film, &seen, spp, 1e-4, 0.0);
    let dim_px = seen.pixels.iter().enumerate().filter(|(i, p)| seen.is_flat(*i) && p.mean == dim as f64).count();

    // The plane, lit.
    let above = build(Vec3::new(1.0, 0.6, 0.0), Vec3::new(1.0, 0.0, 0.0), 90.0);
    let (mean, se) = run.render_seeds(&above, &s, seeds)?;
    let cam = camera_of(&above, w, h);
    let lit = Reference::new(w, h, 8, |film| {
        let (o, d) = primary(&cam, film);
        let q = o + d * (-o.y / d.y);
        let e = rect_irradiance(q, (-1.0, 1.0), (-1.0, 1.0), 1.0, bright as f64)
            + rect_irradiance(q, (2.0, 4.0), (-1.0, 1.0), 1.0, dim as f64);
        0.5 / PI * e
    });
    let (off, pooled) = off_analytic(&mean, &se, &lit);
    let frac = off as f64 / mean.pixels.len() as f64;
    Ok(Verdict::new(
        direct.error,
        direct.limit,
        direct.metric,
        format!("seen directly: {} ({dim_px} px wholly on the 1e-6 emitter); plane: {off} px off (pooled relative SE {pooled:.4})", direct.detail),
    )
    .require(dim_px > 0, "the view must show the 1e-6 emitter")
    .require(frac <= 0.005, format!("{off} of {} plane pixels off the form-factor irradiance", mean.pixels.len())))
}

/// A diffuse plane (albedo 0.5) under a uniform sky of radiance 1 and a 2 × 2 light of
/// radiance 20 at height 1, seen from below the light (direct light only). Under the light it
/// brings most of the irradiance, two units away the sky does, so next-event estimation's
/// light choice changes across the view: the plane must match π·1 + the light's form-factor
/// irradiance at radiance 20 − 1 (the light hides that much sky), with the same statistics
/// as `emitters-1e6-1e-6`, and its mean relative error over the view within 1% + 4 standard
/// errors of that mean. A choice whose density disagreed with the one MIS weighs against
/// would show here as a bias.
pub fn sky_and_area(run: &CaseRun) -> Result<Verdict, CheckError> {
    let (sky, light) = (1.0f32, 20.0f32);
    let mut builder = CaseSceneBuilder::new("sky-and-area-light");
    let plane = builder.diffuse(0.5);
    let e = builder.emitter(light);
    builder.quad(Vec3::new(-6.0, 0.0, -6.0), Vec3::new(0.0, 0.0, 12.0), Vec3::new(12.0, 0.0, 0.0), plane);
    builder.quad(Vec3::new(-1.0, 1.0, -1.0), Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 2.0), e);
    builder.background(Background::Constant(Vec3::splat(sky)));
    builder.camera(Vec3::new(1.2, 0.6, 0.0), Vec3::new(1.2, 0.0, 0.0), Vec3::Z, 120.0);
    let scene = builder.build();
    let (w, h, spp, seeds) = run.by_quality((24, 24, 8, 4), (48, 48, 16, 8));
    let s = RenderSettings { max_depth: 1, ..run.settings(w, h, spp) };
    let (mean, se) = run.render_seeds(&scene, &s, seeds)?;
    let cam = camera_of(&scene, w, h);
    let lit = Reference::new(w, h, 8, |film| {
        let (o, d) = primary(&cam, film);
        let q = o + d * (-o.y / d.y);
        let e = PI * sky as f64 + rect_irradiance(q, (-1.0, 1.0), (-1.0, 1.0), 1.0, (light - sky) as f64);
        0.5 / PI * e
    });
    let (off, pooled) = off_analytic(&mean, &se, &lit);
    let errors: Vec<f64> = mean.pixels.iter().zip(&lit.pixels).map(|(p, e)| (grey(*p) - e.mean) / e.mean).collect();
    let frac = off as f64 / errors.len() as f64;
    // A bias shows as a mean offset over the whole view, which averages out the pixels' noise:
    // it may be 1% plus 4 standard errors of that mean (pixels are independent, and their
    // variances pooled over the view are a steady estimate). At the full size those are
    // ~0.5%; at the quick size ~2%, where a bare 1% failed a correct render on 1 of 40 seeds.
    let n = errors.len() as f64;
    let bias = errors.iter().sum::<f64>() / n;
    let bias_se = se.iter().zip(&lit.pixels).map(|(s, e)| (s / e.mean).powi(2)).sum::<f64>().sqrt() / n;
    let (lo, hi) = lit.pixels.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), p| (lo.min(p.mean), hi.max(p.mean)));
    Ok(Verdict::new(
        bias.abs(),
        0.01 + 4.0 * bias_se,
        "mean relative error",
        format!("{off} px off (pooled relative SE {pooled:.4}, of the mean {bias_se:.4}); analytic radiance {lo:.2}..{hi:.2}"),
    )
    .require(hi > 2.0 * lo, "the view must span where the light dominates and where the sky does")
    .require(frac <= 0.005, format!("{off} of {} plane pixels off the analytic irradiance", errors.len())))
}

/// A plane and a sphere under a point light, plus emitters of zero area: a triangle with
/// three collinear corners, one with a repeated corner, and a sphere of radius 0. They must
/// change nothing: the image must be bit-identical to the render without them (the light
/// choice gives them probability 0); and with only them as lights the image must be black.
pub fn zero_area(run: &CaseRun) -> Result<Verdict, CheckError> {
    let build = |point_light: bool, zero: bool| {
        let mut builder = CaseSceneBuilder::new("zero-area");
        let m = builder.diffuse(0.5);
        let e = builder.emitter(5.0);
        builder.quad(Vec3::new(-4.0, 0.0, -4.0), Vec3::new(0.0, 0.0, 8.0), Vec3::new(8.0, 0.0, 0.0), m);
        builder.sphere(Vec3::new(0.0, 1.0, 0.0), 1.0, m);
        if zero {
            let mesh = TriMesh::new(
                "zero",
                vec![
                    Vec3::new(-1.0, 3.0, 0.0),
                    Vec3::new(0.0, 3.0, 0.5),
                    Vec3::new(1.0, 3.0, 1.0),
                    Vec3::new(1.5, 2.5, -1.0),
                ],
                vec![[0, 1, 2], [3, 3, 0]],
                vec![],
                vec![],
            )
            .expect("indices in range");
            builder.mesh(mesh, e);
            builder.sphere(Vec3::new(1.0, 3.0, -1.0), 0.0, e);
        }
        if point_light {
            builder.point_light(Vec3::new(2.0, 5.0, 3.0), 40.0);
        }
        builder.camera(Vec3::new(3.0, 3.0, 5.0), Vec3::new(0.0, 0.8, 0.0), Vec3::Y, 50.0);
        builder.build()
    };
    let (w, h, spp) = run.by_quality((24, 24, 4), (48, 48, 16));
    let s = run.settings(w, h, spp);
    let with = run.render(&build(true, true), &s)?;
    let without = run.render(&build(true, false), &s)?;
    let only = run.render(&build(false, true), &s)?;
    let naive_only = run.render_naive(&build(false, true), &s)?;
    let worst = diff(&with, &without);
    let black = only.pixels.iter().chain(&naive_only.pixels).all(|p| *p == Vec3::ZERO);
    Ok(Verdict::new(worst, 0.0, "max |Δpx|", "with vs without zero-area emitters (same seed)")
        .require(black, "zero-area emitters alone must give a black image"))
}

fn diff(a: &Film, b: &Film) -> f64 {
    a.pixels
        .iter()
        .zip(&b.pixels)
        .map(|(p, q)| (*p - *q).abs().max_element() as f64)
        .fold(0.0, |m, x| if x.is_nan() { f64::INFINITY } else { m.max(x) })
}

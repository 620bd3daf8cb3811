//! Caustic light paths (`--caustics`, on by default where a scene has mirrors or glass): light
//! that reaches a surface the camera sees through mirrors and glass only, carried by paths
//! traced from the lights and splatted onto the film.
//!
//! A path from the camera finds such light only by chance: at the first surface it hits (x),
//! next-event estimation cannot see the lamp through the glass, so the light counts only when
//! x's BSDF sample happens to go through the glass and on to the lamp (the bright spot under a
//! glass ball, the lamp's reflection a mirror throws on the floor). These paths are much of
//! such scenes' noise. A path traced from a light finds them easily: it leaves the light,
//! bounces off mirrors and through glass (only specular bounces), and where it lands on a
//! surface that is neither, it connects to the camera with a shadow ray and adds its light to
//! the pixel the camera sees it in (light tracing, the t = 1 strategy of a bidirectional path
//! tracer; Veach 1997, §10).
//!
//! The two kinds of path share the work without overlap, so the sum stays unbiased: paths
//! from the camera leave out exactly the light they would find as camera → x (a diffuse
//! bounce) → one or more specular bounces → an emitter the light paths start from
//! ([`crate::light::Emitters::covers`]), and the light paths carry exactly that light:
//! emitter → specular bounces (as many as the path depth leaves room for) → x → camera. On a
//! glossy surface (rough metal, plastic, glTF materials) the caustic stays with the paths from
//! the camera: there a light path's connection can land in the peak of the BSDF's lobe, a
//! firefly (one on a rough copper ball held 2/3 of a render's error). Point
//! lights, which no path from the camera ever hits, get their caustics this way too. Light
//! that the camera sees through glass (camera → glass → floor → glass → lamp) stays with the
//! paths from the camera.
//!
//! The light paths are traced once per render, before the first pixel, as many as the render
//! has samples ([`paths`]), in fixed chunks of [`CHUNK`], each chunk a Sobol sequence of its
//! own. Each splat is added to its pixels in 32.32 fixed point ([`LightSums`]): integer sums do
//! not depend on the order they are made in, so the image is bit-identical whatever the thread
//! count. The pass gives the same image for any kernel (it runs the general code) and on
//! resumption (it is
//! in its checkpoint). A shard traces every shard-count-th chunk, and the merge adds the
//! shards' sums: the same integers as the whole render's.

use super::context::PathContext;
use super::surface::{surface_point, transmittance};
use crate::film::LightSums;
use crate::geometry::{Aabb, Geometry, Ray, Shape, Sphere, offset_ray_origin, offset_toward};
use crate::light::Emitters;
use crate::material::BsdfModel;
use crate::material::MaterialModel;
use crate::sampler::{PixelSampler, SampleStream, mix64};
use crate::scene::Scene;
use crate::settings::clamp_sample;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::sync::atomic::{AtomicI64, AtomicU64, Ordering};

/// Light paths per chunk: one Sobol sequence each.
pub(super) const CHUNK: u64 = 4096;

/// Light paths per sample the render plans (see [`paths`]).
const PATHS_PER_SAMPLE: u64 = 4;

/// What the light paths add to the image ([`LightSums`]), the rays they traced, and how many
/// of their splats the sample clamp scaled down.
pub(super) struct CausticImage {
    pub sums: LightSums,
    pub rays: u64,
    pub clamped: u64,
}

/// How many light paths a render traces: one for every [`PATHS_PER_SAMPLE`] samples it plans
/// (`spp` per pixel), at least one chunk's worth.
pub(super) fn paths(width: u32, height: u32, spp: u32) -> u64 {
    (width as u64 * height as u64 * spp.max(1) as u64 / PATHS_PER_SAMPLE).max(CHUNK)
}

/// A sphere around every surface that can bounce light specularly (every surface whose
/// material is not purely diffuse): a light path adds nothing unless its first bounce is one,
/// so paths start toward it ([`crate::light::Emitters::sample`]). `None` if there is none.
pub(super) fn target(scene: &Scene) -> Option<Sphere> {
    let mut bounds = Aabb::EMPTY;
    for (gi, g) in scene.geometry.iter().enumerate() {
        for prim in 0..g.len() {
            let lobes = scene.material(gi as u32, prim as u32).kind.lobes();
            if !(lobes.glossy || lobes.mirror || lobes.glass) {
                continue;
            }
            bounds = bounds.union(&match g {
                Geometry::Mesh(_) | Geometry::Instance(_) => {
                    g.triangle(prim).iter().fold(Aabb::EMPTY, |b, p| b.grow(*p))
                }
                Geometry::Spheres(s) => s[prim].bounds(),
                Geometry::Cylinders(c) => c[prim].bounds(),
            });
        }
    }
    // With a margin for rounding: a surface just outside would never be aimed at.
    let r = 0.5 * bounds.diagonal().length();
    (bounds.is_valid() && r.is_finite()).then(|| Sphere::new(bounds.center(), r * (1.0 + 1e-4) + 1e-6))
}

/// Traces the render's `paths` light paths from `emitters` through `ctx` (errors deferred: the
/// caller checks [`crate::accel::Accel::deferred_error`]), or in a shard its share of them
/// (chunk c goes to shard c mod the shard count), and returns what they add to each pixel's
/// mean; `None` if `stop_requested` said so between chunks (the sums are then partial).
pub(super) fn render(
    ctx: &PathContext,
    emitters: &Emitters,
    paths: u64,
    stop_requested: &(dyn Fn() -> bool + Sync),
    report: &(dyn Fn(u64, u64) + Sync),
) -> Option<CausticImage> {
    let (w, h) = (ctx.settings.width, ctx.settings.height);
    let sums: Vec<AtomicI64> = (0..3 * w as usize * h as usize).map(|_| AtomicI64::new(0)).collect();
    // Each path's splat is its share of the mean: the image's pixel count over the paths.
    let share = (w as f64 * h as f64 / paths.max(1) as f64) as f32;
    // The sample clamp (`--clamp X`) acts on a splat as on a camera sample: what the splat
    // adds to a pixel, over its share, is the value a sample would have.
    let clamp = ctx.settings.clamp.map(|limit| limit * share);
    let key = mix64(ctx.settings.seed ^ 0x6361_7573_7469_6373); // "caustics"
    let shard = ctx.settings.shard;
    let chunks: Vec<u64> =
        (0..paths.div_ceil(CHUNK)).filter(|c| shard.is_none_or(|s| c % s.count as u64 == s.index as u64)).collect();
    // Paths and rays traced so far, for `report(paths, rays)` after each chunk.
    let (traced, traced_rays) = (AtomicU64::new(0), AtomicU64::new(0));
    let (rays, clamped) = chunks
        .into_par_iter()
        .map(|chunk| {
            if stop_requested() {
                return None;
            }
            let streams = PixelSampler::new(ctx.settings.sampler, key, chunk);
            let (mut rays, mut clamped) = (0, 0);
            let n = CHUNK.min(paths - chunk * CHUNK);
            for s in 0..n {
                let mut rng = streams.sample(s);
                let mut splat = |film: Vec2, value: Vec3| {
                    let value = value * share;
                    if !value.is_finite() {
                        return;
                    }
                    ctx.settings.filter.splat(film * Vec2::new(w as f32, h as f32), (w, h), |x, y, weight| {
                        let i = 3 * (y as usize * w as usize + x as usize);
                        let mut value = value * weight;
                        if let Some(limit) = clamp {
                            let scaled;
                            (value, scaled) = clamp_sample(value, limit);
                            clamped += scaled as u64;
                        }
                        for (c, v) in value.to_array().into_iter().enumerate() {
                            // `as` saturates: a value beyond 2³¹ is clamped, not wrapped.
                            sums[i + c].fetch_add((v as f64 * LightSums::ONE).round() as i64, Ordering::Relaxed);
                        }
                    });
                };
                trace(ctx, emitters, &mut rng, &mut rays, &mut |sp, bsdf, to_light, beta, lens, rays| {
                    connect(ctx, sp, bsdf, to_light, beta, lens, rays, &mut splat)
                });
            }
            report(traced.fetch_add(n, Ordering::Relaxed) + n, traced_rays.fetch_add(rays, Ordering::Relaxed) + rays);
            Some((rays, clamped))
        })
        .try_reduce(|| (0, 0), |a, b| Some((a.0 + b.0, a.1 + b.1)))?;
    let sums = sums.chunks_exact(3).map(|c| std::array::from_fn(|k| c[k].load(Ordering::Relaxed))).collect();
    Some(CausticImage { sums: LightSums(sums), rays, clamped })
}

/// What a light path does where it lands on a diffuse surface after a specular bounce: it is
/// given the surface point, its BSDF, the unit direction toward the light it came from, its
/// weight, a point drawn for the camera's lens, and the ray count.
pub(super) type Land<'a> =
    dyn FnMut(&super::surface::SurfacePoint, crate::material::Bsdf, Vec3, Vec3, Vec2, &mut u64) + 'a;

/// One light path: from a light chosen by `emitters`, through specular bounces only; at each
/// diffuse surface after the first bounce `land` is called (the render's connects it to the
/// camera). Draws its numbers from `rng`; `rays` counts the rays it traced.
pub(super) fn trace(
    ctx: &PathContext,
    emitters: &Emitters,
    rng: &mut SampleStream<'_>,
    rays: &mut u64,
    land: &mut Land,
) {
    let u_choice = rng.next_f32();
    let (u, v) = (rng.next_2d(), rng.next_2d());
    let Some(e) = emitters.sample(u_choice, u, v) else { return };
    let mut beta = e.weight;
    let origin = if e.n == Vec3::ZERO { e.p } else { offset_ray_origin(e.p, e.n) };
    let mut ray = Ray::new(origin, e.d);
    let mut absorption = Vec3::ZERO;
    // Specular bounces so far: a path from the camera that finds this light takes one more
    // bounce (at the surface it connects from) than these.
    let mut bounces = 0;
    loop {
        *rays += 1;
        let Some(hit) = ctx.accel.intersect_deferred(&ray, 0.0, f32::INFINITY) else { return };
        if absorption != Vec3::ZERO {
            // Beer–Lambert over the segment inside glass, as the path from the camera has it.
            beta *= transmittance(absorption, hit.t * ray.d.length());
        }
        let sp = surface_point::<true>(ctx.scene, ctx.normals, &ray, &hit);
        let to_light = -ray.d;
        let mut bsdf = sp.material.bsdf_at::<true>(&sp.tex);
        let lens = rng.next_2d();
        if bounces > 0 && bsdf.is_lambertian() {
            land(&sp, bsdf, to_light, beta, lens, rays);
        }
        if bounces + 2 > ctx.path_depth {
            return; // a further bounce would leave the camera's path too long
        }
        // The next specular bounce, sampled from the side the light comes from.
        let transmissive = bsdf.is_transmissive();
        let (ng, frame) = sp.shading::<true>(to_light, transmissive, &mut bsdf);
        let ns = frame.n;
        let wo_l = frame.to_local(to_light);
        let (u, uc) = (rng.next_2d(), rng.next_f32());
        let Some(bs) = bsdf.sample(wo_l, u, uc) else { return };
        if !bs.delta || !(bs.pdf > 0.0) {
            return;
        }
        let wi = frame.to_world(bs.wi);
        let side = wi.dot(ng);
        if !transmissive && side <= 0.0 {
            return;
        }
        // Light, not importance, is carried: the BSDF's adjoint (its scale across a refraction,
        // and the shading normal's correction, 1 where it is the geometric one).
        let cos_ng = to_light.dot(ng).abs() * wi.dot(ns).abs();
        let correction = if cos_ng > 0.0 { to_light.dot(ns).abs() * side.abs() / cos_ng } else { 0.0 };
        beta *= bs.f * (bs.wi.z.abs() / bs.pdf * bsdf.light_path_scale(wo_l, bs.wi) * correction);
        if transmissive {
            absorption = if side < 0.0 { sp.material.absorption() } else { Vec3::ZERO };
        }
        if beta == Vec3::ZERO || !beta.is_finite() {
            return;
        }
        bounces += 1;
        ray = Ray::new(if transmissive { offset_toward(sp.p, ng, wi) } else { offset_ray_origin(sp.p, ng) }, wi);
    }
}

/// The connection of the light path arriving at `sp` from `to_light` with weight `beta` to the
/// camera (through its lens point drawn with `lens`): the BSDF evaluated as the path from the
/// camera evaluates it at its first hit (the same shading frame), times the camera's weight.
#[allow(clippy::too_many_arguments)]
fn connect(
    ctx: &PathContext,
    sp: &super::surface::SurfacePoint,
    mut bsdf: crate::material::Bsdf,
    to_light: Vec3,
    beta: Vec3,
    lens: Vec2,
    rays: &mut u64,
    splat: &mut dyn FnMut(Vec2, Vec3),
) {
    let Some(view) = ctx.camera.sees(sp.p, lens) else { return };
    let to_cam = view.lens - sp.p;
    let wo = to_cam.normalize();
    let transmissive = bsdf.is_transmissive();
    let (ng, frame) = sp.shading::<true>(wo, transmissive, &mut bsdf);
    if !transmissive && to_light.dot(ng) <= 0.0 {
        return; // lit from behind: the path from the camera leaves on its side only
    }
    let wi_l = frame.to_local(to_light);
    let f = bsdf.eval(frame.to_local(wo), wi_l) * wi_l.z.abs();
    let cos_in = to_light.dot(ng).abs();
    if f == Vec3::ZERO || !(cos_in > 0.0) {
        return;
    }
    let value = beta * f * (wo.dot(ng).abs() / cos_in * view.weight);
    if value == Vec3::ZERO || !value.is_finite() {
        return;
    }
    let o = if transmissive { offset_toward(sp.p, ng, wo) } else { offset_ray_origin(sp.p, ng) };
    *rays += 1;
    if !ctx.accel.occluded_deferred(&Ray::new(o, view.lens - o), 0.0, 1.0) {
        splat(view.film, value);
    }
}

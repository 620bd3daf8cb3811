//! Lambertian vertices shaded [`LANES`] at a time: the wavefront loop's shade stage for
//! kernels without glossy or glass materials, in renders without light vertices, caustic
//! guiding or the uniform-hemisphere estimator ([`applies`]).
//!
//! A vertex is shaded in three steps. Gather, one path at a time: its shading point
//! ([`surface_point`]: the mesh's or shape's own knowledge, with its memory look-ups), the
//! emission its ray found, its light sample ([`crate::light::LightSet::sample`]) and every
//! number it draws, into structure-of-arrays form. Arithmetic, for all lanes in one
//! branch-free loop ([`diffuse_bounce`]): the shading frame, the ray origin off the surface,
//! the Lambertian BSDF toward the light and its MIS weight, the cosine-weighted direction the
//! path continues in, its new throughput and Russian roulette; the loop calls the scalar
//! loop's own functions ([`Frame::from_normal`], [`offset_ray_origin`], [`Lambert`]'s
//! methods), which the compiler turns into vector instructions across the lanes. Scatter, one
//! at a time again: the shadow rays queued and the paths' states written back.
//!
//! Each lane computes what [`super::path::shade`] computes for its vertex, operation for
//! operation on the same numbers, so the image is the scalar kernel's bit for bit (tested with
//! the wavefront loop's). A path draws its numbers before it knows whether it ends at this
//! vertex; a path that ends never draws again, so every path that goes on has drawn what the
//! scalar loop draws.

use super::context::PathContext;
use super::mis::power_heuristic;
use super::path::{PathRules, found_background, found_emission};
use super::surface::surface_point;
use super::wavefront::{Lane, ShadowQueue};
use crate::accel::LANES;
use crate::geometry::{Frame, Ray, offset_ray_origin};
use crate::light::LightSample;
use crate::material::{BsdfModel, Lambert};
use glam::{Vec2, Vec3};

/// Whether the lane stage shades the vertices of a render whose kernel has these switches
/// (those of [`super::kernel::KernelChoice`]): where its plan says so
/// ([`super::RenderPlan::lane_shading`]) and no light vertices or guide run.
#[inline(always)]
pub(super) fn applies<const GLOSSY: bool, const GLASS: bool>(ctx: &PathContext) -> bool {
    !GLOSSY && !GLASS && run_in(ctx)
}

/// Whether the lane stage shades the vertices of the render of `ctx` (its kernel's switches
/// as its plan has them).
#[inline]
pub(super) fn run_in(ctx: &PathContext) -> bool {
    ctx.lanes && ctx.light_vertices.is_none() && ctx.guide.is_none()
}

/// A vector per lane, by component.
#[derive(Clone, Copy, Default)]
struct V {
    x: [f32; LANES],
    y: [f32; LANES],
    z: [f32; LANES],
}

impl V {
    #[inline(always)]
    fn at(&self, i: usize) -> Vec3 {
        Vec3::new(self.x[i], self.y[i], self.z[i])
    }

    #[inline(always)]
    fn set(&mut self, i: usize, a: Vec3) {
        (self.x[i], self.y[i], self.z[i]) = (a.x, a.y, a.z);
    }
}

/// What the Lambertian vertex of each lane brings to the arithmetic.
#[derive(Default)]
struct DiffuseVertices {
    /// Lanes holding a vertex to shade.
    live: [bool; LANES],
    p: V,
    /// The geometric and shading normals, turned to the side of `wo`.
    ng: V,
    ns: V,
    wo: V,
    albedo: V,
    beta: V,
    /// Lanes with a light sample: its direction, radiance, density and whether it is weighed
    /// by MIS (a light BSDF sampling can hit, with MIS on).
    light: [bool; LANES],
    light_wi: V,
    light_radiance: V,
    light_pdf: [f32; LANES],
    light_mis: [bool; LANES],
    /// The numbers of the BSDF sample and of Russian roulette (if it runs after this vertex).
    u: [Vec2; LANES],
    u_rr: [f32; LANES],
    rr: [bool; LANES],
    /// The path ends after this vertex whatever its bounce (nothing it could find emits).
    last: [bool; LANES],
}

/// What the arithmetic gives each lane.
#[derive(Default)]
struct DiffuseBounce {
    /// Where both rays leave from.
    leave: V,
    /// Lanes whose light sample is traced, with what it adds if clear.
    shadow: [bool; LANES],
    contribution: V,
    /// Lanes whose path goes on, along `wi` with throughput `beta`, found with density `pdf`.
    goes_on: [bool; LANES],
    wi: V,
    beta: V,
    pdf: [f32; LANES],
}

/// The arithmetic of [`super::path::shade`] at the Lambertian vertices `v`, for all lanes in
/// one loop without branches.
#[inline(always)]
fn diffuse_bounce(v: &DiffuseVertices) -> DiffuseBounce {
    let mut out = DiffuseBounce::default();
    for i in 0..LANES {
        let (ng, ns, wo, beta) = (v.ng.at(i), v.ns.at(i), v.wo.at(i), v.beta.at(i));
        let frame = Frame::from_normal(ns);
        let bsdf = Lambert::new(v.albedo.at(i));
        // Lambertian: only the cosines of local directions matter.
        let wo_l = Vec3::new(0.0, 0.0, wo.dot(frame.n));
        let leave = offset_ray_origin(v.p.at(i), ng);
        // Next-event estimation.
        let wi = v.light_wi.at(i);
        let wi_l = Vec3::new(0.0, 0.0, wi.dot(frame.n));
        let f = bsdf.eval(wo_l, wi_l) * wi_l.z.abs();
        let radiance = v.light_radiance.at(i);
        let mis = power_heuristic(v.light_pdf[i], bsdf.pdf(wo_l, wi_l), 0.0);
        let w = if v.light_mis[i] { mis } else { 1.0 };
        out.shadow[i] = v.live[i] & v.light[i] & (f != Vec3::ZERO) & (radiance != Vec3::ZERO) & (wi.dot(ng) > 0.0);
        out.contribution.set(i, beta * f * radiance * (w / v.light_pdf[i]));
        // The BSDF sample.
        let s = bsdf.sample_branchless(wo_l, v.u[i]);
        let wi = frame.to_world(s.wi);
        let ok = v.live[i] & (s.pdf > 0.0) & (wi.dot(ng) > 0.0);
        let mut beta = beta * (s.f * (s.wi.z.abs() / s.pdf));
        // Russian roulette.
        let q = (1.0 - beta.max_element()).max(0.05);
        let survives = !v.rr[i] | !(v.u_rr[i] < q);
        beta = if v.rr[i] { beta / (1.0 - q) } else { beta };
        out.goes_on[i] = ok & survives & (beta != Vec3::ZERO) & beta.is_finite() & !v.last[i];
        out.leave.set(i, leave);
        out.wi.set(i, wi);
        out.beta.set(i, beta);
        out.pdf[i] = s.pdf;
    }
    out
}

/// Shades the vertices of `paths` (at most [`LANES`], each at its ray's closest hit, lanes
/// `first..` of the batch) as [`super::path::shade`] would one at a time, `TEX` and
/// `HIT_LIGHTS` as there: queues their shadow rays in `shadow`, sets each path's `goes_on`
/// and, where it goes on, its ray.
#[inline(always)]
pub(super) fn shade_diffuse<const TEX: bool, const HIT_LIGHTS: bool>(
    ctx: &PathContext,
    rules: &PathRules,
    paths: &mut [Lane],
    first: usize,
    shadow: &mut ShadowQueue,
) {
    debug_assert!(paths.len() <= LANES);
    let mut v = DiffuseVertices::default();
    let draws = ctx.lights.numbers();
    let mut samples: [Option<LightSample>; LANES] = [None; LANES];
    for (i, lane) in paths.iter_mut().enumerate() {
        let path = &mut lane.path;
        let Some(hit) = lane.hit else {
            found_background::<HIT_LIGHTS>(ctx, rules, path);
            continue;
        };
        let ray = path.ray();
        let sp = surface_point::<TEX>(ctx.scene, ctx.normals, &ray, &hit);
        found_emission::<TEX, HIT_LIGHTS>(ctx, rules, path, &hit, &sp);
        if path.depth >= ctx.path_depth {
            continue;
        }
        let wo = -ray.d;
        let (ng, ns) = sp.facing(wo, false);
        v.live[i] = true;
        v.p.set(i, sp.p);
        v.ng.set(i, ng);
        v.ns.set(i, ns);
        v.wo.set(i, wo);
        v.albedo.set(i, sp.material.lambert_at::<TEX>(&sp.tex).albedo());
        v.beta.set(i, path.beta);
        if rules.use_nee {
            path.choice = ctx.lights.choice_facing(sp.p, ng);
            let u_choice = if draws.choice { lane.rng.next_f32() } else { 0.0 };
            let u = if draws.position { lane.rng.next_2d() } else { Vec2::ZERO };
            if let Some(ls) = ctx.lights.sample(&path.choice, sp.p, u_choice, u) {
                v.light[i] = true;
                v.light_wi.set(i, ls.wi);
                v.light_radiance.set(i, ls.radiance);
                v.light_pdf[i] = ls.pdf;
                v.light_mis[i] = rules.nee_mis(&ls);
                samples[i] = Some(ls);
            }
        }
        v.u[i] = lane.rng.next_2d();
        v.rr[i] = path.depth + 1 >= ctx.roulette_start;
        if v.rr[i] {
            v.u_rr[i] = lane.rng.next_f32();
        }
        v.last[i] = !HIT_LIGHTS && path.depth + 1 >= ctx.path_depth;
    }
    let out = diffuse_bounce(&v);
    for (i, lane) in paths.iter_mut().enumerate() {
        lane.goes_on = false;
        if !v.live[i] {
            continue;
        }
        let leave = out.leave.at(i);
        if out.shadow[i]
            && let Some(ls) = &samples[i]
        {
            let (ray, tmax) = ls.shadow_ray(leave);
            shadow.push(first + i, lane, ray, tmax, out.contribution.at(i));
        }
        if out.goes_on[i] {
            lane.path.bounced_diffuse(out.beta.at(i), out.pdf[i], v.p.at(i), Ray::new(leave, out.wi.at(i)));
            lane.goes_on = true;
        }
    }
}

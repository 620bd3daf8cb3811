//! The path tracer: an iterative estimator of the rendering equation with next-event
//! estimation and multiple importance sampling (power heuristic, Veach 1997) against BSDF
//! sampling, and Russian roulette.

use super::context::PathContext;
use super::light_vertex::{self, PathVertex, SampleLightVertices};
use super::surface::{facing_shading_normal, surface_point};
use crate::accel::Accel;
use crate::geometry::{Frame, Hit, Ray, offset_ray_origin, offset_toward};
use crate::light::LightChoice;
use crate::material::{Bsdf, BsdfModel, BsdfSample};
use crate::sampler::SampleStream;
use crate::settings::Estimator;
use glam::Vec3;

/// Power heuristic with β = 2.
#[inline]
fn power_heuristic(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    if a2 + b2 > 0.0 { a2 / (a2 + b2) } else { 0.0 }
}

/// Radiance along the camera ray `ray`, whose closest hit `first` the caller traced, then
/// through `accel` (`ctx.accel`, possibly as its concrete type), connecting to
/// `light_vertices` (the sample's entries of `ctx.light_vertices`, if any); `rays` counts the rays traced
/// after the first. Queries defer their errors: the caller checks
/// [`Accel::deferred_error`] before using the result. The const switches are those of
/// [`super::kernel::KernelChoice`]: each one off removes the code of an effect the scene
/// lacks (see there).
#[inline(always)]
pub(crate) fn radiance<
    A: Accel + ?Sized,
    const TEX: bool,
    const GLOSSY: bool,
    const GLASS: bool,
    const HIT_LIGHTS: bool,
>(
    ctx: &PathContext,
    accel: &A,
    mut ray: Ray,
    first: Option<Hit>,
    light_vertices: Option<SampleLightVertices>,
    rng: &mut SampleStream<'_>,
    rays: &mut u64,
) -> Vec3 {
    let s = ctx.settings;
    let use_nee = matches!(s.estimator, Estimator::NeeMis | Estimator::NeeOnly) && !ctx.lights.is_empty();
    let uniform_diffuse = s.estimator == Estimator::BsdfUniform;
    let mis = HIT_LIGHTS && s.estimator == Estimator::NeeMis;
    let found = FoundEmission { use_nee, count: s.estimator != Estimator::NeeOnly, mis };
    let mut l = Vec3::ZERO;
    let mut beta = Vec3::ONE;
    let mut specular = true; // camera rays count as specular: emission seen directly is kept
    let mut prev_pdf = 0.0f32;
    let mut prev_p = ray.o;
    // How next-event estimation chose its light at the last vertex where it ran: the
    // densities MIS weighs emission found by the next ray against (only needed after a
    // non-specular bounce, which always follows next-event estimation).
    let mut choice = LightChoice::BY_POWER;
    let mut depth = 0u32;
    // The absorption of the medium `ray` travels in: that of the glass it last refracted into
    // (zero outside any, and without glass).
    let mut absorption = Vec3::ZERO;
    // The closest hit of `ray`: the caller's for the camera ray, then traced at each bounce.
    let mut next_hit = first;
    loop {
        if GLASS && absorption != Vec3::ZERO {
            // Beer–Lambert over the segment (a channel that absorbs nothing keeps all of its
            // light even on an endless one).
            let d = next_hit.as_ref().map_or(f32::INFINITY, |h| h.t * ray.d.length());
            let kept = (-absorption * d).exp();
            beta *= Vec3::select(absorption.cmpeq(Vec3::ZERO), Vec3::ONE, kept);
            if beta == Vec3::ZERO {
                break;
            }
        }
        let Some(hit) = next_hit else {
            // Without non-delta lights the background is black.
            if HIT_LIGHTS {
                let le = ctx.lights.background().radiance(ray.d);
                if le != Vec3::ZERO
                    && let Some(w) = found.weight(specular, prev_pdf, || ctx.lights.pdf_background(&choice, ray.d))
                {
                    l += beta * le * w;
                }
            }
            break;
        };
        let sp = surface_point::<TEX>(ctx.scene, ctx.normals, &ray, &hit);
        let wo = -ray.d;
        let emission = sp.material.emission.at::<TEX>(&sp.tex);
        // Without non-delta lights nothing emits.
        if HIT_LIGHTS
            && emission != Vec3::ZERO
            && let Some(w) = found
                .weight(specular, prev_pdf, || ctx.lights.pdf_emitter(&choice, hit.geom, hit.prim, prev_p, sp.p, sp.ng))
        {
            l += beta * emission * w;
        }
        if depth >= ctx.path_depth {
            break;
        }
        // Only Lambertian surfaces: the BSDF's variant is known here, so its methods inline
        // without dispatch.
        let mut bsdf = if GLOSSY || GLASS {
            sp.material.bsdf_at::<TEX>(&sp.tex)
        } else {
            Bsdf::Diffuse(sp.material.lambert_at::<TEX>(&sp.tex))
        };
        let transmissive = GLASS && bsdf.is_transmissive();
        let (mut ng, mut ns) = (sp.ng, sp.ns);
        if !transmissive {
            if wo.dot(ng) < 0.0 {
                // Opaque surfaces are shaded on the side they are seen from.
                ng = -ng;
                ns = -ns;
            }
            ns = facing_shading_normal(wo, ng, ns);
        }
        let frame = Frame::from_normal(ns);
        // A clear coat's own normal, turned and made to face `wo` as `ns` is.
        // (Set in place: rebinding `bsdf` would copy it at every vertex. Only textured
        // kernels have coat normal maps.)
        if TEX
            && GLOSSY
            && let Some(n) = sp.coat_normal(ng)
        {
            bsdf.set_coat_normal(frame.to_local(facing_shading_normal(wo, ng, n)));
        }
        // Without glossy or glass materials every BSDF is Lambertian: evaluated and sampled
        // inline (the same arithmetic as through `Bsdf`'s dispatch), and only the cosines of
        // local directions matter to it.
        let lambert = !(GLOSSY || GLASS);
        let local = |v: Vec3| if lambert { Vec3::new(0.0, 0.0, v.dot(frame.n)) } else { frame.to_local(v) };
        let wo_l = local(wo);
        // Both rays leave an opaque surface on the side of `ng` facing `wo` (checked below for
        // each), so they share one origin.
        let leave = if transmissive { sp.p } else { offset_ray_origin(sp.p, ng) };
        let origin = |toward: Vec3| if transmissive { offset_toward(sp.p, ng, toward) } else { leave };

        // Next-event estimation.
        let nee_here = use_nee && !((GLOSSY || GLASS) && bsdf.is_delta());
        if nee_here {
            choice = ctx.lights.choice_at(sp.p).facing(if transmissive { Vec3::ZERO } else { ng });
        }
        // Only the numbers the light sample uses are drawn (see `LightNumbers`).
        let draws = ctx.lights.numbers();
        let light_sample = if nee_here {
            let u_choice = if draws.choice { rng.next_f32() } else { 0.0 };
            let u = if draws.position { rng.next_2d() } else { glam::Vec2::ZERO };
            ctx.lights.sample(&choice, sp.p, u_choice, u)
        } else {
            None
        };
        if let Some(ls) = light_sample {
            let wi_l = local(ls.wi);
            let side = ls.wi.dot(ng);
            let f = if lambert { bsdf.eval_lambert(wo_l, wi_l) } else { bsdf.eval(wo_l, wi_l) } * wi_l.z.abs();
            if f != Vec3::ZERO && ls.radiance != Vec3::ZERO && (transmissive || side > 0.0) {
                let o = origin(ls.wi);
                let (d, tmax) = match ls.point {
                    // Toward a point on a light: stop just short of it (the light's own
                    // surface is not an occluder), measured in units of the full segment.
                    Some(q) => {
                        let q = if ls.delta { q } else { offset_toward(q, ls.normal, o - q) };
                        (q - o, 1.0)
                    }
                    None => (ls.wi, f32::INFINITY),
                };
                *rays += 1;
                if !accel.occluded_deferred(&Ray::new(o, d), 0.0, tmax) {
                    let w = if ls.delta && ctx.light_vertices.is_some() && !specular {
                        // After a bounce: against the light vertex the last vertex connected to.
                        light_vertex::nee_weight(ctx.lights, &ls, sp.p, ng, prev_p, prev_pdf)
                    } else if ls.delta || !mis {
                        1.0
                    } else {
                        power_heuristic(ls.pdf, bsdf.pdf(wo_l, wi_l))
                    };
                    l += beta * f * ls.radiance * (w / ls.pdf);
                }
            }
        }

        // Connect to this vertex's light vertex (a path as long as the depth allows ends at it).
        if nee_here
            && depth + 2 <= ctx.path_depth
            && let Some(y) = light_vertices.and_then(|v| v.at(depth))
        {
            let x = PathVertex { p: sp.p, leave, ng, frame: &frame, bsdf: &bsdf, wo_l };
            l += if lambert {
                light_vertex::connect::<A, true>(accel, &x, y, beta, rays)
            } else {
                light_vertex::connect::<A, false>(accel, &x, y, beta, rays)
            };
        }

        // Continue the path by sampling the BSDF.
        let bs = if uniform_diffuse && bsdf.is_lambertian() {
            sample_uniform_hemisphere(&bsdf, wo_l, rng.next_2d())
        } else {
            // A lobe number only for BSDFs that choose between lobes.
            let u = rng.next_2d();
            let uc = if bsdf.chooses_lobe() { rng.next_f32() } else { 0.0 };
            if lambert { bsdf.sample_lambert(wo_l, u, uc) } else { bsdf.sample(wo_l, u, uc) }
        };
        let Some(bs) = bs else { break };
        let wi = frame.to_world(bs.wi);
        let side = wi.dot(ng);
        if (!transmissive && side <= 0.0) || !(bs.pdf > 0.0) {
            break; // below the geometric surface: the shading normal would leak light
        }
        beta *= bs.f * (bs.wi.z.abs() / bs.pdf);
        if transmissive {
            // Against the outward normal: into the glass (by transmission, or reflected inside).
            absorption = if side < 0.0 { sp.material.absorption() } else { Vec3::ZERO };
        }
        specular = bs.delta;
        prev_pdf = bs.pdf;
        prev_p = sp.p;
        depth += 1;
        if depth >= ctx.roulette_start {
            let q = (1.0 - beta.max_element()).max(0.05);
            if rng.next_f32() < q {
                break;
            }
            beta /= 1.0 - q;
        }
        if beta == Vec3::ZERO || !beta.is_finite() {
            break;
        }
        if !HIT_LIGHTS && depth >= ctx.path_depth {
            // The next hit could only add emission, and nothing BSDF sampling can find emits.
            break;
        }
        ray = Ray::new(origin(wi), wi);
        *rays += 1;
        next_hit = accel.intersect_deferred(&ray, 0.0, f32::INFINITY);
    }
    l
}

/// How emission that a path's ray runs into (an emitter or the background) is counted.
#[derive(Clone, Copy)]
struct FoundEmission {
    use_nee: bool,
    /// The estimator counts emission found by BSDF sampling (all but NEE-only).
    count: bool,
    mis: bool,
}

impl FoundEmission {
    /// The weight of emission found after a bounce sampled with density `prev_pdf`, or `None`
    /// if it is not counted. After a specular bounce (or the camera), or without next-event
    /// estimation, it counts fully; otherwise only if the estimator counts it, weighted by MIS
    /// against `light_pdf`, the density with which next-event estimation picks it.
    #[inline]
    fn weight(self, specular: bool, prev_pdf: f32, light_pdf: impl FnOnce() -> f32) -> Option<f32> {
        if specular || !self.use_nee {
            Some(1.0)
        } else if self.count {
            Some(if self.mis { power_heuristic(prev_pdf, light_pdf()) } else { 1.0 })
        } else {
            None
        }
    }
}

/// Uniform sampling of the hemisphere above the shading normal (density 1/2π), evaluated with
/// the BSDF's own `eval`: the seed paper's estimator, kept for convergence comparisons.
fn sample_uniform_hemisphere(bsdf: &Bsdf, wo: Vec3, u: glam::Vec2) -> Option<BsdfSample> {
    let z = u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * std::f32::consts::PI * u.y;
    let wi = Vec3::new(r * phi.cos(), r * phi.sin(), z);
    let f = bsdf.eval(wo, wi);
    (f != Vec3::ZERO).then_some(BsdfSample { wi, f, pdf: 0.5 * std::f32::consts::FRAC_1_PI, delta: false })
}

//! The path tracer: an iterative estimator of the rendering equation with next-event
//! estimation and multiple importance sampling (power heuristic, Veach 1997) against BSDF
//! sampling, and Russian roulette.

use super::context::PathContext;
pub(crate) use super::light_vertex::ShadowQuery;
use super::light_vertex::{self, PathVertex, SampleLightVertices};
use super::mis::power_heuristic;
use super::surface::{SurfacePoint, surface_point, transmittance};
use crate::accel::Accel;
use crate::geometry::{Hit, Ray, offset_ray_origin, offset_toward};
use crate::light::{LightChoice, LightSample};
use crate::material::{Bsdf, BsdfModel, BsdfSample};
use crate::sampler::SampleStream;
use crate::settings::Estimator;
use glam::Vec3;

/// How a render's paths count light, read once from its settings.
#[derive(Clone, Copy)]
pub(crate) struct PathRules {
    pub(super) use_nee: bool,
    uniform_diffuse: bool,
    pub(super) mis: bool,
    found: FoundEmission,
}

impl PathRules {
    /// The rules of `ctx`'s render; `HIT_LIGHTS` as in [`shade`].
    #[inline(always)]
    pub fn new<const HIT_LIGHTS: bool>(ctx: &PathContext) -> PathRules {
        let s = ctx.settings;
        let use_nee = matches!(s.estimator, Estimator::NeeMis | Estimator::NeeOnly) && !ctx.lights.is_empty();
        let mis = HIT_LIGHTS && s.estimator == Estimator::NeeMis;
        PathRules {
            use_nee,
            uniform_diffuse: s.estimator == Estimator::BsdfUniform,
            mis,
            found: FoundEmission { use_nee, count: s.estimator != Estimator::NeeOnly, mis },
        }
    }

    /// Whether next-event estimation's sample `ls` is weighed by MIS against BSDF sampling
    /// (and connections): a light BSDF sampling can hit, with MIS on. Otherwise its weight is
    /// 1, but for a delta light against light vertices (see [`shade`]).
    #[inline(always)]
    pub(super) fn nee_mis(&self, ls: &LightSample) -> bool {
        !ls.delta && self.mis
    }
}

/// A path between two of its vertices: what it has gathered, what it carries, and how it
/// came to its current ray.
#[derive(Clone, Copy)]
pub(crate) struct PathState {
    /// The radiance gathered so far.
    pub l: Vec3,
    pub(super) beta: Vec3,
    /// The last bounce was specular (camera rays count as specular: emission seen directly
    /// is kept).
    specular: bool,
    prev_pdf: f32,
    prev_p: Vec3,
    /// How next-event estimation chose its light at the last vertex where it ran: the
    /// densities MIS weighs emission found by the next ray against (only needed after a
    /// non-specular bounce, which always follows next-event estimation).
    pub(super) choice: LightChoice,
    pub(super) depth: u32,
    /// The path so far is the camera, a bounce off a diffuse surface, then only specular ones:
    /// the shape of the light that caustic light paths carry (`super::caustic`). Kept only by
    /// kernels with mirrors or glass, the only ones caustic light paths run with.
    caustic: bool,
    /// The absorption of the medium `ray` travels in: that of the glass it last refracted
    /// into (zero outside any, and without glass).
    absorption: Vec3,
    /// The ray the path travels along.
    ray: Ray,
    /// With light vertices from surfaces: the last vertex could connect to one, and its
    /// bounce reflected off it by a non-specular lobe (a connection could have built the path
    /// to the next vertex).
    conn_next: bool,
    /// With light vertices from surfaces: the area density with which BSDF sampling at the
    /// vertex before the last found the last (0 where no connection could have built the
    /// path to it), and the last vertex's geometric normal on the side the path left by.
    conn_pdf: f32,
    conn_ng: Vec3,
}

impl PathState {
    /// A path starting along the camera ray `ray`.
    #[inline(always)]
    pub fn new(ray: Ray) -> PathState {
        PathState {
            l: Vec3::ZERO,
            beta: Vec3::ONE,
            specular: true,
            prev_pdf: 0.0,
            prev_p: ray.o,
            choice: LightChoice::BY_POWER,
            depth: 0,
            caustic: false,
            absorption: Vec3::ZERO,
            ray,
            conn_next: false,
            conn_pdf: 0.0,
            conn_ng: Vec3::ZERO,
        }
    }

    /// The state after a bounce off a Lambertian surface at `p` that sampled its direction
    /// with density `pdf` (no light vertices from surfaces, no mirrors or glass: `caustic` is
    /// not kept), with throughput `beta` after Russian roulette, continuing along `ray`: what
    /// [`shade`] leaves there.
    #[inline(always)]
    pub(super) fn bounced_diffuse(&mut self, beta: Vec3, pdf: f32, p: Vec3, ray: Ray) {
        self.beta = beta;
        self.specular = false;
        self.prev_pdf = pdf;
        self.prev_p = p;
        self.depth += 1;
        self.ray = ray;
    }

    /// The ray the path travels along: after [`shade`] returned `Some`, the one it returned.
    #[inline(always)]
    pub fn ray(&self) -> Ray {
        self.ray
    }
}

/// Where [`shade`] sends the shadow rays it wants traced: traced at once (one path at a
/// time) or queued with others'.
pub(crate) trait ShadowRays {
    /// Adds `contribution` to `l`, the path's radiance, if nothing lies on `ray` within
    /// `0..=tmax` (in units of `ray.d`).
    fn trace(&mut self, l: &mut Vec3, ray: Ray, tmax: f32, contribution: Vec3);
}

/// Shadow rays traced as they come, each against `accel` ([`radiance`]'s).
struct TraceNow<'a, A: ?Sized> {
    accel: &'a A,
    rays: &'a mut u64,
}

impl<A: Accel + ?Sized> ShadowRays for TraceNow<'_, A> {
    #[inline(always)]
    fn trace(&mut self, l: &mut Vec3, ray: Ray, tmax: f32, contribution: Vec3) {
        *self.rays += 1;
        if !self.accel.occluded_deferred(&ray, 0.0, tmax) {
            *l += contribution;
        }
    }
}

/// Radiance along the camera ray `ray`, whose closest hit `first` the caller traced, then
/// through `accel` (`ctx.accel`, possibly as its concrete type), connecting to
/// `light_vertices` (the sample's entries of `ctx.light_vertices`, if any); `rays` counts the
/// rays traced after the first. Queries defer their errors: the caller checks
/// [`Accel::deferred_error`] before using the result. One path at a time: each vertex is
/// shaded ([`shade`]), then its queries traced. The const switches are those of
/// [`super::kernel::KernelChoice`].
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
    ray: Ray,
    first: Option<Hit>,
    light_vertices: Option<SampleLightVertices>,
    rng: &mut SampleStream<'_>,
    rays: &mut u64,
) -> Vec3 {
    let rules = PathRules::new::<HIT_LIGHTS>(ctx);
    let mut path = PathState::new(ray);
    let mut hit = first;
    loop {
        let mut shadow = TraceNow { accel, rays: &mut *rays };
        let next =
            shade::<_, TEX, GLOSSY, GLASS, HIT_LIGHTS>(ctx, &rules, &mut path, hit, light_vertices, rng, &mut shadow);
        let Some(next) = next else { return path.l };
        *rays += 1;
        hit = accel.intersect_deferred(&next, 0.0, f32::INFINITY);
    }
}

/// Shades the vertex of `path` at `hit`, the closest hit of its ray (`None`: the ray left
/// the scene): adds the emission found there to the path's radiance, sends `shadow` the
/// shadow rays of next-event estimation and of the connection to the vertex's light vertex
/// (from `light_vertices`) with what each adds if clear, in that order, and returns the ray
/// the path continues along (the path's new ray; `None` if it ends). Draws the vertex's
/// random numbers from `rng`. Traces nothing itself: the loop that calls it traces, one
/// path at a time ([`radiance`]) or a batch together. The const switches are those of
/// [`super::kernel::KernelChoice`]: each one off removes the code of an effect the scene
/// lacks (see there).
#[inline(always)]
pub(crate) fn shade<S: ShadowRays, const TEX: bool, const GLOSSY: bool, const GLASS: bool, const HIT_LIGHTS: bool>(
    ctx: &PathContext,
    rules: &PathRules,
    path: &mut PathState,
    hit: Option<Hit>,
    light_vertices: Option<SampleLightVertices>,
    rng: &mut SampleStream<'_>,
    shadow: &mut S,
) -> Option<Ray> {
    let ray = path.ray;
    if GLASS && path.absorption != Vec3::ZERO {
        // Beer–Lambert over the segment.
        let d = hit.as_ref().map_or(f32::INFINITY, |h| h.t * ray.d.length());
        path.beta *= transmittance(path.absorption, d);
        if path.beta == Vec3::ZERO {
            return None;
        }
    }
    let Some(hit) = hit else {
        found_background::<HIT_LIGHTS>(ctx, rules, path);
        return None;
    };
    let sp = surface_point::<TEX>(ctx.scene, ctx.normals, &ray, &hit);
    let wo = -ray.d;
    found_emission::<TEX, HIT_LIGHTS>(ctx, rules, path, &hit, &sp);
    if path.depth >= ctx.path_depth {
        return None;
    }
    // Only Lambertian surfaces: the BSDF's variant is known here, so its methods inline
    // without dispatch.
    let mut bsdf = if GLOSSY || GLASS {
        sp.material.bsdf_at::<TEX>(&sp.tex)
    } else {
        Bsdf::Diffuse(sp.material.lambert_at::<TEX>(&sp.tex))
    };
    let transmissive = GLASS && bsdf.is_transmissive();
    // Only textured kernels have coat normal maps.
    let (ng, frame) = if TEX && GLOSSY {
        sp.shading::<true>(wo, transmissive, &mut bsdf)
    } else {
        sp.shading::<false>(wo, transmissive, &mut bsdf)
    };
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
    let beta = path.beta;
    // Light vertices from surfaces come from area lights, which BSDF sampling can hit; caustic
    // light paths and their guide run only beside mirrors or glass. Kernels without those
    // carry none of their code (checked in debug builds).
    debug_assert!(HIT_LIGHTS || !ctx.light_vertices.is_some_and(|p| p.is_from_surfaces()));
    debug_assert!(GLOSSY || GLASS || (ctx.guide.is_none() && ctx.emitters.is_none()));
    // With light vertices from surfaces: the area density with which BSDF sampling at the
    // last vertex found this one, where a connection could have built the path to it.
    let surface_vertices = HIT_LIGHTS && ctx.light_vertices.is_some_and(|p| p.is_from_surfaces());
    let p_xy = if surface_vertices && path.conn_next {
        let back = path.prev_p - sp.p;
        let d2 = back.length_squared();
        path.prev_pdf * (back.dot(ng) / d2.sqrt()).max(0.0) / d2
    } else {
        0.0
    };
    // Caustic guiding (`super::guide`) at a diffuse vertex after the first bounce: its
    // directions are drawn from a mixture, which both its samples' weights and MIS use.
    let guide = if GLOSSY || GLASS {
        ctx.guide.filter(|_| path.depth > 0 && bsdf.is_lambertian()).and_then(|g| g.at(sp.p))
    } else {
        None
    };
    let mixed = |bsdf_pdf: f32, wi: Vec3| match guide {
        Some(c) => (1.0 - c.share()) * bsdf_pdf + c.share() * c.pdf(wi),
        None => bsdf_pdf,
    };

    // Next-event estimation.
    let nee_here = rules.use_nee && !((GLOSSY || GLASS) && bsdf.is_delta());
    if nee_here {
        path.choice = ctx.lights.choice_facing(sp.p, if transmissive { Vec3::ZERO } else { ng });
    }
    // Only the numbers the light sample uses are drawn (see `LightNumbers`).
    let draws = ctx.lights.numbers();
    let light_sample = if nee_here {
        let u_choice = if draws.choice { rng.next_f32() } else { 0.0 };
        let u = if draws.position { rng.next_2d() } else { glam::Vec2::ZERO };
        ctx.lights.sample(&path.choice, sp.p, u_choice, u)
    } else {
        None
    };
    if let Some(ls) = light_sample {
        let wi_l = local(ls.wi);
        let side = ls.wi.dot(ng);
        let f = if lambert { bsdf.eval_lambert(wo_l, wi_l) } else { bsdf.eval(wo_l, wi_l) } * wi_l.z.abs();
        if f != Vec3::ZERO && ls.radiance != Vec3::ZERO && (transmissive || side > 0.0) {
            let (ray, tmax) = ls.shadow_ray(origin(ls.wi));
            let w = if ls.delta && ctx.light_vertices.is_some() && !path.specular {
                // After a bounce: against the light vertex the last vertex connected to.
                light_vertex::nee_weight(ctx.lights, &ls, sp.p, ng, path.prev_p, path.prev_pdf)
            } else if !rules.nee_mis(&ls) {
                1.0
            } else {
                // Also against the connection from the last vertex to a light vertex here.
                let conn = match ctx.light_vertices {
                    Some(pool) if p_xy > 0.0 => pool.connection_per(ls.light, sp.p, ng, side, p_xy),
                    _ => 0.0,
                };
                power_heuristic(ls.pdf, mixed(bsdf.pdf(wo_l, wi_l), ls.wi), conn)
            };
            shadow.trace(&mut path.l, ray, tmax, beta * f * ls.radiance * (w / ls.pdf));
        }
    }

    // Connect to this vertex's light vertex (a path as long as the depth allows ends at it).
    if nee_here
        && path.depth + 2 <= ctx.path_depth
        && let Some(y) = light_vertices.and_then(|v| v.at(path.depth))
    {
        let x = PathVertex { p: sp.p, leave, ng, frame: &frame, bsdf: &bsdf, wo_l };
        let connection = if lambert {
            light_vertex::connection::<true>(&x, y, beta)
        } else {
            light_vertex::connection::<false>(&x, y, beta)
        };
        if let Some(c) = connection {
            shadow.trace(&mut path.l, c.ray, c.tmax, c.contribution);
        }
    }

    // Continue the path by sampling the BSDF.
    let bs = if let Some(cell) = guide {
        let (pick, u) = (rng.next_f32(), rng.next_2d());
        if pick < cell.share() {
            let wi = cell.sample(pick / cell.share(), u);
            let wi_l = frame.to_local(wi);
            let f = bsdf.eval(wo_l, wi_l);
            (f != Vec3::ZERO && wi_l.z > 0.0).then(|| BsdfSample {
                wi: wi_l,
                f,
                pdf: mixed(bsdf.pdf(wo_l, wi_l), wi),
                delta: false,
            })
        } else {
            bsdf.sample(wo_l, u, 0.0).map(|b| BsdfSample { pdf: mixed(b.pdf, frame.to_world(b.wi)), ..b })
        }
    } else if rules.uniform_diffuse && bsdf.is_lambertian() {
        sample_uniform_hemisphere(&bsdf, wo_l, rng.next_2d())
    } else {
        // A lobe number only for BSDFs that choose between lobes.
        let u = rng.next_2d();
        let uc = if bsdf.chooses_lobe() { rng.next_f32() } else { 0.0 };
        if lambert { bsdf.sample_lambert(wo_l, u, uc) } else { bsdf.sample(wo_l, u, uc) }
    };
    let bs = bs?;
    let wi = frame.to_world(bs.wi);
    let side = wi.dot(ng);
    if (!transmissive && side <= 0.0) || !(bs.pdf > 0.0) {
        return None; // below the geometric surface: the shading normal would leak light
    }
    path.beta *= bs.f * (bs.wi.z.abs() / bs.pdf);
    if transmissive {
        // Against the outward normal: into the glass (by transmission, or reflected inside).
        path.absorption = if side < 0.0 { sp.material.absorption() } else { Vec3::ZERO };
    }
    path.specular = bs.delta;
    if GLOSSY || GLASS {
        path.caustic = if path.depth == 0 { !bs.delta && bsdf.is_lambertian() } else { path.caustic && bs.delta };
    }
    path.prev_pdf = bs.pdf;
    path.prev_p = sp.p;
    if surface_vertices {
        path.conn_next = nee_here && path.depth + 2 <= ctx.path_depth && !bs.delta && side > 0.0;
        path.conn_pdf = p_xy;
        path.conn_ng = ng;
    }
    path.depth += 1;
    if path.depth >= ctx.roulette_start {
        let q_rr = (1.0 - path.beta.max_element()).max(0.05);
        if rng.next_f32() < q_rr {
            return None;
        }
        path.beta /= 1.0 - q_rr;
    }
    if path.beta == Vec3::ZERO || !path.beta.is_finite() {
        return None;
    }
    if !HIT_LIGHTS && path.depth >= ctx.path_depth {
        // The next hit could only add emission, and nothing BSDF sampling can find emits.
        return None;
    }
    path.ray = Ray::new(origin(wi), wi);
    Some(path.ray)
}

/// Adds to the radiance of `path`, whose ray left the scene, the background's emission along
/// it (weighed by MIS where next-event estimation could have found it). Without non-delta
/// lights the background is black.
#[inline(always)]
pub(super) fn found_background<const HIT_LIGHTS: bool>(ctx: &PathContext, rules: &PathRules, path: &mut PathState) {
    let ray = path.ray;
    if HIT_LIGHTS {
        let le = ctx.lights.background().radiance(ray.d);
        if le != Vec3::ZERO
            && let Some(w) = rules.found.weight(
                path.specular,
                path.prev_pdf,
                || ctx.lights.pdf_background(&path.choice, ray.d),
                || 0.0,
            )
        {
            path.l += path.beta * le * w;
        }
    }
}

/// Adds to the radiance of `path` the emission of `sp`, its ray's closest hit `hit` (weighed by
/// MIS where next-event estimation or a connection could have found it). Without non-delta
/// lights nothing emits. Light found after the camera's first hit and only specular bounces
/// since is the caustic light paths' to carry, where they run.
#[inline(always)]
pub(super) fn found_emission<const TEX: bool, const HIT_LIGHTS: bool>(
    ctx: &PathContext,
    rules: &PathRules,
    path: &mut PathState,
    hit: &Hit,
    sp: &SurfacePoint,
) {
    let ray = path.ray;
    let wo = -ray.d;
    let emission = sp.material.emission.at::<TEX>(&sp.tex);
    if HIT_LIGHTS
        && emission != Vec3::ZERO
        && !(path.caustic && path.depth >= 2 && ctx.emitters.is_some_and(|e| e.covers(hit.geom, hit.prim, sp.ng, wo)))
        && let Some(w) = rules.found.weight(
            path.specular,
            path.prev_pdf,
            || ctx.lights.pdf_emitter(&path.choice, hit.geom, hit.prim, path.prev_p, sp.p, sp.ng),
            || connection_ratio(ctx, path, ctx.lights.light_index(hit.geom, hit.prim), ray.d),
        )
    {
        path.l += path.beta * emission * w;
    }
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
    /// against `light_pdf`, the density with which next-event estimation picks it, and
    /// `connection`, the connection to a light vertex ([`connection_ratio`]; 0 if none).
    #[inline]
    fn weight(
        self,
        specular: bool,
        prev_pdf: f32,
        light_pdf: impl FnOnce() -> f32,
        connection: impl FnOnce() -> f32,
    ) -> Option<f32> {
        if specular || !self.use_nee {
            Some(1.0)
        } else if self.count {
            Some(if self.mis { power_heuristic(prev_pdf, light_pdf(), connection()) } else { 1.0 })
        } else {
            None
        }
    }
}

/// With light vertices from surfaces, for emission of light `light` (if it is one) that the
/// path's ray `d` found: the density with which the vertex before the last connects to a light
/// vertex at the last and that vertex's light path starts at this point toward it, per the
/// density with which BSDF sampling found the last vertex from the one before (its
/// solid-angle density from the last vertex, as MIS weighs it against `path.prev_pdf`); 0 where
/// no connection could have built the path.
#[inline]
fn connection_ratio(ctx: &PathContext, path: &PathState, light: Option<u32>, d: Vec3) -> f32 {
    match (ctx.light_vertices, light) {
        (Some(pool), Some(i)) if path.conn_pdf > 0.0 => {
            pool.connection_per(i, path.prev_p, path.conn_ng, d.dot(path.conn_ng), path.conn_pdf)
        }
        _ => 0.0,
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

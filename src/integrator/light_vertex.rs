//! Light vertices: a second way to build the last bounce of a path, for scenes lit by point
//! lights (`--light-vertices`, on by default where every light is a point light inside the
//! scene's surfaces: a lamp in a room).
//!
//! A path that bounces at x onto a surface point z and takes z's light by next-event
//! estimation finds z by sampling x's BSDF. Near a lamp, z's irradiance I cos θ / r² is many
//! times that of the rest of the scene, and BSDF sampling rarely lands there: the light that
//! bounces off surfaces close to the lamp is much of such a scene's noise (Embree's Cornell
//! box hangs its lamp beside the tall block). So each sample also traces one
//! ray from a point light (chosen by power, direction uniform): where it lands is its *light
//! vertex* y, distributed over the surfaces as the lamp's light is. Every path vertex x that
//! could bounce toward y connects to it with a shadow ray: the path x → y → light, whose
//! density is p_conn(y) = P(light) cos θ_y / (4π r²) over surface area at y. The same path
//! found the usual way has density p_uni(y) = P_nee(light | y) p_bsdf(x → y) cos θ_y' / d².
//! Both estimates are weighted by the balance heuristic over the two (Veach 1997: this is a
//! bidirectional path tracer's strategy of light subpaths with one surface vertex, with only
//! that strategy and the unidirectional one), so near the lamp the light vertex carries the
//! path and elsewhere BSDF sampling still does. Unbiased: the two weights of any path sum to 1.
//! (The balance heuristic gives 0.98× the relMSE of the power heuristic on the Cornell box,
//! 0.005863 against 0.005995 at 512² and 64 spp; next-event estimation against BSDF-found
//! emission keeps the power heuristic.)
//!
//! The light vertex is traced once per sample, when the path first reaches a vertex that can
//! connect (not a mirror or glass, and at least two bounces before the path depth); its
//! numbers are drawn there, after that vertex's light sample. It costs one ray per sample and
//! one shadow ray per connection. On Embree's Cornell box (512², 64 spp, 2 threads) a sample
//! traces 1.33× the rays and the render takes 1.45× as long, for 0.61× the relMSE: 1.13× the
//! efficiency (docs/performance.md, "Light vertices").

use super::path::PathContext;
use super::surface::surface_point;
use crate::accel::Accel;
use crate::geometry::{Frame, Ray, offset_toward};
use crate::light::{LightSample, LightSet, uniform_sphere};
use crate::material::Bsdf;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// A surface point lit by a point light, reached by a ray from the light.
pub(super) struct LightVertex {
    pub p: Vec3,
    /// Geometric normal, on the side the light is.
    pub ng: Vec3,
    /// Shading frame, its normal on the side of `ng`.
    pub frame: Frame,
    pub bsdf: Bsdf,
    /// Unit direction toward the light.
    pub to_light: Vec3,
    /// What the vertex carries per unit of its BSDF term f(wo, to_light) |cos θ_s|:
    /// I 4π / (P(light) cos θ_g), the light's radiance arriving at `p` over the vertex's
    /// density, times the area density's r² (which the radiance's 1/r² cancels).
    pub scale: Vec3,
    /// p_conn: area density of this vertex (light choice, direction, cos θ_g / r²).
    pub p_conn: f32,
    /// P_nee(light | p): next-event estimation's probability of choosing this light here.
    pub p_choice: f32,
}

/// The light vertex of a sample: a point light chosen by power with `u_choice`, a ray in the
/// direction `uniform_sphere(u)` from it, and the surface it hits (`None` if it leaves the
/// scene or lands on a mirror or glass, where no path could connect).
#[inline(never)]
pub(super) fn trace<A: Accel + ?Sized, const TEX: bool, const GLOSSY: bool, const GLASS: bool>(
    ctx: &PathContext,
    accel: &A,
    u_choice: f32,
    u: Vec2,
    rays: &mut u64,
) -> Option<LightVertex> {
    let e = ctx.lights.choose_point_by_power(u_choice)?;
    let ray = Ray::new(e.position, uniform_sphere(u));
    *rays += 1;
    let hit = accel.intersect_deferred(&ray, 0.0, f32::INFINITY)?;
    let sp = surface_point::<TEX>(ctx.scene, ctx.normals, &ray, &hit);
    let bsdf = if GLOSSY || GLASS { sp.material.bsdf_at::<TEX>(sp.uv) } else { sp.material.lambert_at::<TEX>(sp.uv) };
    if (GLOSSY || GLASS) && bsdf.is_delta() {
        return None;
    }
    let (ng, ns) = if ray.d.dot(sp.ng) > 0.0 { (-sp.ng, -sp.ns) } else { (sp.ng, sp.ns) };
    let to_l = e.position - sp.p;
    let r2 = to_l.length_squared();
    let to_light = to_l / r2.sqrt();
    let cos_g = to_light.dot(ng);
    if !(cos_g > 0.0 && r2 > 0.0) {
        return None;
    }
    Some(LightVertex {
        p: sp.p,
        ng,
        frame: Frame::from_normal(ns),
        bsdf,
        to_light,
        scale: e.intensity * (4.0 * PI / (e.prob * cos_g)),
        p_conn: e.prob * cos_g / (4.0 * PI * r2),
        p_choice: ctx.lights.choice_probability_at(sp.p, e.light),
    })
}

/// A path vertex that connects to a light vertex: where it is and how it reflects.
pub(super) struct PathVertex<'a> {
    /// The point, and the ray origin for leaving it on the side of `ng`.
    pub p: Vec3,
    pub leave: Vec3,
    /// Geometric normal on the side the path arrived from.
    pub ng: Vec3,
    pub frame: &'a Frame,
    pub bsdf: &'a Bsdf,
    /// The direction the path arrived from, in `frame`.
    pub wo_l: Vec3,
}

/// The contribution of the path through `x` to the light vertex `y` and its light, throughput
/// `beta` before x, MIS-weighted against the same path found by BSDF sampling at x (zero if
/// y is on the wrong side of either surface, or hidden from x). `LAMBERT`: every BSDF is
/// Lambertian, and only cosines to the normal are computed (as the path does).
#[inline(always)]
pub(super) fn connect<A: Accel + ?Sized, const LAMBERT: bool>(
    accel: &A,
    x: &PathVertex,
    y: &LightVertex,
    beta: Vec3,
    rays: &mut u64,
) -> Vec3 {
    let v = y.p - x.p;
    let d2 = v.length_squared();
    let dir = v / d2.sqrt();
    let cos_y = -dir.dot(y.ng);
    if !(d2 > 0.0 && cos_y > 0.0 && dir.dot(x.ng) > 0.0) {
        return Vec3::ZERO;
    }
    let local = |f: &Frame, v: Vec3| if LAMBERT { Vec3::new(0.0, 0.0, v.dot(f.n)) } else { f.to_local(v) };
    let eval = |b: &Bsdf, wo: Vec3, wi: Vec3| if LAMBERT { b.eval_lambert(wo, wi) } else { b.eval(wo, wi) };
    let wi_x = local(x.frame, dir);
    let f_x = eval(x.bsdf, x.wo_l, wi_x) * wi_x.z.abs();
    if f_x == Vec3::ZERO {
        return Vec3::ZERO;
    }
    let wi_y = local(&y.frame, y.to_light);
    let f_y = eval(&y.bsdf, local(&y.frame, -dir), wi_y) * wi_y.z.abs();
    if f_y == Vec3::ZERO {
        return Vec3::ZERO;
    }
    let p_uni = y.p_choice * x.bsdf.pdf(x.wo_l, wi_x) * cos_y / d2;
    let c = beta * f_x * f_y * y.scale * (cos_y / d2 * balance_heuristic(y.p_conn, p_uni));
    if c == Vec3::ZERO || !c.is_finite() {
        return Vec3::ZERO;
    }
    let q = offset_toward(y.p, y.ng, -dir);
    *rays += 1;
    if accel.occluded_deferred(&Ray::new(x.leave, q - x.leave), 0.0, 1.0) { Vec3::ZERO } else { c }
}

/// The MIS weight of next-event estimation's sample `ls` of a point light at `p` (geometric
/// normal `ng` on the side of the path), reached by BSDF sampling with density `prev_pdf` from
/// `prev`: against the same path's light vertex at `p` connected from `prev`.
#[inline(always)]
pub(super) fn nee_weight(lights: &LightSet, ls: &LightSample, p: Vec3, ng: Vec3, prev: Vec3, prev_pdf: f32) -> f32 {
    let Some(q) = ls.point else { return 1.0 };
    let back = prev - p;
    let (d2, r2) = (back.length_squared(), (q - p).length_squared());
    if !(d2 > 0.0 && r2 > 0.0) {
        return 1.0; // a degenerate path, which no light vertex connects
    }
    let p_uni = ls.pdf * prev_pdf * (back.dot(ng) / d2.sqrt()).max(0.0) / d2;
    let p_conn = lights.power_probability(ls.light) * ls.wi.dot(ng).max(0.0) / (4.0 * PI * r2);
    balance_heuristic(p_uni, p_conn)
}

/// The balance heuristic: the weight of a strategy of density `a` against one of density `b`.
#[inline]
fn balance_heuristic(a: f32, b: f32) -> f32 {
    if a + b > 0.0 { a / (a + b) } else { 0.0 }
}

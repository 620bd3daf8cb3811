//! Light vertices: a second way to build the last bounce of a path, for scenes lit by point
//! lights (`--light-vertices`, on by default where every light is a point light inside the
//! scene's surfaces: a lamp in a room) or by area lights in an enclosed scene (on by default
//! where most bounces of the pass before the render stay in the scene: a room).
//!
//! A path that bounces at x onto a surface point z and takes z's light by next-event
//! estimation finds z by sampling x's BSDF. Near a lamp, z's irradiance I cos θ / r² is many
//! times that of the rest of the scene, and BSDF sampling rarely lands there: the light that
//! bounces off surfaces close to the lamp is much of such a scene's noise (Embree's Cornell
//! box hangs its lamp beside the tall block). So each path vertex x also has a *light vertex*
//! y of its own: the point where a ray from a point light (chosen by power, direction
//! uniform) lands, distributed over the surfaces as the lamp's light is. If x could bounce
//! toward y, it connects to it with a shadow ray: the path x → y → light, whose
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
//! From area lights (no point light in the scene) the light vertex is where a light path
//! lands, started at a point on a light chosen by power (uniform by area, in a cosine
//! direction: [`Emitters::sample`]), and the same path has a third way to be found: BSDF
//! sampling at x and then at y, hitting the light. The three are weighed by the power
//! heuristic, each density taken per the light point's cos / r² (which all share):
//! q_conn = P(light) cos θ_y / (π A faces) ([`Emitters::surface_density`]), q_nee = p(x → y)
//! p_nee(y → light), q_bsdf = p(x → y) p_bsdf(y → light), p(x → y) the area density of BSDF
//! sampling at x. A room lit through a window by a sun outside gains most: light reaching the
//! floor through the window lights the room, and BSDF sampling finds that patch rarely (the
//! pool keeps only vertices where the camera's paths go: see
//! [`LightVertexPool::from_surfaces`]).
//!
//! The light vertices are traced once per render, before the first pixel, into a pool (one
//! per sample of the render, at most [`LightVertexPool::SIZE`]) from which each vertex of a
//! sample's path takes its own (see there): a light vertex does not depend on the path that
//! connects to it, so the pool's are as good as a sample's own, and a large image's samples
//! share one ray's work among many. At one depth no two samples of a pixel share one (up to
//! the pool's size, at least the spp), and the vertices of one path connect to different
//! ones; pixels that share vertices have correlated errors, at random places. The pool is
//! the same for any kernel, thread count, tile order and shard. A connection costs one shadow
//! ray. On Embree's Cornell box a sample traces about 1.2× the rays of a render without light
//! vertices, for about half the relMSE (the figures: docs/performance.md, "Light vertices").

use super::mis::{balance_heuristic, power_heuristic};
use super::surface::{FaceNormals, surface_point};
use super::visibility::Visited;
use crate::accel::Accel;
use crate::geometry::{Frame, Ray, offset_ray_origin, offset_toward};
use crate::light::{Emission, Emitters, LightSample, LightSet, uniform_sphere};
use crate::material::{Bsdf, BsdfModel};
use crate::scene::Scene;
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::f32::consts::PI;

/// A surface point lit by a light, reached by a ray from it.
#[derive(Clone, Copy)]
pub(super) struct LightVertex {
    pub p: Vec3,
    /// Geometric normal, on the side the light is.
    pub ng: Vec3,
    /// Shading frame, its normal on the side of `ng`.
    pub frame: Frame,
    pub bsdf: Bsdf,
    /// Unit direction toward the light.
    pub to_light: Vec3,
    /// What the vertex carries per unit of its BSDF term f(wo, to_light) |cos θ_s|: the
    /// light's radiance arriving at `p` over the vertex's density, times the density's
    /// geometric factor at the light (which the radiance's cancels). For a point light
    /// I 4π / (P(light) cos θ_g); for a surface, [`Emission::weight`] / cos θ_g.
    pub scale: Vec3,
    /// A point light's: p_conn, the area density of this vertex (light choice, direction,
    /// cos θ_g / r²). A surface's: q_conn, that density per the light point's cos / r²
    /// ([`Emitters::surface_density`] × cos θ_g).
    pub p_conn: f32,
    /// A point light's: P_nee(light | p), next-event estimation's probability of choosing it
    /// here. A surface's: the solid-angle density with which next-event estimation at `p`
    /// picks the light's point.
    pub p_choice: f32,
    /// From a point light.
    pub delta: bool,
}

/// The vertices paths connect to: one per entry, traced once per render before the first
/// pixel, each from a point light chosen by power with a ray in a uniform direction (see the
/// module documentation): as many as the render has samples, at most [`Self::SIZE`]. A pixel
/// takes a block of B entries (B the render's spp rounded up to a power of two) by a hash h
/// of the pixel and seed, and the vertex after `d` bounces of its sample `s` (s < B) takes
/// entry `h B + (s + d) mod B`. At each depth a pixel's samples take distinct entries of
/// one block, consecutive points of one Owen-scrambled Sobol sequence (well spread over the
/// directions around the lamp, as a pixel's own Sobol samples were), and the vertices of one
/// path take different entries: with one entry per path (the same at every depth) a path's
/// connections gained or lost together when its light vertex lay near or far from the lamp,
/// which left the Cornell box's relMSE 1.08× higher at the same rays. Samples from B
/// on take the next blocks.
pub(crate) struct LightVertexPool {
    vertices: Vec<Option<LightVertex>>,
    index: PoolIndex,
    /// Per light of the set, [`Emitters::surface_density`] × T / M (see
    /// [`LightVertexPool::from_surfaces`]); empty where every light is a point light.
    surface_density: Vec<f32>,
    /// From surfaces: the cells its vertices are kept in.
    visited: Option<Visited>,
    /// The rays traced to build it.
    pub rays: u64,
    /// The distinct vertices it holds (of a pool from surfaces; 0 from point lights).
    pub kept: u32,
}

/// Which entry of a [`LightVertexPool`] each sample takes.
#[derive(Clone, Copy, Debug, PartialEq)]
struct PoolIndex {
    /// log2 of the pool's size.
    size_bits: u32,
    /// log2 of B, the block of consecutive entries a pixel's samples start in.
    block_bits: u32,
    seed: u64,
}

impl PoolIndex {
    /// For a render of `samples` samples in all, `spp` per pixel: B = `spp` rounded up to a
    /// power of two, and as many entries as samples (rounded up to a power of two, at least B,
    /// at most [`LightVertexPool::SIZE`]), so that a small render traces no more light
    /// vertices than it takes.
    fn new(seed: u64, spp: u32, samples: u64) -> PoolIndex {
        let max_bits = LightVertexPool::SIZE.trailing_zeros();
        let block_bits = (spp.max(1) as u64).next_power_of_two().trailing_zeros().min(max_bits);
        let size_bits = samples.max(1).next_power_of_two().trailing_zeros().clamp(block_bits, max_bits);
        PoolIndex { size_bits, block_bits, seed }
    }

    fn size(self) -> u32 {
        1 << self.size_bits
    }

    /// The first entry of the block of B that sample `sample` of pixel `pixel` takes its
    /// vertices from: the pixel's block (by a hash of the pixel and seed) for its first B
    /// samples, the blocks after it for the next ones.
    #[inline]
    fn block_start(self, pixel: u64, sample: u64) -> usize {
        let blocks = 1u64 << (self.size_bits - self.block_bits);
        let block = crate::sampler::mix64(self.seed ^ pixel.wrapping_mul(0x9e37_79b9_7f4a_7c15));
        (((block + (sample >> self.block_bits)) & (blocks - 1)) << self.block_bits) as usize
    }

    /// The entry of the vertex after `depth` bounces of sample `sample` of pixel `pixel`:
    /// entry (s + depth) mod B of its block, s = `sample` mod B (what
    /// [`SampleLightVertices::at`] reads).
    #[cfg(test)]
    fn entry(self, pixel: u64, sample: u64, depth: u32) -> usize {
        let b = (1u64 << self.block_bits) - 1;
        self.block_start(pixel, sample) + ((sample + depth as u64) & b) as usize
    }
}

/// Light vertices from area lights run (unless asked) where at most this share of the rays
/// after a bounce in the first chunk of the camera pass (`super::visibility`) left the scene: in a room, where
/// light bounces many times (the broad suite's interior 2%, `cornell-area.toml` 20%). In open
/// scenes (68–86%: `teapot.toml`, `helmet.toml`, `lamps.toml`, the broad suite's diffuse, metal
/// and textured scenes) the connections' shadow rays cost more than they gain.
pub(super) const MOST_ESCAPED: f64 = 0.5;

/// Light paths of the pilot that sizes a pool from surfaces.
const PILOT: u32 = 4096;

/// The most light paths a pool from surfaces traces per entry.
const MOST_PER_ENTRY: u32 = 4;

impl LightVertexPool {
    /// The most entries of a pool from point lights (the Sobol sequence's index limit).
    pub const SIZE: u32 = 1 << 16;

    /// The pool of a `width` × `height` render of `spp` samples per pixel with `seed`, from its
    /// point lights (every light is one), traced through `accel` (errors deferred, as the
    /// path's queries are: the caller checks [`Accel::deferred_error`]). The same for every
    /// kernel, thread count and shard.
    pub fn build(
        (scene, normals, lights): (&Scene, &FaceNormals, &LightSet),
        accel: &dyn Accel,
        seed: u64,
        (width, height): (u32, u32),
        spp: u32,
    ) -> LightVertexPool {
        let index = PoolIndex::new(seed, spp, width as u64 * height as u64 * spp as u64);
        let scramble = crate::sampler::mix64(seed ^ 0x6c76_706f_6f6c) as u32; // "lvpool"
        let mut rays = 0;
        let vertices = (0..index.size())
            .map(|i| {
                let u = sobol_burley::sample_4d(i, 0, scramble);
                trace((scene, normals, lights), accel, u[2], Vec2::new(u[0], u[1]), &mut rays)
            })
            .collect();
        LightVertexPool { vertices, index, surface_density: Vec::new(), visited: None, rays, kept: 0 }
    }

    /// The pool of a render as [`LightVertexPool::build`]'s, from the lights that emit from
    /// surfaces (no light is a point), keeping only the vertices in cells where paths from the
    /// camera went (`visited`, by the side a surface faces). Light from a lamp outside a room
    /// lit through a window mostly lands outside it (99% in the broad suite's interior): a
    /// pool of every landing would waste almost every connection. So the pool traces T light
    /// paths, T the pool's size S times what a pilot of [`PILOT`] paths (of their own numbers)
    /// says gives about S kept (at most [`MOST_PER_ENTRY`] times), and its entries hold the
    /// first M' of the M kept in turn, M' the largest power of two at most M and S: each fills
    /// S / M' entries alike. Given M, the first M' are as good a sample of where kept paths land
    /// as all M, and M / T estimates how often a path is kept without bias; so each entry's
    /// light is divided by T / M, and MIS weighs the vertices by T / M times the density of one
    /// light path. Outside the visited cells MIS gives paths to the other strategies: the
    /// estimate stays unbiased. Every vertex fills as many entries so that all weigh alike: a
    /// pixel takes a block of consecutive entries, and vertices weighed unlike in runs would
    /// shift whole pixels together. The same for every kernel, thread count and shard.
    pub fn from_surfaces(
        (scene, normals, lights): (&Scene, &FaceNormals, &LightSet),
        accel: &dyn Accel,
        seed: u64,
        (width, height): (u32, u32),
        spp: u32,
        visited: Visited,
    ) -> LightVertexPool {
        let index = PoolIndex::new(seed, spp, width as u64 * height as u64 * spp as u64);
        let empty = |rays| LightVertexPool {
            vertices: (0..index.size()).map(|_| None).collect(),
            index,
            surface_density: vec![0.0; lights.len()],
            visited: None,
            rays,
            kept: 0,
        };
        let Some(emitters) = lights.emitters(None) else { return empty(0) };
        let scramble = crate::sampler::mix64(seed ^ 0x6c76_706f_6f6c) as u32; // "lvpool"
        // Light path i (its numbers: a Sobol sequence per 2^16 paths) and where it lands, if
        // kept.
        let kept = |i: u32, scramble: u32| {
            let scramble = crate::sampler::mix64(scramble as u64 ^ (i >> 16) as u64) as u32;
            let (u, v) =
                (sobol_burley::sample_4d(i & 0xffff, 0, scramble), sobol_burley::sample_4d(i & 0xffff, 1, scramble));
            let e = emitters.sample(u[2], Vec2::new(v[0], v[1]), Vec2::new(u[0], u[1]))?;
            trace_surface((scene, normals, lights), accel, &emitters, &e).filter(|y| visited.contains(y.p, y.ng))
        };
        let pilot = (0..PILOT).into_par_iter().filter(|&i| kept(i, !scramble).is_some()).count() as u32;
        let size = index.size();
        let traced = size * PILOT.div_ceil(pilot.max(1)).min(MOST_PER_ENTRY);
        let kept: Vec<LightVertex> = (0..traced).into_par_iter().filter_map(|i| kept(i, scramble)).collect();
        let rays = (PILOT + traced) as u64;
        let m = kept.len() as u32;
        if m == 0 {
            return empty(rays);
        }
        // The first M' kept, M' a power of two: every one fills as many entries.
        let used = 1 << m.min(size).ilog2();
        let mis = traced as f32 / m as f32;
        let vertices = (0..size)
            .map(|k| {
                let mut y = kept[(k % used) as usize];
                y.scale /= mis;
                y.p_conn *= mis;
                Some(y)
            })
            .collect();
        let surface_density = (0..lights.len() as u32).map(|i| emitters.surface_density(i) * mis).collect();
        LightVertexPool { vertices, index, surface_density, visited: Some(visited), rays, kept: used }
    }

    /// Whether a vertex at `p` (geometric normal `n` on the side the path is) could be a
    /// light vertex of this pool: where a pool from surfaces keeps them.
    #[inline]
    pub(super) fn holds(&self, p: Vec3, n: Vec3) -> bool {
        self.visited.as_ref().is_none_or(|v| v.contains(p, n))
    }

    /// [`Emitters::surface_density`] of light `light` of the set where the pool's vertices
    /// come from surfaces (0 where they come from point lights).
    #[inline]
    pub(super) fn surface_density(&self, light: u32) -> f32 {
        self.surface_density.get(light as usize).copied().unwrap_or(0.0)
    }

    /// With vertices from surfaces: the density with which a connection from the vertex before
    /// `y` to a light vertex at `y` (geometric normal `ng`, on the side the path arrived by)
    /// builds a path whose light path starts at a point of light `light` seen at cosine `cos`
    /// from `y`, per the light point's cos / r² and per `p_xy`, the area density with which BSDF
    /// sampling at the vertex before found `y`: what MIS weighs next-event estimation and BSDF
    /// sampling at `y` against. 0 where the pool keeps no vertex.
    #[inline]
    pub(super) fn connection_per(&self, light: u32, y: Vec3, ng: Vec3, cos: f32, p_xy: f32) -> f32 {
        if self.holds(y, ng) { self.surface_density(light) * cos.max(0.0) / p_xy } else { 0.0 }
    }

    /// The pool's vertices come from lights that emit from surfaces.
    #[inline]
    pub(super) fn is_from_surfaces(&self) -> bool {
        !self.surface_density.is_empty()
    }

    /// The light vertices of sample `sample` of pixel `pixel`.
    #[inline]
    pub(super) fn for_sample(&self, pixel: u64, sample: u64) -> SampleLightVertices<'_> {
        let start = self.index.block_start(pixel, sample);
        let block = &self.vertices[start..start + (1 << self.index.block_bits)];
        SampleLightVertices { block, sample: sample as usize }
    }
}

/// The light vertices one sample's path connects to, one per path vertex: see
/// [`LightVertexPool`].
#[derive(Clone, Copy)]
pub(super) struct SampleLightVertices<'a> {
    /// The sample's block of B entries.
    block: &'a [Option<LightVertex>],
    sample: usize,
}

impl<'a> SampleLightVertices<'a> {
    /// The light vertex for the path vertex after `depth` bounces (`None` if its ray left the
    /// scene or landed on a mirror or glass): [`PoolIndex::entry`].
    #[inline]
    pub fn at(self, depth: u32) -> Option<&'a LightVertex> {
        // B is a power of two.
        self.block[(self.sample + depth as usize) & (self.block.len() - 1)].as_ref()
    }
}

/// Where a ray from a light lands, seen from the light's side.
struct Landing {
    p: Vec3,
    /// Geometric normal, on the side the ray came from.
    ng: Vec3,
    /// Shading frame, its normal on the side of `ng`.
    frame: Frame,
    bsdf: Bsdf,
}

/// Where `ray` lands (`None` if it leaves the scene or lands on a mirror or glass, where no
/// path could connect). Built with the general kernel's code (every switch on), whose results
/// are the specialised kernels' bit for bit.
fn land(scene: &Scene, normals: &FaceNormals, accel: &dyn Accel, ray: &Ray) -> Option<Landing> {
    let hit = accel.intersect_deferred(ray, 0.0, f32::INFINITY)?;
    let sp = surface_point::<true>(scene, normals, ray, &hit);
    let mut bsdf = sp.material.bsdf_at::<true>(&sp.tex);
    if bsdf.is_delta() {
        return None;
    }
    let (ng, ns) = if ray.d.dot(sp.ng) > 0.0 { (-sp.ng, -sp.ns) } else { (sp.ng, sp.ns) };
    let frame = Frame::from_normal(ns);
    if let Some(n) = sp.coat_normal(ng) {
        bsdf.set_coat_normal(frame.to_local(n));
    }
    Some(Landing { p: sp.p, ng, frame, bsdf })
}

/// The light vertex of a point light chosen by power with `u_choice` and a ray in the
/// direction `uniform_sphere(u)` from it: where the ray [`land`]s.
fn trace(
    (scene, normals, lights): (&Scene, &FaceNormals, &LightSet),
    accel: &dyn Accel,
    u_choice: f32,
    u: Vec2,
    rays: &mut u64,
) -> Option<LightVertex> {
    let e = lights.choose_point_by_power(u_choice)?;
    let ray = Ray::new(e.position, uniform_sphere(u));
    *rays += 1;
    let Landing { p, ng, frame, bsdf } = land(scene, normals, accel, &ray)?;
    let to_l = e.position - p;
    let r2 = to_l.length_squared();
    let to_light = to_l / r2.sqrt();
    let cos_g = to_light.dot(ng);
    if !(cos_g > 0.0 && r2 > 0.0) {
        return None;
    }
    Some(LightVertex {
        p,
        ng,
        frame,
        bsdf,
        to_light,
        scale: e.intensity * (4.0 * PI / (e.prob * cos_g)),
        p_conn: e.prob * cos_g / (4.0 * PI * r2),
        p_choice: lights.choice_probability_at(p, e.light),
        delta: true,
    })
}

/// The light vertex of `emission`, light leaving a surface of the set `lights` (as
/// `emitters` starts it): where its ray [`land`]s.
fn trace_surface(
    (scene, normals, lights): (&Scene, &FaceNormals, &LightSet),
    accel: &dyn Accel,
    emitters: &Emitters,
    emission: &Emission,
) -> Option<LightVertex> {
    let ray = Ray::new(offset_ray_origin(emission.p, emission.n), emission.d);
    let Landing { p, ng, frame, bsdf } = land(scene, normals, accel, &ray)?;
    let to_light = -emission.d;
    let cos_g = to_light.dot(ng);
    if !(cos_g > 0.0) {
        return None;
    }
    // Next-event estimation's density of the light point, as a path arriving on this side
    // chooses and samples it.
    let choice = lights.choice_facing(p, ng);
    let p_nee = lights.pdf_point(&choice, emission.light, p, emission.p, emission.n);
    Some(LightVertex {
        p,
        ng,
        frame,
        bsdf,
        to_light,
        scale: emission.weight / cos_g,
        p_conn: emitters.surface_density(emission.light) * cos_g,
        p_choice: p_nee,
        delta: false,
    })
}

/// A shadow query: `contribution` adds to a path's radiance if nothing lies on `ray` within
/// `0..=tmax` (in units of `ray.d`).
#[derive(Clone, Copy, Debug)]
pub(crate) struct ShadowQuery {
    pub ray: Ray,
    pub tmax: f32,
    pub contribution: Vec3,
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

/// The shadow query connecting the path through `x` to the light vertex `y`, with the
/// contribution of the path x → y → light if it is clear (throughput `beta` before x,
/// MIS-weighted against the same path found by BSDF sampling at x); `None` if y is on the
/// wrong side of either surface or the contribution is zero. `LAMBERT`: every BSDF is
/// Lambertian, and only cosines to the normal are computed (as the path does).
#[inline(always)]
pub(super) fn connection<const LAMBERT: bool>(x: &PathVertex, y: &LightVertex, beta: Vec3) -> Option<ShadowQuery> {
    let v = y.p - x.p;
    let d2 = v.length_squared();
    let dir = v / d2.sqrt();
    let cos_y = -dir.dot(y.ng);
    if !(d2 > 0.0 && cos_y > 0.0 && dir.dot(x.ng) > 0.0) {
        return None;
    }
    let local = |f: &Frame, v: Vec3| if LAMBERT { Vec3::new(0.0, 0.0, v.dot(f.n)) } else { f.to_local(v) };
    let eval = |b: &Bsdf, wo: Vec3, wi: Vec3| if LAMBERT { b.eval_lambert(wo, wi) } else { b.eval(wo, wi) };
    let wi_x = local(x.frame, dir);
    let f_x = eval(x.bsdf, x.wo_l, wi_x) * wi_x.z.abs();
    if f_x == Vec3::ZERO {
        return None;
    }
    let wi_y = local(&y.frame, y.to_light);
    let f_y = eval(&y.bsdf, local(&y.frame, -dir), wi_y) * wi_y.z.abs();
    if f_y == Vec3::ZERO {
        return None;
    }
    let w = if y.delta {
        let p_uni = y.p_choice * x.bsdf.pdf(x.wo_l, wi_x) * cos_y / d2;
        balance_heuristic(y.p_conn, p_uni)
    } else {
        // Against the same path found by BSDF sampling at x, then next-event estimation or
        // BSDF sampling at y (all three per the light point's cos / r²).
        let p_xy = x.bsdf.pdf(x.wo_l, wi_x) * cos_y / d2;
        let p_bsdf_y = y.bsdf.pdf(local(&y.frame, -dir), wi_y);
        power_heuristic(y.p_conn, p_xy * y.p_choice, p_xy * p_bsdf_y)
    };
    let c = beta * f_x * f_y * y.scale * (cos_y / d2 * w);
    if c == Vec3::ZERO || !c.is_finite() {
        return None;
    }
    let q = offset_toward(y.p, y.ng, -dir);
    Some(ShadowQuery { ray: Ray::new(x.leave, q - x.leave), tmax: 1.0, contribution: c })
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

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::HashSet;

    #[test]
    fn a_pixel_takes_distinct_entries_of_one_aligned_block_at_each_depth() {
        for (spp, block) in [(1, 1), (64, 64), (100, 128), (1 << 20, 1 << 16)] {
            let index = PoolIndex::new(7, spp, 512 * 512 * spp as u64);
            for pixel in [0, 1, 513, 262_143] {
                let start = index.entry(pixel, 0, 0);
                assert_eq!(start % block, 0, "spp {spp}: pixel {pixel} starts a block");
                for depth in [0, 1, 7] {
                    let n = (spp as usize).min(block);
                    let entries: HashSet<usize> = (0..n as u64).map(|s| index.entry(pixel, s, depth)).collect();
                    assert_eq!(entries.len(), n, "spp {spp}: a pixel's samples never share an entry");
                    assert!(entries.iter().all(|&e| (start..start + block).contains(&e)));
                }
            }
        }
        // Past B samples, the next blocks: 16 × 64 samples of a pixel take 1,024 entries.
        let index = PoolIndex::new(7, 64, 512 * 512 * 64);
        let entries: HashSet<usize> = (0..1024).map(|s| index.entry(9, s, 2)).collect();
        assert_eq!(entries.len(), 1024);
    }

    #[test]
    fn the_vertices_of_a_path_take_different_entries() {
        let index = PoolIndex::new(7, 64, 512 * 512 * 64);
        for (pixel, sample) in [(0, 0), (513, 5), (262_143, 63)] {
            let entries: HashSet<usize> = (0..8).map(|d| index.entry(pixel, sample, d)).collect();
            assert_eq!(entries.len(), 8);
        }
        // What the pool hands a path is that entry.
        let pool = LightVertexPool {
            vertices: (0..index.size()).map(|i| (!i.is_multiple_of(3)).then(|| vertex(i as f32))).collect(),
            index,
            surface_density: Vec::new(),
            visited: None,
            rays: 0,
            kept: 0,
        };
        for (pixel, sample, depth) in [(0, 0, 0), (513, 5, 3), (262_143, 63, 7), (9, 700, 2)] {
            let e = index.entry(pixel, sample, depth);
            let got = pool.for_sample(pixel, sample).at(depth).map(|y| y.p.x);
            assert_eq!(got, (!e.is_multiple_of(3)).then_some(e as f32), "pixel {pixel} sample {sample} depth {depth}");
        }
    }

    fn vertex(x: f32) -> LightVertex {
        LightVertex {
            p: Vec3::new(x, 0.0, 0.0),
            ng: Vec3::Z,
            frame: Frame::from_normal(Vec3::Z),
            bsdf: Bsdf::diffuse(Vec3::ONE),
            to_light: Vec3::Z,
            scale: Vec3::ONE,
            p_conn: 1.0,
            p_choice: 1.0,
            delta: true,
        }
    }

    #[test]
    fn a_small_render_has_a_small_pool() {
        // As many entries as samples, rounded up to a power of two, at least the block.
        let size = |spp, samples| PoolIndex::new(1, spp, samples).size();
        assert_eq!((size(1, 64), size(16, 16 * 16 * 16), size(64, 100)), (64, 4096, 128));
        assert_eq!((size(8, 1), size(64, 512 * 512 * 64)), (8, LightVertexPool::SIZE));
        // The most samples a pixel can be asked for.
        assert_eq!(size(u32::MAX, u32::MAX as u64), LightVertexPool::SIZE);
        // A pixel's samples stay distinct within the small pool.
        let index = PoolIndex::new(3, 16, 10 * 10 * 16);
        for pixel in 0..100 {
            let e: HashSet<usize> = (0..16).map(|s| index.entry(pixel, s, 3)).collect();
            assert!(e.len() == 16 && e.iter().all(|&i| i < index.size() as usize));
        }
    }

    #[test]
    fn pixels_and_seeds_spread_over_the_blocks() {
        let index = PoolIndex::new(7, 64, 512 * 512 * 64);
        let blocks: HashSet<usize> = (0..4096).map(|p| index.entry(p, 0, 0) / 64).collect();
        // 4096 pixels over 1024 blocks: about 1024 (1 - e^-4) = 1005 of them taken.
        assert!(blocks.len() > 950, "{} blocks", blocks.len());
        let other = PoolIndex::new(8, 64, 512 * 512 * 64);
        let moved = (0..4096).filter(|&p| other.entry(p, 0, 0) != index.entry(p, 0, 0)).count();
        assert!(moved > 4000, "another seed moves the pixels: {moved}");
    }
}

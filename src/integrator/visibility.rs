//! The pass that learns where next-event estimation's light samples get through
//! (`--light-visibility`; the weights are `crate::light::visibility`'s).
//!
//! Before the first pixel, a few paths from the camera (one per [`SAMPLES_PER_PATH`] samples
//! the render plans, [`FEWEST_CHUNKS`] to [`MOST_CHUNKS`] chunks of [`CHUNK`]) bounce by BSDF sampling; at
//! each vertex that is not a mirror or clear glass, one light sample is drawn as next-event
//! estimation draws it (by importance) and its shadow ray traced. The grid cell of the vertex
//! (1/[`CELLS_PER_RADIUS`] of the scene's bounding radius, by the side the surface faces) counts
//! the sample for its light's group, and whether it brought light: not blocked, not behind the
//! surface. Counts are integers summed over fixed chunks, each a Sobol sequence keyed by the
//! seed: every render of a scene and seed learns the same weights, whatever its thread count,
//! shard or resumption. The weights are kept only where at most half of the pass's light
//! samples brought light (a room lit through a window): in an open scene they change little
//! and their look-up at every shading point costs about 4% (measured on `teapot.toml`).
//!
//! The pass also records the cells its vertices landed in and, from its first chunk, the share
//! of bounces that left the scene: light vertices from area lights need the cells where that
//! share is low (`super::light_vertex::MOST_ESCAPED`). A pass run only for them (nothing to
//! weigh) stops after its first chunk where they are not needed.

use super::caustic::CHUNK;
use super::context::PathContext;
use super::surface::surface_point;
use crate::geometry::{Grid, Ray, Sphere, offset_ray_origin, offset_toward};
use crate::light::visibility::{CellKey, Counts, NO_COUNTS, Visibility, key};
use crate::material::BsdfModel;
use crate::sampler::{PixelSampler, mix64};
use glam::Vec3;
use rayon::prelude::*;
use rustc_hash::{FxHashMap, FxHashSet};

/// Samples the render plans per path of the pass.
const SAMPLES_PER_PATH: u64 = 64;

/// The fewest and the most chunks of paths the pass traces.
const FEWEST_CHUNKS: u64 = 4;
const MOST_CHUNKS: u64 = 16;

/// The most vertices of a path of the pass.
const DEPTH: u32 = 4;

/// Cells per radius of the scene's bounding sphere.
const CELLS_PER_RADIUS: f32 = 16.0;

/// Chunks of paths in the pass of a render of `spp` samples per pixel at `width` × `height`.
pub(super) fn chunks(width: u32, height: u32, spp: u32) -> u64 {
    (width as u64 * height as u64 * spp.max(1) as u64 / SAMPLES_PER_PATH)
        .clamp(FEWEST_CHUNKS * CHUNK, MOST_CHUNKS * CHUNK)
        / CHUNK
}

/// The cells (and sides) where the pass's paths had a vertex that is not a mirror or clear
/// glass: where paths from the camera go (light vertices from surfaces are kept only there).
#[derive(Clone, Debug)]
pub(crate) struct Visited {
    grid: Grid,
    cells: FxHashSet<CellKey>,
}

impl Visited {
    /// Whether a path's vertex at `p` on the side `n` faces lies in a visited cell.
    #[inline]
    pub fn contains(&self, p: Vec3, n: Vec3) -> bool {
        key(&self.grid, p, n).is_some_and(|k| self.cells.contains(&k))
    }
}

/// What the pass learned: the visibility weights of the lights' groups (`None` where more than
/// half of the pass's light samples brought light, or every group got through wherever it was
/// counted, or `weigh` is false), where its paths went, and how often they left the scene.
pub(super) struct Learned {
    pub weights: Option<Visibility>,
    pub visited: Visited,
    /// The share of the rays after a bounce that left the scene, in the pass's first chunk.
    pub escaped: f64,
}

/// Runs the pass over `ctx`'s scene, counting light samples by group where `weigh` (the lights
/// must then choose by importance); `None` for a scene of no size. Traces only its first chunk
/// unless it weighs or `needs_cells` the first chunk's share of bounces that left the scene;
/// [`Learned::visited`] then holds that chunk's cells. Adds the rays traced to `rays`.
pub(super) fn learn(
    ctx: &PathContext,
    weigh: bool,
    needs_cells: impl Fn(f64) -> bool,
    rays: &mut u64,
) -> Option<Learned> {
    let lights = ctx.lights;
    let bounds = ctx.scene.bounds();
    let radius = 0.5 * bounds.diagonal().length();
    if !(radius > 0.0 && radius.is_finite()) {
        return None;
    }
    let grid = Grid::over(&Sphere::new(bounds.center(), radius), CELLS_PER_RADIUS);
    let streams_key = mix64(ctx.settings.seed ^ 0x0076_6973_6962_6c65); // "visible"
    let trace_chunk = |chunk: u64| {
        let streams = PixelSampler::new(ctx.settings.sampler, streams_key, chunk);
        let (mut counts, mut rays, mut bounces) = (FxHashMap::<CellKey, Counts>::default(), 0, [0u64; 2]);
        for s in 0..CHUNK {
            let mut rng = streams.sample(s);
            let (film, lens) = (rng.next_2d(), rng.next_2d());
            let mut ray = ctx.camera.ray(film, lens);
            for depth in 0..DEPTH.min(ctx.path_depth.max(1)) {
                rays += 1;
                let hit = ctx.accel.intersect_deferred(&ray, 0.0, f32::INFINITY);
                if depth > 0 {
                    bounces[0] += 1;
                    bounces[1] += hit.is_none() as u64;
                }
                let Some(hit) = hit else { break };
                let sp = surface_point::<true>(ctx.scene, ctx.normals, &ray, &hit);
                let wo = -ray.d;
                let mut bsdf = sp.material.bsdf_at::<true>(&sp.tex);
                let transmissive = bsdf.is_transmissive();
                let (ng, frame) = sp.shading::<true>(wo, transmissive, &mut bsdf);
                let n = if transmissive { Vec3::ZERO } else { ng };
                let (uc, u) = (rng.next_f32(), rng.next_2d());
                let cell = if bsdf.is_delta() { None } else { key(&grid, sp.p, n) };
                // Every cell a vertex lands in is visited, whether or not it counts a sample.
                let cell = cell.map(|k| counts.entry(k).or_insert(NO_COUNTS));
                if weigh
                    && let Some(cell) = cell
                    && let Some(ls) = lights.sample(&lights.choice_at(sp.p).facing(n), sp.p, uc, u)
                {
                    let brings = ls.radiance != Vec3::ZERO && (transmissive || ls.wi.dot(ng) > 0.0) && {
                        let o = if transmissive { offset_toward(sp.p, ng, ls.wi) } else { offset_ray_origin(sp.p, ng) };
                        let (shadow, tmax) = ls.shadow_ray(o);
                        rays += 1;
                        !ctx.accel.occluded_deferred(&shadow, 0.0, tmax)
                    };
                    if let Some(c) = cell.get_mut(lights.group_of(ls.light)) {
                        c[0] += 1;
                        c[1] += brings as u32;
                    }
                }
                let (u, uc) = (rng.next_2d(), rng.next_f32());
                let Some(bs) = bsdf.sample(frame.to_local(wo), u, uc) else { break };
                let wi = frame.to_world(bs.wi);
                if !(bs.pdf > 0.0) || (!transmissive && wi.dot(ng) <= 0.0) {
                    break;
                }
                ray =
                    Ray::new(if transmissive { offset_toward(sp.p, ng, wi) } else { offset_ray_origin(sp.p, ng) }, wi);
            }
        }
        (counts, rays, bounces)
    };
    // The first chunk's share of bounces that left the scene decides light vertices; where
    // nothing is weighed and the cells are not needed, the rest of the pass is not traced.
    let all_chunks = chunks(ctx.settings.width, ctx.settings.height, ctx.settings.spp);
    let mut traced: Vec<_> = (0..if weigh { all_chunks } else { 1 }).into_par_iter().map(trace_chunk).collect();
    let escaped = traced[0].2[1] as f64 / traced[0].2[0].max(1) as f64;
    if !weigh && needs_cells(escaped) {
        let rest: Vec<_> = (1..all_chunks).into_par_iter().map(trace_chunk).collect();
        traced.extend(rest);
    }
    // Integer sums: the same whatever order the chunks are added in.
    let mut all: FxHashMap<CellKey, Counts> = FxHashMap::default();
    for (counts, r, _) in traced {
        *rays += r;
        for (k, c) in counts {
            let sum = all.entry(k).or_insert(NO_COUNTS);
            for (s, c) in sum.iter_mut().zip(c) {
                s[0] += c[0];
                s[1] += c[1];
            }
        }
    }
    let visited = Visited { grid, cells: all.keys().copied().collect() };
    // Where most light samples bring light (an open scene), weighing them gains little and
    // each shading point's look-up costs a few percent.
    let (traced, brought) = all.values().flatten().fold((0u64, 0u64), |(t, b), c| (t + c[0] as u64, b + c[1] as u64));
    let weights = if weigh && 2 * brought <= traced {
        Visibility::of(grid, all.into_iter().filter(|(_, c)| c.iter().any(|c| c[0] > 0)))
    } else {
        None
    };
    Some(Learned { weights, visited, escaped })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_pass_traces_one_path_per_64_samples_within_4_to_16_chunks() {
        assert_eq!(chunks(64, 48, 16), 4);
        assert_eq!(chunks(512, 256, 16), 8);
        assert_eq!(chunks(4096, 4096, 1024), MOST_CHUNKS);
    }
}

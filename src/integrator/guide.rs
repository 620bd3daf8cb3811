//! Caustic guiding: where light paths through mirrors and glass land on diffuse surfaces,
//! paths from the camera that reach those surfaces by another bounce sample their next
//! direction toward where that light came from, as well as by their BSDF.
//!
//! The caustic light paths (`super::caustic`) carry the light a camera sees on a diffuse
//! surface directly. Light the camera sees on a diffuse surface *through* glass or in a mirror
//! (camera → glass → floor → glass → lamp: the floor under a glass bunny seen through it) no
//! light path can carry, and a path from the camera finds it only when its BSDF sample at the
//! floor happens to go back through the glass to the lamp. Jensen's importance-driven path
//! tracing ("Importance driven path tracing using the photon map", 1995) makes that likely: a
//! small pass of light paths records where they land and from which direction; at a diffuse
//! vertex (after the camera's first bounce), the path draws its direction with probability
//! [`GUIDED`] from a narrow cone about the direction of one of the records near it, else from
//! its BSDF, and weighs it by the mixture's density, so the estimate stays unbiased.
//! Next-event estimation's weights use the same density.
//!
//! The records come from their own pass of light paths ([`chunks`]) (fixed chunks, each a Sobol
//! sequence of its own keyed by the seed), binned in a grid of cells: every render of a scene
//! and seed builds the same guide, whatever its thread count, shard or resumption.

use super::caustic::{self, CHUNK};
use super::context::PathContext;
use crate::geometry::Sphere;
use crate::light::{Emitters, sample_cone};
use crate::sampler::{PixelSampler, mix64};
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use rustc_hash::FxHashMap;
use std::collections::HashMap;

/// The most light paths of the guide's pass: 64 chunks.
const MOST_PATHS: u64 = 64 * CHUNK;

/// Samples the render plans per light path of the guide's pass (below [`MOST_PATHS`]).
const SAMPLES_PER_PATH: u64 = 16;

/// The share of a guided vertex's directions drawn toward the records.
pub(super) const GUIDED: f32 = 0.5;

/// 1 − cos of the half-angle of the cone about a record's direction: 1 − cos 15°.
const CONE: f32 = 0.034_074;

/// Cells per radius of the sphere around the specular surfaces.
const CELLS_PER_RADIUS: f32 = 16.0;

/// The most records a cell keeps (the first in the pass's order).
const MOST: usize = 64;

/// The fewest records a cell guides with.
const FEWEST: usize = 2;

/// Chunks of light paths in the guide's pass of a render of `spp` samples per pixel at
/// `width` × `height`: one path per [`SAMPLES_PER_PATH`] samples, at least one chunk, at most
/// [`MOST_PATHS`].
fn chunks(width: u32, height: u32, spp: u32) -> u64 {
    (width as u64 * height as u64 * spp.max(1) as u64 / SAMPLES_PER_PATH).clamp(CHUNK, MOST_PATHS) / CHUNK
}

/// Where caustic light lands and whence: directions toward the light, binned by where it
/// landed.
pub(crate) struct Guide {
    origin: Vec3,
    inv_cell: f32,
    cells: FxHashMap<[i32; 3], (u32, u32)>,
    dirs: Vec<Vec3>,
}

/// The records of one cell.
#[derive(Clone, Copy)]
pub(crate) struct Cell<'a>(&'a [Vec3]);

impl Guide {
    /// The guide of `ctx`'s scene: the landings of a pass of light paths from `emitters` toward
    /// `target` (the sphere around the specular surfaces); `None` if none landed. Adds the rays
    /// it traced to `rays`.
    pub(super) fn build(ctx: &PathContext, emitters: &Emitters, target: Sphere, rays: &mut u64) -> Option<Guide> {
        let key = mix64(ctx.settings.seed ^ 0x6775_6964_6573); // "guides"
        let chunks: Vec<(Vec<(Vec3, Vec3)>, u64)> =
            (0..chunks(ctx.settings.width, ctx.settings.height, ctx.settings.spp))
                .into_par_iter()
                .map(|chunk| {
                    let streams = PixelSampler::new(ctx.settings.sampler, key, chunk);
                    let (mut landed, mut rays) = (Vec::new(), 0);
                    for s in 0..CHUNK {
                        let mut rng = streams.sample(s);
                        caustic::trace(ctx, emitters, &mut rng, &mut rays, &mut |sp, _, to_light, beta, _, _| {
                            if beta.max_element() > 0.0 {
                                landed.push((sp.p, to_light));
                            }
                        });
                    }
                    (landed, rays)
                })
                .collect();
        *rays += chunks.iter().map(|c| c.1).sum::<u64>();
        Guide::of(chunks.into_iter().flat_map(|c| c.0), target)
    }

    /// The guide of the landings `landed` (where, and the unit direction toward the light), in
    /// cells of [`CELLS_PER_RADIUS`] per radius of `target`; `None` if no cell has
    /// [`FEWEST`] of them.
    fn of(landed: impl Iterator<Item = (Vec3, Vec3)>, target: Sphere) -> Option<Guide> {
        let (origin, inv_cell) = (target.center, CELLS_PER_RADIUS / target.radius);
        let mut binned: HashMap<[i32; 3], Vec<Vec3>> = HashMap::new();
        for (p, d) in landed {
            let Some(k) = cell_of(p, origin, inv_cell) else { continue };
            let v = binned.entry(k).or_default();
            if v.len() < MOST {
                v.push(d);
            }
        }
        // In the order of their keys: the same guide whatever the hash map's order.
        let mut keys: Vec<[i32; 3]> = binned.iter().filter(|(_, v)| v.len() >= FEWEST).map(|(k, _)| *k).collect();
        keys.sort_unstable();
        let (mut cells, mut dirs) = (FxHashMap::default(), Vec::new());
        for k in keys {
            let start = dirs.len() as u32;
            dirs.extend_from_slice(&binned[&k]);
            cells.insert(k, (start, dirs.len() as u32));
        }
        (!dirs.is_empty()).then_some(Guide { origin, inv_cell, cells, dirs })
    }

    /// The records of the cell around `p`, if it guides.
    #[inline]
    pub(crate) fn at(&self, p: Vec3) -> Option<Cell<'_>> {
        let &(a, b) = self.cells.get(&cell_of(p, self.origin, self.inv_cell)?)?;
        Some(Cell(&self.dirs[a as usize..b as usize]))
    }
}

/// The cell of `p` in the grid of cells 1 / `inv_cell` wide with a corner at `origin`; `None`
/// far outside it (where the cell number would not fit).
#[inline]
fn cell_of(p: Vec3, origin: Vec3, inv_cell: f32) -> Option<[i32; 3]> {
    let k = ((p - origin) * inv_cell).floor();
    (k.abs().max_element() < 1e9).then(|| k.as_ivec3().to_array())
}

impl Cell<'_> {
    /// The density of [`Cell::sample`] at the unit direction `wi` (solid angle).
    #[inline]
    pub(crate) fn pdf(&self, wi: Vec3) -> f32 {
        let inside = self.0.iter().filter(|d| d.dot(wi) >= 1.0 - CONE).count();
        inside as f32 / (self.0.len() as f32 * 2.0 * std::f32::consts::PI * CONE)
    }

    /// A direction in the cone about one of the records: `pick` in [0, 1) chooses which, `u`
    /// where in it.
    #[inline]
    pub(crate) fn sample(&self, pick: f32, u: Vec2) -> Vec3 {
        let i = ((pick * self.0.len() as f32) as usize).min(self.0.len() - 1);
        sample_cone(self.0[i], CONE, u)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::PI;

    /// Uniform directions on the sphere from a fixed sequence (R2 points).
    fn directions(n: usize) -> impl Iterator<Item = Vec3> {
        (0..n).map(|i| {
            let (a, b) = ((i as f64 * 0.754_877_666_246_693).fract(), (i as f64 * 0.569_840_290_998_053).fract());
            let z = 1.0 - 2.0 * a as f32;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = 2.0 * PI * b as f32;
            Vec3::new(r * phi.cos(), r * phi.sin(), z)
        })
    }

    #[test]
    fn a_cells_density_integrates_to_one_and_its_samples_lie_where_it_is_positive() {
        // Two cones that overlap (19° apart), a third apart.
        let overlapping = [Vec3::Y, Vec3::new(0.3, 0.9, 0.1).normalize(), Vec3::new(0.0, 0.2, -1.0).normalize()];
        let cell = Cell(&overlapping);
        // ∫ pdf over the sphere by 4M uniform directions: 1 within 1%.
        let n = 4_000_000;
        let integral: f64 = directions(n).map(|w| cell.pdf(w) as f64).sum::<f64>() * 4.0 * PI as f64 / n as f64;
        assert!((integral - 1.0).abs() < 0.01, "∫ pdf = {integral}");
        // Every sample has a density, at least one cone's share; each record is picked as often
        // (cones 37° and more apart).
        let records = [Vec3::Y, Vec3::new(0.6, 0.8, 0.0), Vec3::new(0.0, 0.2, -1.0).normalize()];
        let cell = Cell(&records);
        let mut picked = [0; 3];
        for (i, u) in directions(3000).enumerate() {
            let pick = (i as f32 + 0.5) / 3000.0;
            let w = cell.sample(pick, Vec2::new(0.5 * (u.x + 1.0), 0.5 * (u.y + 1.0)).min(Vec2::splat(0.999_999)));
            assert!((w.length() - 1.0).abs() < 1e-5);
            assert!(cell.pdf(w) >= 1.0 / (3.0 * 2.0 * PI * CONE) * 0.999, "sample {w} has density {}", cell.pdf(w));
            picked[records.iter().position(|r| r.dot(w) >= 1.0 - CONE).unwrap()] += 1;
        }
        assert_eq!(picked, [1000; 3]);
    }

    #[test]
    fn landings_are_binned_by_cell_and_sparse_cells_do_not_guide() {
        let target = Sphere::new(Vec3::ZERO, 1.6); // cells 0.1 wide
        let up = Vec3::Y;
        let landed = vec![
            (Vec3::new(0.01, 0.0, 0.01), up),
            (Vec3::new(0.09, 0.0, 0.05), Vec3::X),
            (Vec3::new(0.55, 0.0, 0.55), up), // alone in its cell
        ];
        let guide = Guide::of(landed.into_iter(), target).unwrap();
        let cell = guide.at(Vec3::new(0.05, 0.05, 0.05)).expect("the cell of two landings guides");
        assert_eq!(cell.0, &[up, Vec3::X]);
        assert!(guide.at(Vec3::new(0.55, 0.0, 0.55)).is_none(), "one landing is too few");
        assert!(guide.at(Vec3::new(-0.05, 0.0, 0.05)).is_none(), "a neighbouring cell has none");
        assert!(guide.at(Vec3::splat(f32::INFINITY)).is_none() && guide.at(Vec3::NAN).is_none());
        // No cell with enough landings: no guide.
        assert!(Guide::of([(Vec3::ZERO, up)].into_iter(), target).is_none());
        // A cell keeps its first MOST landings.
        let many = (0..MOST + 10).map(|i| (Vec3::splat(0.05), if i < MOST { up } else { Vec3::X }));
        assert!(Guide::of(many, target).unwrap().at(Vec3::splat(0.05)).unwrap().0.iter().all(|d| *d == up));
    }

    #[test]
    fn the_pass_traces_one_path_per_16_samples_within_1_to_64_chunks() {
        assert_eq!(chunks(64, 48, 16), 1);
        assert_eq!(chunks(512, 512, 16), 4_194_304 / 16 / CHUNK);
        assert_eq!(chunks(1920, 1080, 1024), 64);
        assert_eq!(chunks(1, 1, 0), 1);
    }
}

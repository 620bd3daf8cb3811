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
//! vertex (after the camera's first bounce), the path draws its direction from a narrow cone
//! about the direction of one of the records near it, else from its BSDF, and weighs it by the
//! mixture's density, so the estimate stays unbiased. Next-event estimation's weights use the
//! same density.
//!
//! How often a cell's vertices draw toward its records follows how much of the light there
//! the caustic is: [`GUIDED`] × the caustic's irradiance (the flux of the pass's paths that
//! landed in the cell, over a cell's face) / (that + the direct irradiance at a few of its
//! landings, by light samples with shadow rays). Under a glass object, in its shadow, the
//! caustic is most of the light; on a wall that a convex mirror throws a faint, spread
//! reflection of the lamp onto, little of it, and the BSDF keeps the samples the rest of the
//! light needs.
//!
//! The records come from their own pass of light paths ([`chunks`]) (fixed chunks, each a Sobol
//! sequence of its own keyed by the seed), binned in a grid of cells, and the direct light is
//! sampled cell by cell in the cells' order: every render of a scene and seed builds the same
//! guide, whatever its thread count, shard or resumption.

use super::caustic::{self, CHUNK};
use super::context::PathContext;
use crate::geometry::{Grid, Sphere, offset_ray_origin};
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

/// The most of a vertex's directions a cell draws toward its records.
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
    grid: Grid,
    /// A cell's records (a range of `dirs`) and its guided share.
    cells: FxHashMap<[i32; 3], (u32, u32, f32)>,
    dirs: Vec<Vec3>,
}

/// The records of one cell, and the share of a vertex's directions drawn toward them.
#[derive(Clone, Copy)]
pub(crate) struct Cell<'a>(&'a [Vec3], f32);

/// Where a light path of the guide's pass landed: the point, the surface's normal on the side
/// the light came from, the unit direction toward the light, and the path's flux (mean of its
/// channels).
#[derive(Clone, Copy)]
struct Landing {
    p: Vec3,
    n: Vec3,
    to_light: Vec3,
    flux: f32,
}

/// Landings of a cell whose direct irradiance is measured.
const PROBED: usize = 8;

/// The mean irradiance the lights give directly (shadow rays traced; the sky included) at the
/// first [`PROBED`] of `landings`, cell `cell` of the guide, by one light sample each; `rays`
/// counts the shadow rays.
fn direct_irradiance(ctx: &PathContext, key: u64, cell: usize, landings: &[Landing], rays: &mut u64) -> f32 {
    let streams = PixelSampler::new(ctx.settings.sampler, mix64(key ^ 0x6469_7265_6374), cell as u64); // "direct"
    let probed = &landings[..landings.len().min(PROBED)];
    let mut sum = 0.0;
    for (s, l) in probed.iter().enumerate() {
        let mut rng = streams.sample(s as u64);
        let (uc, u) = (rng.next_f32(), rng.next_2d());
        let choice = ctx.lights.choice_facing(l.p, l.n);
        let Some(ls) = ctx.lights.sample(&choice, l.p, uc, u) else { continue };
        let cos = ls.wi.dot(l.n);
        if !(cos > 0.0 && ls.pdf > 0.0) {
            continue;
        }
        let (ray, tmax) = ls.shadow_ray(offset_ray_origin(l.p, l.n));
        *rays += 1;
        if !ctx.accel.occluded_deferred(&ray, 0.0, tmax) {
            sum += (ls.radiance.element_sum() / 3.0 * cos / ls.pdf) as f64;
        }
    }
    (sum / probed.len().max(1) as f64) as f32
}

impl Guide {
    /// The guide of `ctx`'s scene: the landings of a pass of light paths from `emitters` toward
    /// `target` (the sphere around the specular surfaces); `None` if none landed. Adds the rays
    /// it traced to `rays`.
    pub(super) fn build(ctx: &PathContext, emitters: &Emitters, target: Sphere, rays: &mut u64) -> Option<Guide> {
        let key = mix64(ctx.settings.seed ^ 0x6775_6964_6573); // "guides"
        let chunks: Vec<(Vec<Landing>, u64)> = (0..chunks(ctx.settings.width, ctx.settings.height, ctx.settings.spp))
            .into_par_iter()
            .map(|chunk| {
                let streams = PixelSampler::new(ctx.settings.sampler, key, chunk);
                let (mut landed, mut rays) = (Vec::new(), 0);
                for s in 0..CHUNK {
                    let mut rng = streams.sample(s);
                    caustic::trace(ctx, emitters, &mut rng, &mut rays, &mut |sp, _, to_light, beta, _, _| {
                        let flux = beta.element_sum() / 3.0;
                        if flux > 0.0 && flux.is_finite() {
                            let n = if sp.ng.dot(to_light) < 0.0 { -sp.ng } else { sp.ng };
                            landed.push(Landing { p: sp.p, n, to_light, flux });
                        }
                    });
                }
                (landed, rays)
            })
            .collect();
        *rays += chunks.iter().map(|c| c.1).sum::<u64>();
        let paths = chunks.len() as u64 * CHUNK;
        let direct = |i: usize, at: &[Landing]| direct_irradiance(ctx, key, i, at, rays);
        Guide::of(chunks.into_iter().flat_map(|c| c.0), target, paths, direct)
    }

    /// The guide of the landings `landed` of `paths` light paths, in cells of
    /// [`CELLS_PER_RADIUS`] per radius of `target`; `direct(i, landings)` is the mean direct
    /// irradiance at a cell's first landings (cell `i` in the guide's order). A cell's guided
    /// share is [`GUIDED`] × its caustic irradiance / (that + the direct irradiance there): where
    /// the caustic is a small part of the light, its samples go to the rest. `None` if no cell
    /// has [`FEWEST`] landings.
    fn of(
        landed: impl Iterator<Item = Landing>,
        target: Sphere,
        paths: u64,
        mut direct: impl FnMut(usize, &[Landing]) -> f32,
    ) -> Option<Guide> {
        let grid = Grid::over(&target, CELLS_PER_RADIUS);
        // Each cell's first MOST landings, and the flux of all that landed in it.
        let mut binned: HashMap<[i32; 3], (Vec<Landing>, f64)> = HashMap::new();
        for l in landed {
            let Some(k) = grid.cell(l.p) else { continue };
            let (v, flux) = binned.entry(k).or_default();
            *flux += l.flux as f64;
            if v.len() < MOST {
                v.push(l);
            }
        }
        // In the order of their keys: the same guide whatever the hash map's order.
        let mut keys: Vec<[i32; 3]> = binned.iter().filter(|(_, v)| v.0.len() >= FEWEST).map(|(k, _)| *k).collect();
        keys.sort_unstable();
        // The caustic's irradiance in a cell: the flux that landed there over the area of a
        // surface across it (a cell's face).
        let area = (grid.cell_width() as f64).powi(2) * paths.max(1) as f64;
        let (mut cells, mut dirs) = (FxHashMap::default(), Vec::new());
        for (i, k) in keys.into_iter().enumerate() {
            let (landings, flux) = &binned[&k];
            let caustic = (flux / area) as f32;
            let share = GUIDED * caustic / (caustic + direct(i, landings).max(0.0));
            if !(share > 0.0) {
                continue;
            }
            let start = dirs.len() as u32;
            dirs.extend(landings.iter().map(|l| l.to_light));
            cells.insert(k, (start, dirs.len() as u32, share));
        }
        (!dirs.is_empty()).then_some(Guide { grid, cells, dirs })
    }

    /// The records of the cell around `p`, if it guides.
    #[inline]
    pub(crate) fn at(&self, p: Vec3) -> Option<Cell<'_>> {
        let &(a, b, share) = self.cells.get(&self.grid.cell(p)?)?;
        Some(Cell(&self.dirs[a as usize..b as usize], share))
    }
}

impl Cell<'_> {
    /// The share of a vertex's directions drawn toward the records (at most [`GUIDED`]).
    #[inline]
    pub(crate) fn share(&self) -> f32 {
        self.1
    }

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
        let cell = Cell(&overlapping, GUIDED);
        // ∫ pdf over the sphere by 4M uniform directions: 1 within 1%.
        let n = 4_000_000;
        let integral: f64 = directions(n).map(|w| cell.pdf(w) as f64).sum::<f64>() * 4.0 * PI as f64 / n as f64;
        assert!((integral - 1.0).abs() < 0.01, "∫ pdf = {integral}");
        // Every sample has a density, at least one cone's share; each record is picked as often
        // (cones 37° and more apart).
        let records = [Vec3::Y, Vec3::new(0.6, 0.8, 0.0), Vec3::new(0.0, 0.2, -1.0).normalize()];
        let cell = Cell(&records, GUIDED);
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

    /// A landing at `p` from `to_light` carrying flux 1, on a floor.
    fn at(p: Vec3, to_light: Vec3) -> Landing {
        Landing { p, n: Vec3::Y, to_light, flux: 1.0 }
    }

    #[test]
    fn landings_are_binned_by_cell_and_sparse_cells_do_not_guide() {
        let target = Sphere::new(Vec3::ZERO, 1.6); // cells 0.1 wide
        let up = Vec3::Y;
        let landed = vec![
            at(Vec3::new(0.01, 0.0, 0.01), up),
            at(Vec3::new(0.09, 0.0, 0.05), Vec3::X),
            at(Vec3::new(0.55, 0.0, 0.55), up), // alone in its cell
        ];
        let unlit = |_: usize, _: &[Landing]| 0.0;
        let guide = Guide::of(landed.into_iter(), target, 1, unlit).unwrap();
        let cell = guide.at(Vec3::new(0.05, 0.05, 0.05)).expect("the cell of two landings guides");
        assert_eq!(cell.0, &[up, Vec3::X]);
        assert!(guide.at(Vec3::new(0.55, 0.0, 0.55)).is_none(), "one landing is too few");
        assert!(guide.at(Vec3::new(-0.05, 0.0, 0.05)).is_none(), "a neighbouring cell has none");
        assert!(guide.at(Vec3::splat(f32::INFINITY)).is_none() && guide.at(Vec3::NAN).is_none());
        // No cell with enough landings: no guide.
        assert!(Guide::of([at(Vec3::ZERO, up)].into_iter(), target, 1, unlit).is_none());
        // A cell keeps its first MOST landings.
        let many = (0..MOST + 10).map(|i| at(Vec3::splat(0.05), if i < MOST { up } else { Vec3::X }));
        assert!(Guide::of(many, target, 1, unlit).unwrap().at(Vec3::splat(0.05)).unwrap().0.iter().all(|d| *d == up));
    }

    #[test]
    fn a_cell_guides_by_the_share_of_its_light_the_caustic_gives() {
        let target = Sphere::new(Vec3::ZERO, 1.6); // cells 0.1 wide: 0.01 of area
        // 4 landings of flux 1 of 100 paths: caustic irradiance 4 / (100 · 0.01) = 4.
        let landed = || (0..4).map(|_| at(Vec3::splat(0.05), Vec3::Y));
        let share = |direct: f32| {
            let guide = Guide::of(landed(), target, 100, |_, l: &[Landing]| {
                assert_eq!(l.len(), 4);
                direct
            });
            guide.and_then(|g| g.at(Vec3::splat(0.05)).map(|c| c.share()))
        };
        assert_eq!(share(0.0), Some(GUIDED), "in the dark the caustic is all the light");
        assert!((share(4.0).unwrap() - GUIDED / 2.0).abs() < 1e-6);
        assert!((share(36.0).unwrap() - GUIDED / 10.0).abs() < 1e-6);
        // Where the direct light cannot be measured (not finite), the cell does not guide.
        assert_eq!(share(f32::INFINITY), None);
    }

    #[test]
    fn the_pass_traces_one_path_per_16_samples_within_1_to_64_chunks() {
        assert_eq!(chunks(64, 48, 16), 1);
        assert_eq!(chunks(512, 512, 16), 4_194_304 / 16 / CHUNK);
        assert_eq!(chunks(1920, 1080, 1024), 64);
        assert_eq!(chunks(1, 1, 0), 1);
    }
}

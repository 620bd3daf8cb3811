//! The wavefront loop (`--path-loop wavefront`): a batch of paths advanced stage by stage
//! (Laine, Karras and Aila, "Megakernels considered harmful", 2013), instead of one path at a
//! time from its camera ray to its end.
//!
//! A batch is many groups of [`LANES`] samples (a tile's pixels, in order). Each round of the
//! loop runs one stage over every live path of the batch before the next stage starts:
//!
//! 1. camera: each group's camera rays, traced as one packet (as the scalar kernel does);
//! 2. shade: every path's vertex at its ray's closest hit ([`shade`]): emission found, the
//!    light sample, the light-vertex connection and the BSDF sample, each path drawing from
//!    its own sample stream; Lambertian vertices [`LANES`] at a time where the render allows
//!    ([`super::lanes`]);
//! 3. shadow: the shadow rays the shade stage queued (next-event estimation's and the
//!    connections');
//! 4. extend: paths that ended hand in their radiance and leave the batch (compacted, so the
//!    next stages run over live paths only); the others' continuation rays are traced.
//!
//! The shadow and extend stages trace a group's rays (a pixel's paths, which start near one
//! another) 8 at a time as one packet, without Embree's coherence hint: on the scenes measured
//! that costs less than one query per ray, and the hint costs more (docs/performance.md, "Path
//! loops").
//!
//! Shading, the queue of queries and tracing are apart, which is what lets a stage run over
//! many paths at once (in SIMD lanes, or with rays traced together). Every path computes
//! exactly what the scalar loop computes for it, the same arithmetic in the same order on the
//! same numbers: the image is the scalar kernel's bit for bit (tested), so everything the
//! scalar kernel guarantees (thread counts, tiles, resume, shards, `--no-specialize`) holds
//! here too. Its cost against the scalar loop: docs/performance.md, "Path loops".

use super::aux::{AuxSample, aux_sample};
use super::context::PathContext;
use super::kernel::{KernelFamily, camera_stage};
use super::path::{PathRules, PathState, ShadowQuery, ShadowRays, shade};
use crate::accel::{Accel, AccelError, LANES};
use crate::geometry::Hit;
use crate::geometry::{Ray, RayPacket};
use crate::sampler::{PixelSampler, SampleStream};
use glam::Vec3;
use std::ops::Range;

/// One group of samples of a batch: samples `samples` (at most [`LANES`], within one group of
/// `LANES` aligned on sample 0, as the scalar kernel takes them) of pixel (x, y), whose
/// streams are `streams`.
pub(crate) struct GroupJob<'s> {
    pub streams: &'s PixelSampler,
    pub pixel: (u32, u32),
    pub samples: Range<u32>,
}

/// Renders the groups `jobs`: the value of sample `jobs[g].samples.start + i` to
/// `out[g][i]`, its auxiliary sample to `aux[g][i]` if given; `rays[g]` counts the rays
/// traced for group g (added to).
pub(crate) type BatchFn = fn(
    &PathContext,
    &[GroupJob],
    &mut [[Vec3; LANES]],
    Option<&mut [[AuxSample; LANES]]>,
    &mut [u64],
) -> Result<(), AccelError>;

/// The wavefront kernels ([`BatchFn`]), one per combination of the kernel switches.
pub(crate) struct WavefrontLoop;

impl KernelFamily for WavefrontLoop {
    type Fn = BatchFn;
    fn instance<const LENS: bool, const TEX: bool, const GLOSSY: bool, const GLASS: bool, const HIT_LIGHTS: bool>()
    -> BatchFn {
        batch::<LENS, TEX, GLOSSY, GLASS, HIT_LIGHTS>
    }
}

fn batch<const LENS: bool, const TEX: bool, const GLOSSY: bool, const GLASS: bool, const HIT_LIGHTS: bool>(
    ctx: &PathContext,
    jobs: &[GroupJob],
    out: &mut [[Vec3; LANES]],
    aux: Option<&mut [[AuxSample; LANES]]>,
    rays: &mut [u64],
) -> Result<(), AccelError> {
    match ctx.accel.as_embree() {
        Some(embree) => run::<_, LENS, TEX, GLOSSY, GLASS, HIT_LIGHTS>(ctx, embree, jobs, out, aux, rays),
        None => run::<_, LENS, TEX, GLOSSY, GLASS, HIT_LIGHTS>(ctx, ctx.accel, jobs, out, aux, rays),
    }
}

/// A live path of the batch: its state, the closest hit of its ray, its numbers, its light
/// vertices, whether it goes on after its vertex, and where its value goes (group, lane).
pub(super) struct Lane<'s, 'c> {
    pub path: PathState,
    pub hit: Option<Hit>,
    pub rng: SampleStream<'s>,
    light_vertices: Option<super::light_vertex::SampleLightVertices<'c>>,
    pub goes_on: bool,
    slot: (u32, u8),
}

/// A shadow ray of a shade stage, with the lane whose radiance its contribution adds to and
/// that lane's group.
struct Queued {
    lane: u32,
    group: u32,
    query: ShadowQuery,
}

/// The shadow rays of a shade stage, in the order the stage made them (a path's add in the
/// order it made them, as the scalar loop's do).
pub(super) struct ShadowQueue {
    queries: Vec<Queued>,
    lane: u32,
    group: u32,
}

impl ShadowQueue {
    /// Queues `ray` for the lane `index` of the batch (`lane`).
    #[inline(always)]
    pub(super) fn push(&mut self, index: usize, lane: &Lane, ray: Ray, tmax: f32, contribution: Vec3) {
        self.queue(index as u32, lane.slot.0, ShadowQuery { ray, tmax, contribution });
    }

    #[inline(always)]
    fn queue(&mut self, lane: u32, group: u32, query: ShadowQuery) {
        self.queries.push(Queued { lane, group, query });
    }
}

impl ShadowRays for ShadowQueue {
    #[inline(always)]
    fn trace(&mut self, _l: &mut Vec3, ray: Ray, tmax: f32, contribution: Vec3) {
        self.queue(self.lane, self.group, ShadowQuery { ray, tmax, contribution });
    }
}

/// The end of the packet that starts at item `start` of `len`: the items from `start` on that
/// are in its group (`group(i)` is item i's), at most [`LANES`] of them.
#[inline(always)]
fn packet_end(start: usize, len: usize, group: impl Fn(usize) -> u32) -> usize {
    let g = group(start);
    let mut end = start + 1;
    while end < len && end - start < LANES && group(end) == g {
        end += 1;
    }
    end
}

#[inline(always)]
fn run<
    A: Accel + ?Sized,
    const LENS: bool,
    const TEX: bool,
    const GLOSSY: bool,
    const GLASS: bool,
    const HIT_LIGHTS: bool,
>(
    ctx: &PathContext,
    accel: &A,
    jobs: &[GroupJob],
    out: &mut [[Vec3; LANES]],
    mut aux: Option<&mut [[AuxSample; LANES]]>,
    rays: &mut [u64],
) -> Result<(), AccelError> {
    let rules = PathRules::new::<HIT_LIGHTS>(ctx);
    // Lambertian vertices are shaded a group of paths at a time ([`super::lanes`]).
    let lane_stage = super::lanes::applies::<GLOSSY, GLASS>(ctx);
    let width = ctx.settings.width as u64;
    // Camera stage.
    let mut lanes: Vec<Lane> = Vec::with_capacity(jobs.len() * LANES);
    for (g, job) in jobs.iter().enumerate() {
        let n = job.samples.len();
        let (camera_rays, rngs) = camera_stage::<LENS>(ctx, job.streams, job.pixel, job.samples.clone());
        let active = std::array::from_fn(|i| i < n);
        let hits = accel.intersect_packet_deferred(&camera_rays, active, 0.0, f32::INFINITY);
        let pixel = job.pixel.1 as u64 * width + job.pixel.0 as u64;
        let first_sample = job.samples.start as u64;
        for (i, rng) in rngs.into_iter().enumerate().take(n) {
            rays[g] += 1;
            lanes.push(Lane {
                path: PathState::new(camera_rays.ray(i)),
                hit: hits[i],
                rng,
                light_vertices: ctx.light_vertices.map(|p| p.for_sample(pixel, first_sample + i as u64)),
                goes_on: false,
                slot: (g as u32, i as u8),
            });
        }
        // Beside the paths, from the same camera rays and first hits (see `super::aux`).
        if let Some(aux) = aux.as_deref_mut() {
            for i in 0..n {
                let ray = camera_rays.ray(i);
                let sample = first_sample + i as u64;
                aux[g][i] = aux_sample::<A, TEX, GLOSSY, GLASS>(ctx, accel, ray, hits[i], pixel, sample, &mut rays[g]);
            }
        }
    }
    let mut shadow = ShadowQueue { queries: Vec::with_capacity(2 * lanes.len()), lane: 0, group: 0 };
    while !lanes.is_empty() {
        // Shade stage.
        shadow.queries.clear();
        if lane_stage {
            for (c, paths) in lanes.chunks_mut(LANES).enumerate() {
                super::lanes::shade_diffuse::<TEX, HIT_LIGHTS>(ctx, &rules, paths, c * LANES, &mut shadow);
            }
        } else {
            for (i, lane) in lanes.iter_mut().enumerate() {
                shadow.lane = i as u32;
                shadow.group = lane.slot.0;
                lane.goes_on = shade::<_, TEX, GLOSSY, GLASS, HIT_LIGHTS>(
                    ctx,
                    &rules,
                    &mut lane.path,
                    lane.hit,
                    lane.light_vertices,
                    &mut lane.rng,
                    &mut shadow,
                )
                .is_some();
            }
        }
        // Shadow stage.
        let queries = &shadow.queries;
        let mut start = 0;
        while start < queries.len() {
            let end = packet_end(start, queries.len(), |i| queries[i].group);
            let packet = &queries[start..end];
            let mut rays_of = RayPacket::splat(&packet[0].query.ray);
            let mut tmax = [0.0; LANES];
            for (i, q) in packet.iter().enumerate() {
                rays_of.set(i, &q.query.ray);
                tmax[i] = q.query.tmax;
            }
            let blocked =
                accel.occluded_packet_deferred(&rays_of, std::array::from_fn(|i| i < packet.len()), 0.0, tmax);
            rays[packet[0].group as usize] += packet.len() as u64;
            for (q, blocked) in packet.iter().zip(blocked) {
                if !blocked {
                    lanes[q.lane as usize].path.l += q.query.contribution;
                }
            }
            start = end;
        }
        // Extend stage: finished paths leave, the others' rays are traced.
        lanes.retain(|lane| {
            if !lane.goes_on {
                out[lane.slot.0 as usize][lane.slot.1 as usize] = lane.path.l;
            }
            lane.goes_on
        });
        let mut start = 0;
        while start < lanes.len() {
            let end = packet_end(start, lanes.len(), |i| lanes[i].slot.0);
            let packet = &mut lanes[start..end];
            let mut rays_of = RayPacket::splat(&packet[0].path.ray());
            for (i, lane) in packet.iter().enumerate().skip(1) {
                rays_of.set(i, &lane.path.ray());
            }
            let hits = accel.intersect_packet_deferred(
                &rays_of,
                std::array::from_fn(|i| i < packet.len()),
                0.0,
                f32::INFINITY,
            );
            rays[packet[0].slot.0 as usize] += packet.len() as u64;
            for (lane, hit) in packet.iter_mut().zip(hits) {
                lane.hit = hit;
            }
            start = end;
        }
    }
    // Queries report errors (a panicked user-geometry callback) once per batch.
    accel.deferred_error()
}

//! The render loop: rounds of samples over 16×16 tiles in parallel, accumulated per pixel.
//!
//! Tiles are taken in a fixed shuffled order ([`tile_order`]), not row by row: the tiles done
//! at any moment are then a fair sample of the image, so the share of samples done follows the
//! share of time spent (row by row, the cheap tiles of a sky come first and a progress bar
//! runs ahead of the work). The order changes no pixel: a pixel's samples depend only on it.
//!
//! The plan says how many rounds ([`RenderPlan::rounds`]) and each pixel's target in each
//! ([`RenderPlan::round_target`]). A uniform render has one round: every pixel goes to `spp`. An
//! adaptive one ([`super::adaptive`]) has two: the first round everywhere, then the plan made from
//! the whole image's first round (a shard takes them in two stages:
//! [`RenderControl::first_round_only`], then [`RenderControl::first_rounds`]). With a target error,
//! rounds double the sample count (16, 32, 64, … up to `spp`) of the pixels whose estimated error
//! is still above the target. A pixel's samples are always taken in index order and its decision
//! depends only on its own samples, so the image is the same whatever the thread count, and whether
//! or not the render was interrupted and resumed: a stop request is honoured between groups of
//! [`LANES`] samples (inside a pixel too, whose samples may take minutes), where the pixel's state
//! — its sums, in sample order — is saved exactly, and a pixel stopped inside a round goes on with
//! it when resumed (see [`RenderPlan::round_target`]).
//!
//! [`run`] is a sequence of named steps: where the film starts ([`Earlier`]: a resumed
//! checkpoint, stage 1 of a shard, or empty), the path context and light vertices, then the
//! rounds. Each round is a parallel loop over tiles ([`Session::render_tile`]): the task takes
//! its tile's pixels out of the shared film ([`TileFilm::take`]), renders them
//! ([`render_tile`]) and puts them back ([`TileFilm::put_back`]), then writes a due checkpoint
//! or preview and reports progress, counted in work ([`WorkMeter`]). The film is locked twice
//! per tile, not per pixel.

use super::adaptive;
use super::aux::AuxSample;
use super::caustic;
use super::context::PathContext;
use super::kernel::SampleFn;
use super::light_vertex::{self, LightVertexPool};
use super::surface::FaceNormals;
use super::wavefront::{BatchFn, GroupJob};
use super::{RenderError, RenderPlan, RenderSettings, RenderStats, SurfaceLightVertices};
use crate::accel::{Accel, LANES};
use crate::film::{Accumulator, AuxSums, Checkpoint, CheckpointKey, LightSums, PixelState};
use crate::light::Emitters;
use crate::sampler::{PixelSampler, mix64};
use crate::scene::Scene;
use crate::settings::{LightVertices, PathLoop, TILE, clamp_sample};
use glam::DVec3;
use rayon::prelude::*;
use std::ops::Range;
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Mutex, OnceLock};
use std::time::{Duration, Instant};

/// Control over a long render.
#[derive(Default)]
pub struct RenderControl<'a> {
    /// When set, the render finishes the pixels in flight and returns early.
    pub stop: Option<&'a AtomicBool>,
    /// Write a checkpoint here when stopped early, and also every `Duration` while rendering.
    pub checkpoint: Option<(&'a Path, Option<Duration>)>,
    /// Continue from this checkpoint (checked against the scene and settings).
    pub resume: Option<(&'a Path, Checkpoint)>,
    /// Called from the worker threads as tiles finish (see [`Progress`]).
    pub progress: Option<&'a (dyn Fn(Progress) + Sync)>,
    /// Every `Duration`, hand the image as it stands (each pixel's mean so far; black where no
    /// sample has landed yet) to this function, from a worker thread with no lock held; an
    /// `Err` is a preview that could not be shown (reported once at the end, with the count).
    pub preview: Option<(Duration, &'a PreviewFn<'a>)>,
    /// Stage 1 of a two-stage shard: render only what needs no other shard (an adaptive
    /// render's first round; all of a uniform render).
    pub first_round_only: bool,
    /// Stage 2 of a two-stage shard: start from the whole image's first round (every shard's
    /// stage 1, put together), planned as a whole render plans it; unless resumed.
    pub first_rounds: Option<FirstRounds>,
}

/// What [`RenderControl::preview`] calls with the image so far.
pub type PreviewFn<'a> = dyn Fn(&crate::film::Film) -> Result<(), String> + Sync + 'a;

/// The whole image's first round, for stage 2 of a two-stage shard ([`RenderControl`]).
pub struct FirstRounds {
    /// Every pixel's first-round state, with the plan's data in an adaptive render.
    pub accum: Accumulator,
    /// The time this shard's first round took, and the non-finite samples it dropped.
    pub elapsed: Duration,
    pub nonfinite: u64,
}

/// How far a render has got, reported to [`RenderControl::progress`] each time a tile
/// finishes a round.
///
/// Work is counted in samples, each weighed by what it costs: 1 for a sample of a uniform
/// render or of an adaptive render's first round; in the second round, the pixel's cost
/// ([`adaptive::sample_costs`]: its first-round rays per sample over the image's mean), since
/// the plan sends samples to pixels that cost more (or less) than the mean. Until the plan is
/// made, an adaptive render's work is planned as its budget, `spp` samples in every pixel; so
/// the share of the work done follows the time spent through both rounds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Progress {
    /// Work done so far, earlier sessions of a resumed render included.
    pub work_done: f64,
    /// Of that, the work of earlier sessions (read from the checkpoint resumed):
    /// `work_done - work_before` was done in `elapsed`.
    pub work_before: f64,
    /// The work of the whole render, as planned now. With a target error, only to the end of
    /// the current round: later rounds may add more (only pixels still above the target take
    /// part in them).
    pub work_planned: f64,
    /// Rays traced in this session.
    pub rays: u64,
    /// Time spent in this session.
    pub elapsed: Duration,
    /// The current round (from 1) and the most rounds there can be; 0 while the caustics'
    /// light paths are traced.
    pub round: u32,
    pub rounds: u32,
    /// While the caustics' light paths are traced, before the first pixel: (paths traced,
    /// paths planned). No pixel work is done then, and none is planned yet (0). `None` after.
    pub light_paths: Option<(u64, u64)>,
}

/// The outcome of [`super::render_controlled`].
pub struct RenderResult {
    pub accum: Accumulator,
    pub stats: RenderStats,
    /// False when the render was stopped before every pixel was done.
    pub complete: bool,
    /// Problems that did not stop the render, for the user to see: periodic checkpoints that
    /// could not be written (one line for all of them, with the count).
    pub warnings: Vec<String>,
}

/// Something a render writes periodically (checkpoints, previews): when the last was
/// written, and the failures.
struct Periodic {
    /// What is written, plural: `periodic checkpoints`.
    what: &'static str,
    last: Instant,
    attempts: u32,
    failures: u32,
    first_failure: Option<String>,
}

impl Periodic {
    fn new(what: &'static str) -> Mutex<Periodic> {
        Mutex::new(Periodic { what, last: Instant::now(), attempts: 0, failures: 0, first_failure: None })
    }

    /// Runs `write` now; a failure is counted, not returned.
    fn attempt<E: std::fmt::Display>(&mut self, write: impl FnOnce() -> Result<(), E>) {
        self.attempts += 1;
        if let Err(e) = write() {
            self.failures += 1;
            self.first_failure.get_or_insert_with(|| e.to_string());
        }
        self.last = Instant::now();
    }

    fn warning(&self) -> Option<String> {
        let first = self.first_failure.as_ref()?;
        Some(format!(
            "{} of {} {} could not be written; the render went on without them (first failure: {first})",
            self.failures, self.attempts, self.what
        ))
    }
}

/// The tiles of a `w`×`h` image, as (column, row) of 16×16 tiles, in the order they are
/// rendered: shuffled by a fixed hash, the same for every render of that size.
pub fn tile_order(w: u32, h: u32) -> Vec<(u32, u32)> {
    let mut tiles: Vec<(u32, u32)> =
        (0..h.div_ceil(TILE)).flat_map(|ty| (0..w.div_ceil(TILE)).map(move |tx| (tx, ty))).collect();
    tiles.sort_by_key(|&(tx, ty)| mix64(((ty as u64) << 32 | tx as u64) ^ 0x7469_6c65_6f72_6465));
    tiles
}

/// Renders `scene` through `accel` as `plan` says, under `control` (see the module's text).
pub(super) fn run(
    scene: &Scene,
    accel: &dyn Accel,
    plan: &RenderPlan,
    mut control: RenderControl,
) -> Result<RenderResult, RenderError> {
    let start = Instant::now();
    let settings = &plan.settings;
    // A resumed stage is still told which it is: resuming stage 1 as a whole shard would plan
    // from this shard's pixels alone.
    let staged = control.first_round_only || control.first_rounds.is_some();
    if settings.adaptive && settings.shard.is_some() && !staged {
        return Err(RenderError::AdaptiveShard);
    }
    let key = LazyKey { scene, accel, plan, key: OnceLock::new() };
    let mut earlier = Earlier::of(plan, control.resume.take(), control.first_rounds.take(), &key)?;
    let owned = Owned::of(settings);
    if plan.traces_nothing() && !settings.aux {
        return Ok(earlier.traced_nothing(plan, owned, start));
    }
    let camera = scene.camera(settings.width as f32 / settings.height as f32);
    let normals = FaceNormals::of(scene);
    let lights = scene.light_set(settings.light_tree);
    let taking = !earlier.all_taken(settings.spp, owned);
    let (learned, visibility_rays) =
        learn(&PathContext::new(scene, accel, &lights, &normals, &camera, plan), plan, taking);
    let (weights, visited) = match learned {
        Some(l) => (l.weights, Some((l.visited, l.escaped))),
        None => (None, None),
    };
    let lights = match weights {
        Some(v) => lights.with_visibility(v),
        None => lights,
    };
    accel.deferred_error()?;
    let mut ctx = PathContext::new(scene, accel, &lights, &normals, &camera, plan);
    let pool = light_vertex_pool(&ctx, plan, visited.as_ref());
    let surface_light_vertices = visited
        .as_ref()
        .filter(|_| plan.light_vertices_from_surfaces())
        .map(|(_, escaped)| SurfaceLightVertices { escaped: *escaped, pool: pool.as_ref().map(|p| (p.kept, p.rays)) });
    accel.deferred_error()?;
    ctx.light_vertices = pool.as_ref();
    let target = if plan.caustics { caustic::target(scene) } else { None };
    let emitters = if plan.caustics { lights.emitters(target) } else { None };
    ctx.emitters = emitters.as_ref();
    let mut guide_rays = 0;
    // The caustic guide, built alike by every render of the scene and seed (shards, resumed),
    // unless no sample is left to take.
    let guide = match (&emitters, target) {
        (Some(e), Some(t)) if plan.guiding && taking => super::guide::Guide::build(&ctx, e, t, &mut guide_rays),
        _ => None,
    };
    accel.deferred_error()?;
    ctx.guide = guide.as_ref();
    let (mut light_rays, mut clamped_splats) = (0, 0);
    if plan.caustics && earlier.film.light.is_none() {
        let c = caustic_image(&ctx, plan, emitters.as_ref(), &control, start)?;
        accel.deferred_error()?;
        earlier.film.light = Some(c.sums);
        (light_rays, clamped_splats) = (c.rays, c.clamped);
    }
    // A shard renders only its own tiles.
    let tiles: Vec<(u32, u32)> = tile_order(settings.width, settings.height)
        .into_iter()
        .filter(|&(tx, ty)| settings.shard.is_none_or(|s| s.owns_tile(tx, ty)))
        .collect();
    // Stage 1 of an adaptive shard stops before the plan; every other render needs no other
    // shard, and stage 1 is all of it.
    let rounds = if control.first_round_only && settings.adaptive { 1 } else { plan.rounds() };
    let session = Session::new(&ctx, Kernel::for_render(plan, &ctx), plan, &control, &key, earlier, owned, start);
    session.rays.fetch_add(pool.as_ref().map_or(0, |p| p.rays), Ordering::Relaxed);
    session.rays.fetch_add(light_rays + guide_rays + visibility_rays, Ordering::Relaxed);
    session.clamped_splats.fetch_add(clamped_splats, Ordering::Relaxed);
    for round in 0..rounds {
        // An adaptive render plans its second round once the first is done everywhere (a
        // resumed render may have the plan from its checkpoint).
        if round == 1 {
            plan_second_round(&mut session.lock().film, settings.spp);
        }
        let meter = session.round_meter(round, rounds);
        tiles.par_iter().try_for_each(|&tile| session.render_tile(tile, round, rounds, &meter))?;
        if session.stopped.load(Ordering::Relaxed) {
            break;
        }
    }
    session.finish().map(|mut r| {
        r.stats.light_visibility_cells = lights.visibility_cells();
        r.stats.surface_light_vertices = surface_light_vertices;
        r
    })
}

/// The pass of camera paths before the render ([`super::visibility::learn`]), where the plan
/// needs it: to weigh the light choice by where samples get through, or to see where paths go
/// for light vertices from area lights. Learned alike by every render of the scene and seed
/// (shards, resumed), unless no sample is left to `take`. With the rays it traced.
fn learn(ctx: &PathContext, plan: &RenderPlan, taking: bool) -> (Option<super::visibility::Learned>, u64) {
    let weigh = plan.light_visibility && ctx.lights.chooses_by_importance();
    let surface_vertices = plan.light_vertices_from_surfaces();
    let mut rays = 0;
    let needs_cells = |escaped| surface_vertices && builds_surface_pool(&plan.settings, escaped);
    let learned = if (weigh || surface_vertices) && taking {
        super::visibility::learn(ctx, weigh, needs_cells, &mut rays)
    } else {
        None
    };
    (learned, rays)
}

/// The light vertices the plan connects to: from the point lights, or from the area lights
/// where most of the pass's bounces stayed in the scene (`visited`, with the share that left)
/// or `--light-vertices on` asks.
fn light_vertex_pool(
    ctx: &PathContext,
    plan: &RenderPlan,
    visited: Option<&(super::visibility::Visited, f64)>,
) -> Option<LightVertexPool> {
    let settings = &plan.settings;
    let pass = (ctx.scene, ctx.normals, ctx.lights);
    let (size, spp, seed) = ((settings.width, settings.height), settings.spp, settings.seed);
    if plan.light_vertices_from_surfaces() {
        visited
            .filter(|(_, escaped)| builds_surface_pool(settings, *escaped))
            .map(|(v, _)| LightVertexPool::from_surfaces(pass, ctx.accel, seed, size, spp, v.clone()))
    } else {
        plan.light_vertices.then(|| LightVertexPool::build(pass, ctx.accel, seed, size, spp))
    }
}

/// Whether light vertices come from the area lights, given the share of the pass's bounces
/// that left the scene: where most stay in it ([`light_vertex::MOST_ESCAPED`]), or when asked.
fn builds_surface_pool(settings: &RenderSettings, escaped: f64) -> bool {
    settings.light_vertices == LightVertices::On || escaped <= light_vertex::MOST_ESCAPED
}

/// The caustics' light paths, traced before the first pixel, reporting their progress (a
/// checkpoint has them already; the first round of a two-stage shard leaves them to its second
/// stage, and so does a scene with nothing for them to light: an empty image).
fn caustic_image(
    ctx: &PathContext,
    plan: &RenderPlan,
    emitters: Option<&Emitters>,
    control: &RenderControl,
    start: Instant,
) -> Result<caustic::CausticImage, RenderError> {
    let (w, h) = (ctx.settings.width, ctx.settings.height);
    match emitters {
        Some(e) if !control.first_round_only => {
            let stop = control.stop;
            let stop_requested = || stop.is_some_and(|s| s.load(Ordering::Relaxed));
            let paths = caustic::paths(w, h, plan.settings.spp);
            let rounds = plan.rounds();
            let report = |traced, rays| {
                if let Some(report) = control.progress {
                    report(Progress {
                        work_done: 0.0,
                        work_before: 0.0,
                        work_planned: 0.0,
                        rays,
                        elapsed: start.elapsed(),
                        round: 0,
                        rounds,
                        light_paths: Some((traced, paths)),
                    });
                }
            };
            caustic::render(ctx, e, paths, &stop_requested, &report).ok_or(RenderError::StoppedInLightPaths)
        }
        _ => Ok(caustic::CausticImage { sums: LightSums::new(w as usize * h as usize), rays: 0, clamped: 0 }),
    }
}

/// The render's checkpoint key ([`RenderPlan::checkpoint_key`]), made when first needed:
/// hashing the scene reads all of its data, so it is done only when a checkpoint is read or
/// written.
struct LazyKey<'a> {
    scene: &'a Scene,
    accel: &'a dyn Accel,
    plan: &'a RenderPlan,
    key: OnceLock<CheckpointKey>,
}

impl LazyKey<'_> {
    fn get(&self) -> &CheckpointKey {
        self.key.get_or_init(|| self.plan.checkpoint_key(self.scene.fingerprint(), &self.accel.image_key()))
    }
}

/// The pixels a render takes: a shard's, or all.
#[derive(Clone, Copy)]
struct Owned {
    shard: Option<crate::settings::Shard>,
    width: u32,
}

impl Owned {
    fn of(settings: &RenderSettings) -> Owned {
        Owned { shard: settings.shard, width: settings.width }
    }

    fn pixel(self, i: usize) -> bool {
        self.shard.is_none_or(|s| s.owns_pixel(i as u32 % self.width, i as u32 / self.width))
    }
}

/// What the render starts from: the film and what earlier sessions spent on it (a resumed
/// checkpoint's, or stage 1's for stage 2 of a shard; an empty film otherwise).
struct Earlier {
    film: Accumulator,
    elapsed: Duration,
    nonfinite: u64,
}

impl Earlier {
    /// Whether every pixel `owned` has taken all its samples: `spp`, or in an adaptive render
    /// the number its plan gave it (none has before the plan).
    fn all_taken(&self, spp: u32, owned: Owned) -> bool {
        let film = &self.film;
        film.pixels.iter().enumerate().filter(|&(i, _)| owned.pixel(i)).all(|(i, p)| {
            let target = film.adaptive.as_ref().map_or(spp, |a| a[i].target);
            target > 0 && p.count >= target
        })
    }

    fn of(
        plan: &RenderPlan,
        resume: Option<(&Path, Checkpoint)>,
        first_rounds: Option<FirstRounds>,
        key: &LazyKey,
    ) -> Result<Earlier, RenderError> {
        let settings = &plan.settings;
        let (w, h) = (settings.width, settings.height);
        Ok(match (resume, first_rounds) {
            (Some((path, c)), _) => {
                c.check_matches(path, key.get())?;
                if let Some(stored) = &c.accum.adaptive {
                    let rays = plan.max_rays_per_sample();
                    if let Some((_, why)) =
                        adaptive::stored_plan_problem(&c.accum.pixels, stored, w, h, settings.spp, rays)
                    {
                        return Err(crate::film::CheckpointError::Corrupt(path.to_path_buf(), why).into());
                    }
                }
                Earlier { film: c.accum, elapsed: c.elapsed, nonfinite: c.nonfinite }
            }
            (None, Some(first)) => {
                assert_eq!((first.accum.width, first.accum.height), (w, h), "the first rounds are the image's");
                assert_eq!(
                    first.accum.adaptive.is_some(),
                    settings.adaptive,
                    "an adaptive render's first rounds have a plan"
                );
                Earlier { film: first.accum, elapsed: first.elapsed, nonfinite: first.nonfinite }
            }
            (None, None) => Earlier {
                film: Accumulator::empty(w, h, settings.aux, settings.adaptive),
                elapsed: Duration::ZERO,
                nonfinite: 0,
            },
        })
    }

    /// The render of a scene where nothing emits: every path carries zero radiance, so none is
    /// traced; each pixel's samples are all exactly zero. (The auxiliary images need the paths
    /// traced.)
    fn traced_nothing(mut self, plan: &RenderPlan, owned: Owned, start: Instant) -> RenderResult {
        for (i, p) in self.film.pixels.iter_mut().enumerate() {
            if !owned.pixel(i) {
                continue;
            }
            // As many exact zeros as the round takes: the sums stay 0 (and a huge spp takes no
            // time).
            if let Some(t) = plan.round_target(0, p, None) {
                p.count = p.count.max(t);
            }
        }
        let stats = self.stats(plan, owned, start, 0, (0, 0, 0));
        RenderResult { accum: self.film, stats, complete: true, warnings: Vec::new() }
    }

    /// The render's statistics, for its film `self.film` after this session's `rays`, dropped
    /// and clamped samples, and clamped light-path splats.
    fn stats(
        &self,
        plan: &RenderPlan,
        owned: Owned,
        start: Instant,
        rays: u64,
        (nonfinite, clamped, clamped_splats): (u64, u64, u64),
    ) -> RenderStats {
        let film = &self.film;
        let pixel = |i: usize| owned.pixel(i);
        RenderStats {
            elapsed: start.elapsed(),
            earlier_sessions: self.elapsed,
            rays,
            samples: film.samples_of(pixel),
            nonfinite: self.nonfinite + nonfinite,
            clamped,
            clamped_splats,
            added_sample_cost: film
                .adaptive
                .as_ref()
                .and_then(|p| adaptive::added_sample_cost(p, adaptive::first_round_spp(plan.settings.spp), pixel)),
            plan: plan.clone(),
            spp: film.spp_range_of(pixel),
            error_estimate: film.error_estimate_of(pixel),
            light_visibility_cells: None,
            surface_light_vertices: None,
        }
    }
}

/// Progress is counted in work ([`Progress`]): a sample of pixel `i` beyond an adaptive
/// render's first round weighs `costs[i]` once the plan is made (`None` before, and in other
/// renders: every sample weighs 1).
struct WorkMeter {
    first_round: u32,
    owned: Owned,
    costs: Option<Vec<f64>>,
}

impl WorkMeter {
    fn new(film: &Accumulator, first_round: u32, owned: Owned) -> WorkMeter {
        let costs = film.adaptive.as_ref().and_then(|plan| {
            plan.iter().all(|p| p.target > 0).then(|| adaptive::sample_costs(plan, first_round, |i| owned.pixel(i)))
        });
        WorkMeter { first_round, owned, costs }
    }

    /// The work of pixel `i`'s first `count` samples.
    fn of(&self, i: usize, count: u32) -> f64 {
        match &self.costs {
            Some(c) => adaptive::work(count, self.first_round, c[i]),
            None => count as f64,
        }
    }

    /// The work of the film's owned pixels as they stand.
    fn done(&self, film: &Accumulator) -> f64 {
        film.pixels.iter().enumerate().filter(|&(i, _)| self.owned.pixel(i)).map(|(i, p)| self.of(i, p.count)).sum()
    }
}

/// A render session's state, shared by the tile tasks of every round.
struct Session<'a> {
    ctx: &'a PathContext<'a>,
    kernel: Kernel,
    plan: &'a RenderPlan,
    control: &'a RenderControl<'a>,
    key: &'a LazyKey<'a>,
    start: Instant,
    owned: Owned,
    /// The film's pixels, and what earlier sessions spent on them.
    earlier: Mutex<Earlier>,
    /// The work done before this session ([`Progress::work_before`]) and up to now.
    work_before: f64,
    work_done: Mutex<f64>,
    rays: AtomicU64,
    nonfinite: AtomicU64,
    clamped: AtomicU64,
    /// Light-path splats of this session scaled down by the sample clamp.
    clamped_splats: AtomicU64,
    stopped: AtomicBool,
    periodic: Mutex<Periodic>,
    previews: Mutex<Periodic>,
}

impl<'a> Session<'a> {
    #[allow(clippy::too_many_arguments)]
    fn new(
        ctx: &'a PathContext<'a>,
        kernel: Kernel,
        plan: &'a RenderPlan,
        control: &'a RenderControl<'a>,
        key: &'a LazyKey<'a>,
        earlier: Earlier,
        owned: Owned,
        start: Instant,
    ) -> Session<'a> {
        let first_round = adaptive::first_round_spp(plan.settings.spp);
        let work_before = WorkMeter::new(&earlier.film, first_round, owned).done(&earlier.film);
        Session {
            ctx,
            kernel,
            plan,
            control,
            key,
            start,
            owned,
            earlier: Mutex::new(earlier),
            work_before,
            work_done: Mutex::new(work_before),
            rays: AtomicU64::new(0),
            nonfinite: AtomicU64::new(0),
            clamped: AtomicU64::new(0),
            clamped_splats: AtomicU64::new(0),
            stopped: AtomicBool::new(false),
            periodic: Periodic::new("periodic checkpoints"),
            previews: Periodic::new("previews"),
        }
    }

    /// The film and what earlier sessions spent on it, locked.
    fn lock(&self) -> std::sync::MutexGuard<'_, Earlier> {
        self.earlier.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn stop_requested(&self) -> bool {
        self.control.stop.is_some_and(|s| s.load(Ordering::Relaxed))
    }

    /// The work meter of round `round` (of `rounds`) and the work planned to its end
    /// ([`Progress::work_planned`]).
    fn round_meter(&self, round: u32, rounds: u32) -> (WorkMeter, f64) {
        let settings = &self.plan.settings;
        let earlier = self.lock();
        let a = &earlier.film;
        let meter = WorkMeter::new(a, adaptive::first_round_spp(settings.spp), self.owned);
        let planned: f64 = if settings.adaptive && meter.costs.is_none() && rounds > 1 {
            // Before the plan, its budget: the cost of `spp` samples in every pixel.
            (0..a.pixels.len()).filter(|&i| self.owned.pixel(i)).count() as f64 * settings.spp as f64
        } else {
            // Pixel `i`'s planned total in an adaptive render (0 before the plan).
            let allocated = |i: usize| a.adaptive.as_ref().map(|plan| plan[i].target);
            let pixels = a.pixels.iter().enumerate().filter(|&(i, _)| self.owned.pixel(i));
            pixels.map(|(i, p)| meter.of(i, self.plan.round_target(round, p, allocated(i)).unwrap_or(p.count))).sum()
        };
        (meter, planned)
    }

    /// One tile's part of round `round`: its pixels are taken out of the shared film once,
    /// rendered, put back once; then a due checkpoint or preview is written and progress
    /// reported.
    fn render_tile(
        &self,
        (tx, ty): (u32, u32),
        round: u32,
        rounds: u32,
        (meter, planned): &(WorkMeter, f64),
    ) -> Result<(), RenderError> {
        if self.stop_requested() {
            self.stopped.store(true, Ordering::Relaxed);
            return Ok(());
        }
        let settings = &self.plan.settings;
        let mut tile =
            TileFilm::take(&self.lock().film, tile_rect(tx, ty, settings.width, settings.height), round, self.plan);
        let out = render_tile(self.ctx, self.kernel, &mut tile, &|| self.stop_requested())?;
        if out.stopped {
            self.stopped.store(true, Ordering::Relaxed);
        }
        let taken: f64 = tile.pixels.iter().map(|t| meter.of(t.i, t.state.count) - meter.of(t.i, t.first)).sum();
        let mut a = self.lock();
        tile.put_back(&mut a.film, round);
        // Counted under the lock, so a checkpoint's count matches its pixels.
        let total_bad = self.nonfinite.fetch_add(out.nonfinite, Ordering::Relaxed) + out.nonfinite;
        self.clamped.fetch_add(out.clamped, Ordering::Relaxed);
        // A periodic checkpoint that cannot be written (a full disk) does not stop the
        // render: it is reported at the end, and tried again after `every`.
        if let Some((_, Some(every))) = self.control.checkpoint
            && let Ok(mut p) = self.periodic.try_lock()
            && p.last.elapsed() >= every
        {
            p.attempt(|| self.save_checkpoint(&a, total_bad));
        }
        // A preview reads the pixels under the lock and is written without it.
        if let Some((every, show)) = self.control.preview
            && let Ok(mut p) = self.previews.try_lock()
            && p.last.elapsed() >= every
        {
            let film = a.film.film();
            drop(a);
            p.attempt(|| show(&film));
        } else {
            drop(a);
        }
        let rays = self.rays.fetch_add(out.rays, Ordering::Relaxed) + out.rays;
        let done = {
            let mut done = self.work_done.lock().unwrap_or_else(|e| e.into_inner());
            *done += taken;
            *done
        };
        if let Some(report) = self.control.progress {
            report(Progress {
                work_done: done,
                work_before: self.work_before,
                work_planned: *planned,
                rays,
                elapsed: self.start.elapsed(),
                round: round + 1,
                rounds,
                light_paths: None,
            });
        }
        Ok(())
    }

    /// Writes the checkpoint of `earlier`'s film with this session's `nonfinite` samples, if
    /// the render keeps one.
    fn save_checkpoint(&self, earlier: &Earlier, nonfinite: u64) -> Result<(), RenderError> {
        if let Some((path, _)) = self.control.checkpoint {
            let key = self.key.get();
            let c = Checkpoint {
                scene: key.scene,
                settings: key.settings.clone(),
                nonfinite: earlier.nonfinite + nonfinite,
                elapsed: earlier.elapsed + self.start.elapsed(),
                accum: earlier.film.clone(),
            };
            c.save(path)?;
        }
        Ok(())
    }

    /// The session's result; a stopped render's checkpoint is written first.
    fn finish(self) -> Result<RenderResult, RenderError> {
        let bad = self.nonfinite.load(Ordering::Relaxed);
        let complete = !self.stopped.load(Ordering::Relaxed);
        if !complete {
            self.save_checkpoint(&self.lock(), bad)?;
        }
        let earlier = self.earlier.into_inner().unwrap_or_else(|e| e.into_inner());
        let warnings = [self.periodic, self.previews]
            .into_iter()
            .filter_map(|p| p.into_inner().unwrap_or_else(|e| e.into_inner()).warning())
            .collect();
        let counts = (bad, self.clamped.load(Ordering::Relaxed), self.clamped_splats.load(Ordering::Relaxed));
        let stats = earlier.stats(self.plan, self.owned, self.start, self.rays.load(Ordering::Relaxed), counts);
        Ok(RenderResult { accum: earlier.film, stats, complete, warnings })
    }
}

/// An adaptive render's plan for its second round, made once the first is done everywhere
/// (a resumed render may have it from its checkpoint already): each pixel's total of the
/// `spp` budget ([`adaptive::allocate`]).
fn plan_second_round(a: &mut Accumulator, spp: u32) {
    let (w, h) = (a.width, a.height);
    if let Some(plan) = &mut a.adaptive
        && plan.iter().any(|p| p.target == 0)
    {
        let targets = adaptive::allocate(&a.pixels, plan, w, h, spp);
        for (p, t) in plan.iter_mut().zip(targets) {
            p.target = t;
        }
    }
}

/// The pixels of tile (`tx`, `ty`) of a `w` × `h` image: x0..x1, y0..y1.
fn tile_rect(tx: u32, ty: u32, w: u32, h: u32) -> (std::ops::Range<u32>, std::ops::Range<u32>) {
    let (x0, y0) = (tx * TILE, ty * TILE);
    (x0..(x0 + TILE).min(w), y0..(y0 + TILE).min(h))
}

/// One pixel of a [`TileFilm`].
struct TilePixel {
    /// Index in the image, and coordinates.
    i: usize,
    x: u32,
    y: u32,
    /// Its sums, taken out of the film; the sample count it had then.
    state: PixelState,
    first: u32,
    aux: Option<AuxSums>,
    /// The samples it takes this round ([`RenderPlan::round_target`]; `None`: none).
    target: Option<u32>,
    /// An adaptive render's first round: the squares of its samples, summed on from the
    /// film's (in sample order, whatever the sessions), and the rays its samples traced.
    sum_sq: DVec3,
    rays: u64,
}

/// A tile's pixels for one round, owned by the task that renders it: taken out of the shared
/// film at the tile's start and put back at its end, so that the film is locked twice per
/// tile, not per pixel.
struct TileFilm {
    pixels: Vec<TilePixel>,
}

impl TileFilm {
    fn take(
        a: &Accumulator,
        (xs, ys): (std::ops::Range<u32>, std::ops::Range<u32>),
        round: u32,
        plan: &RenderPlan,
    ) -> TileFilm {
        let w = a.width;
        let pixels = ys
            .flat_map(|y| xs.clone().map(move |x| (x, y)))
            .map(|(x, y)| {
                let i = (y * w + x) as usize;
                let state = a.pixels[i];
                let planned = a.adaptive.as_ref().map(|plan| plan[i].target);
                TilePixel {
                    i,
                    x,
                    y,
                    state,
                    first: state.count,
                    aux: a.aux.as_ref().map(|aux| aux[i]),
                    target: plan.round_target(round, &state, planned),
                    sum_sq: a.adaptive.as_ref().map_or(DVec3::ZERO, |plan| plan[i].sum_sq),
                    rays: 0,
                }
            })
            .collect();
        TileFilm { pixels }
    }

    /// Writes the tile's pixels (those that took part in the round) back into `a`.
    fn put_back(&self, a: &mut Accumulator, round: u32) {
        for t in self.pixels.iter().filter(|t| t.target.is_some()) {
            a.pixels[t.i] = t.state;
            if round == 0
                && let Some(plan) = &mut a.adaptive
            {
                let p = &mut plan[t.i];
                p.rays = p.rays.saturating_add(t.rays.min(u32::MAX as u64) as u32);
                p.sum_sq = t.sum_sq;
            }
            if let (Some(aux), Some(pa)) = (&mut a.aux, t.aux) {
                aux[t.i] = pa;
            }
        }
    }
}

/// What rendering a tile did.
struct TileOutcome {
    rays: u64,
    /// Samples dropped as non-finite, and scaled by the sample clamp.
    nonfinite: u64,
    clamped: u64,
    /// A stop was requested: the tile's pixels are as far as they got (whole groups).
    stopped: bool,
}

/// The compiled kernel a render runs, for the path loop its settings name.
#[derive(Clone, Copy)]
enum Kernel {
    Scalar(SampleFn),
    Wavefront(BatchFn),
}

impl Kernel {
    /// The kernel of `plan` for its path loop, once the passes have filled `ctx` (light
    /// vertices, guide): `auto` runs the wavefront loop where its shade stage runs in lanes.
    fn for_render(plan: &RenderPlan, ctx: &PathContext) -> Kernel {
        let wavefront = match plan.settings.path_loop {
            PathLoop::Scalar => false,
            PathLoop::Wavefront => true,
            PathLoop::Auto => super::lanes::run_in(ctx),
        };
        if wavefront { Kernel::Wavefront(plan.kernel.batch_fn()) } else { Kernel::Scalar(plan.kernel.sample_fn()) }
    }
}

/// Takes each pixel of `tile` to its round's target, in groups of [`LANES`] samples aligned
/// on sample 0, whatever the rounds (a sample's packet mates never depend on when it is
/// taken); a stop request is honoured between groups (a pixel of many samples can take
/// minutes), the pixel's state kept as it is.
fn render_tile(
    ctx: &PathContext,
    kernel: Kernel,
    tile: &mut TileFilm,
    stop_requested: &dyn Fn() -> bool,
) -> Result<TileOutcome, RenderError> {
    match kernel {
        Kernel::Scalar(sample) => render_tile_scalar(ctx, sample, tile, stop_requested),
        Kernel::Wavefront(batch) => render_tile_wavefront(ctx, batch, tile, stop_requested),
    }
}

/// [`render_tile`] one pixel and one group of samples at a time.
fn render_tile_scalar(
    ctx: &PathContext,
    sample: SampleFn,
    tile: &mut TileFilm,
    stop_requested: &dyn Fn() -> bool,
) -> Result<TileOutcome, RenderError> {
    let settings = ctx.settings;
    let mut out = TileOutcome { rays: 0, nonfinite: 0, clamped: 0, stopped: false };
    let mut values = [glam::Vec3::ZERO; LANES];
    let mut aux_values = [AuxSample::default(); LANES];
    for t in &mut tile.pixels {
        let Some(target) = t.target else { continue };
        if stop_requested() {
            out.stopped = true;
            t.target = None; // untouched: nothing to put back
            continue;
        }
        let streams = t.streams(settings);
        let mut s = t.state.count;
        while s < target {
            if stop_requested() {
                out.stopped = true;
                break;
            }
            let end = target.min((s / LANES as u32 + 1) * LANES as u32);
            let aux_out = t.aux.is_some().then_some(&mut aux_values);
            let mut rays = 0;
            sample(ctx, &streams, (t.x, t.y), s..end, &mut values, aux_out, &mut rays).map_err(RenderError::from)?;
            let n = (end - s) as usize;
            t.add_group(settings, &values[..n], &aux_values[..n], rays, &mut out);
            s = end;
        }
    }
    Ok(out)
}

/// Groups of samples a wavefront batch takes (up to [`LANES`] paths each).
const WAVEFRONT_GROUPS: usize = 64;

/// [`render_tile`] by the wavefront loop: the tile's groups of samples, pixel by pixel and in
/// sample order, in batches of [`WAVEFRONT_GROUPS`] (a batch may span pixels, and a pixel
/// batches); a stop request is honoured between batches. Each group's values are added to its
/// pixel in the order the scalar loop adds them, so the sums are the same.
fn render_tile_wavefront(
    ctx: &PathContext,
    batch: BatchFn,
    tile: &mut TileFilm,
    stop_requested: &dyn Fn() -> bool,
) -> Result<TileOutcome, RenderError> {
    let settings = ctx.settings;
    let mut out = TileOutcome { rays: 0, nonfinite: 0, clamped: 0, stopped: false };
    let streams: Vec<Option<PixelSampler>> =
        tile.pixels.iter().map(|t| t.target.map(|_| t.streams(settings))).collect();
    // The next group to take: (pixel of the tile, its first sample), in the order the scalar
    // loop takes them. Groups are cut as they are taken (a pixel may have billions).
    let next_group = |k: &mut usize, s: &mut u32, pixels: &[TilePixel]| -> Option<(usize, Range<u32>)> {
        while *k < pixels.len() {
            if let Some(target) = pixels[*k].target {
                *s = (*s).max(pixels[*k].state.count);
                if *s < target {
                    let end = target.min((*s / LANES as u32 + 1) * LANES as u32);
                    let group = (*k, *s..end);
                    *s = end;
                    return Some(group);
                }
            }
            (*k, *s) = (*k + 1, 0);
        }
        None
    };
    let aux = tile.pixels.iter().any(|t| t.target.is_some() && t.aux.is_some());
    let mut values = vec![[glam::Vec3::ZERO; LANES]; WAVEFRONT_GROUPS];
    let mut aux_values = vec![[AuxSample::default(); LANES]; if aux { WAVEFRONT_GROUPS } else { 0 }];
    let mut rays = vec![0u64; WAVEFRONT_GROUPS];
    let mut chunk = Vec::with_capacity(WAVEFRONT_GROUPS);
    let (mut k, mut s) = (0, 0);
    loop {
        chunk.clear();
        while chunk.len() < WAVEFRONT_GROUPS
            && let Some(group) = next_group(&mut k, &mut s, &tile.pixels)
        {
            chunk.push(group);
        }
        if chunk.is_empty() {
            break;
        }
        if stop_requested() {
            out.stopped = true;
            break;
        }
        let jobs: Vec<GroupJob> = chunk
            .iter()
            .map(|(k, samples)| GroupJob {
                streams: streams[*k].as_ref().expect("a pixel with a target has streams"),
                pixel: (tile.pixels[*k].x, tile.pixels[*k].y),
                samples: samples.clone(),
            })
            .collect();
        let n = chunk.len();
        rays[..n].fill(0);
        let aux_out = aux.then(|| &mut aux_values[..n]);
        batch(ctx, &jobs, &mut values[..n], aux_out, &mut rays[..n]).map_err(RenderError::from)?;
        for (g, (k, samples)) in chunk.iter().enumerate() {
            let m = samples.len();
            let aux_group = if aux { &aux_values[g][..m] } else { &[] };
            tile.pixels[*k].add_group(settings, &values[g][..m], aux_group, rays[g], &mut out);
        }
    }
    if out.stopped {
        for t in &mut tile.pixels {
            // A pixel no batch reached still has the samples it started the round with:
            // nothing to put back.
            if t.state.count == t.first {
                t.target = None;
            }
        }
    }
    Ok(out)
}

impl TilePixel {
    /// The streams of this pixel's samples.
    fn streams(&self, settings: &RenderSettings) -> PixelSampler {
        PixelSampler::new(settings.sampler, settings.seed, self.y as u64 * settings.width as u64 + self.x as u64)
    }

    /// Adds the values of a group of this pixel's samples, in sample order, and their
    /// auxiliary samples (if the render makes auxiliary images); `rays` were traced for them.
    fn add_group(
        &mut self,
        settings: &RenderSettings,
        values: &[glam::Vec3],
        aux: &[AuxSample],
        rays: u64,
        out: &mut TileOutcome,
    ) {
        for &v in values {
            if v.is_finite() {
                // The sample clamp acts on what the film receives: the path and its
                // numbers are those of an unclamped render.
                let v = match settings.clamp {
                    Some(limit) => {
                        let (v, scaled) = clamp_sample(v, limit);
                        out.clamped += scaled as u64;
                        v
                    }
                    None => v,
                };
                self.state.add(v);
                let v = v.as_dvec3();
                self.sum_sq += v * v;
            } else {
                out.nonfinite += 1;
                self.state.add(glam::Vec3::ZERO);
            }
        }
        if let Some(pa) = &mut self.aux {
            // In sample order, like the radiance: the same sums whatever the threads,
            // rounds or sessions.
            for a in aux {
                pa.add(a.albedo, a.normal);
            }
        }
        self.rays += rays;
        out.rays += rays;
    }
}

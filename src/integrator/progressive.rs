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
//! Each round is a parallel loop over tiles, in named steps: the task takes its tile's pixels
//! out of the shared film ([`TileFilm::take`]), renders them ([`render_tile`]) and puts them
//! back ([`TileFilm::put_back`]), then writes a due checkpoint or preview and reports progress.
//! The film is locked twice per tile, not per pixel.

use super::adaptive;
use super::aux::AuxSample;
use super::context::PathContext;
use super::kernel::SampleFn;
use super::light_vertex::LightVertexPool;
use super::surface::FaceNormals;
use super::wavefront::{BatchFn, GroupJob};
use super::{RenderError, RenderPlan, RenderSettings, RenderStats};
use crate::accel::{Accel, LANES};
use crate::film::{Accumulator, AuxSums, Checkpoint, PixelState};
use crate::sampler::{PixelSampler, mix64};
use crate::scene::Scene;
use crate::settings::{PathLoop, TILE, clamp_sample};
use glam::DVec3;
use rayon::prelude::*;
use std::ops::Range;
use std::path::Path;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
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
    /// The current round (from 1) and the most rounds there can be.
    pub round: u32,
    pub rounds: u32,
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

pub(super) fn run(
    scene: &Scene,
    accel: &dyn Accel,
    plan: &RenderPlan,
    control: RenderControl,
) -> Result<RenderResult, RenderError> {
    let start = Instant::now();
    let settings = &plan.settings;
    // A resumed stage is still told which it is: resuming stage 1 as a whole shard would plan
    // from this shard's pixels alone.
    let staged = control.first_round_only || control.first_rounds.is_some();
    if settings.adaptive && settings.shard.is_some() && !staged {
        return Err(RenderError::AdaptiveShard);
    }
    let (w, h) = (settings.width, settings.height);
    // Hashing the scene reads all of its data: done only when a checkpoint is read or written.
    let key = std::sync::OnceLock::new();
    let key = || key.get_or_init(|| plan.checkpoint_key(scene.fingerprint(), &accel.image_key()));
    let (mut accum, prior_elapsed, prior_nonfinite) = match (control.resume, control.first_rounds) {
        (Some((path, c)), _) => {
            c.check_matches(path, key())?;
            if let Some(stored) = &c.accum.adaptive {
                let rays = plan.max_rays_per_sample();
                if let Some((_, why)) = adaptive::stored_plan_problem(&c.accum.pixels, stored, w, h, settings.spp, rays)
                {
                    return Err(crate::film::CheckpointError::Corrupt(path.to_path_buf(), why).into());
                }
            }
            (c.accum, c.elapsed, c.nonfinite)
        }
        (None, Some(first)) => {
            assert_eq!((first.accum.width, first.accum.height), (w, h), "the first rounds are the image's");
            assert_eq!(
                first.accum.adaptive.is_some(),
                settings.adaptive,
                "an adaptive render's first rounds have a plan"
            );
            (first.accum, first.elapsed, first.nonfinite)
        }
        (None, None) => (Accumulator::empty(w, h, settings.aux, settings.adaptive), Duration::ZERO, 0),
    };
    let camera = scene.camera(w as f32 / h as f32);
    let lights = scene.light_set(settings.light_tree);
    // The pixels this render takes: a shard's, or all.
    let owned = |i: usize| settings.shard.is_none_or(|s| s.owns_pixel(i as u32 % w, i as u32 / w));
    let finish = |accum: Accumulator, rays: u64, (nonfinite, clamped): (u64, u64), complete, warnings| {
        let stats = RenderStats {
            elapsed: start.elapsed(),
            earlier_sessions: prior_elapsed,
            rays,
            samples: accum.samples_of(owned),
            nonfinite: prior_nonfinite + nonfinite,
            clamped,
            added_sample_cost: accum
                .adaptive
                .as_ref()
                .and_then(|p| adaptive::added_sample_cost(p, adaptive::first_round_spp(settings.spp), owned)),
            plan: plan.clone(),
            spp: accum.spp_range_of(owned),
            error_estimate: accum.error_estimate_of(owned),
        };
        RenderResult { accum, stats, complete, warnings }
    };
    if plan.traces_nothing() && !settings.aux {
        // Nothing emits: every path carries zero radiance, so none is traced; each pixel's
        // samples are all exactly zero. (The auxiliary images need the paths traced.)
        for (i, p) in accum.pixels.iter_mut().enumerate() {
            if !owned(i) {
                continue;
            }
            // As many exact zeros as the round takes: the sums stay 0 (and a huge spp takes no
            // time).
            if let Some(t) = plan.round_target(0, p, None) {
                p.count = p.count.max(t);
            }
        }
        return Ok(finish(accum, 0, (0, 0), true, Vec::new()));
    }
    let kernel = Kernel::for_plan(plan);
    let normals = FaceNormals::of(scene);
    let mut ctx = PathContext {
        scene,
        accel,
        lights: &lights,
        normals: &normals,
        camera: &camera,
        settings,
        path_depth: plan.path_depth,
        roulette_start: plan.roulette_start.unwrap_or(u32::MAX),
        light_vertices: None,
    };
    let pool = plan
        .light_vertices
        .then(|| LightVertexPool::build((scene, &normals, &lights), accel, settings.seed, (w, h), settings.spp));
    accel.deferred_error()?;
    ctx.light_vertices = pool.as_ref();
    // A shard renders only its own tiles.
    let tiles: Vec<(u32, u32)> =
        tile_order(w, h).into_iter().filter(|&(tx, ty)| settings.shard.is_none_or(|s| s.owns_tile(tx, ty))).collect();
    // Stage 1 of an adaptive shard stops before the plan; every other render needs no other
    // shard, and stage 1 is all of it.
    let n_rounds = if control.first_round_only && settings.adaptive { 1 } else { plan.rounds() };
    let rays_total = AtomicU64::new(pool.as_ref().map_or(0, |p| p.rays));
    // Progress is counted in work ([`Progress`]): a sample of pixel `i` beyond an adaptive
    // render's first round weighs `costs[i]` once the plan is made.
    let first_round = adaptive::first_round_spp(settings.spp);
    let costs_of = |a: &Accumulator| -> Option<Vec<f64>> {
        let plan = a.adaptive.as_ref()?;
        plan.iter().all(|p| p.target > 0).then(|| adaptive::sample_costs(plan, first_round, owned))
    };
    let work_of = |costs: &Option<Vec<f64>>, i: usize, count: u32| match costs {
        Some(c) => adaptive::work(count, first_round, c[i]),
        None => count as f64,
    };
    let work_before = {
        let costs = costs_of(&accum);
        accum.pixels.iter().enumerate().filter(|&(i, _)| owned(i)).map(|(i, p)| work_of(&costs, i, p.count)).sum()
    };
    let work_done = Mutex::new(work_before);
    let nonfinite = AtomicU64::new(0);
    let clamped = AtomicU64::new(0);
    let stopped = AtomicBool::new(false);
    let shared = Mutex::new(accum);
    let periodic = Periodic::new("periodic checkpoints");
    let previews = Periodic::new("previews");
    let stop_requested = || control.stop.is_some_and(|s| s.load(Ordering::Relaxed));
    let save_checkpoint = |accum: &Accumulator, nonfinite: u64| -> Result<(), RenderError> {
        if let Some((path, _)) = control.checkpoint {
            let key = key();
            let c = Checkpoint {
                scene: key.scene,
                settings: key.settings.clone(),
                nonfinite: prior_nonfinite + nonfinite,
                elapsed: prior_elapsed + start.elapsed(),
                accum: accum.clone(),
            };
            c.save(path)?;
        }
        Ok(())
    };

    for round in 0..n_rounds {
        // An adaptive render plans its second round once the first is done everywhere (a
        // resumed render may have the plan from its checkpoint).
        if round == 1 {
            plan_second_round(&mut shared.lock().unwrap_or_else(|e| e.into_inner()), settings.spp);
        }
        // Pixel `i`'s planned total in an adaptive render (0 before the plan).
        let allocated = |a: &Accumulator, i: usize| a.adaptive.as_ref().map(|plan| plan[i].target);
        let (costs, planned) = {
            let a = shared.lock().unwrap_or_else(|e| e.into_inner());
            let costs = costs_of(&a);
            let planned: f64 = if settings.adaptive && costs.is_none() && n_rounds > 1 {
                // Before the plan, its budget: the cost of `spp` samples in every pixel.
                (0..a.pixels.len()).filter(|&i| owned(i)).count() as f64 * settings.spp as f64
            } else {
                let pixels = a.pixels.iter().enumerate().filter(|&(i, _)| owned(i));
                pixels
                    .map(|(i, p)| {
                        let end = plan.round_target(round, p, allocated(&a, i)).unwrap_or(p.count);
                        work_of(&costs, i, end)
                    })
                    .sum()
            };
            (costs, planned)
        };
        tiles.par_iter().try_for_each(|&(tx, ty)| -> Result<(), RenderError> {
            if stop_requested() {
                stopped.store(true, Ordering::Relaxed);
                return Ok(());
            }
            // The tile's pixels belong to this task for the round: taken out of the shared
            // film once, rendered, put back once.
            let mut tile = {
                let a = shared.lock().unwrap_or_else(|e| e.into_inner());
                TileFilm::take(&a, tile_rect(tx, ty, w, h), round, plan)
            };
            let out = render_tile(&ctx, kernel, &mut tile, &stop_requested)?;
            if out.stopped {
                stopped.store(true, Ordering::Relaxed);
            }
            let taken: f64 =
                tile.pixels.iter().map(|t| work_of(&costs, t.i, t.state.count) - work_of(&costs, t.i, t.first)).sum();
            let mut a = shared.lock().unwrap_or_else(|e| e.into_inner());
            tile.put_back(&mut a, round);
            // Counted under the lock, so a checkpoint's count matches its pixels.
            let total_bad = nonfinite.fetch_add(out.nonfinite, Ordering::Relaxed) + out.nonfinite;
            clamped.fetch_add(out.clamped, Ordering::Relaxed);
            // A periodic checkpoint that cannot be written (a full disk) does not stop the
            // render: it is reported at the end, and tried again after `every`.
            if let Some((_, Some(every))) = control.checkpoint
                && let Ok(mut p) = periodic.try_lock()
                && p.last.elapsed() >= every
            {
                p.attempt(|| save_checkpoint(&a, total_bad));
            }
            // A preview reads the pixels under the lock and is written without it.
            if let Some((every, show)) = control.preview
                && let Ok(mut p) = previews.try_lock()
                && p.last.elapsed() >= every
            {
                let film = a.film();
                drop(a);
                p.attempt(|| show(&film));
            } else {
                drop(a);
            }
            let rays = rays_total.fetch_add(out.rays, Ordering::Relaxed) + out.rays;
            let done = {
                let mut done = work_done.lock().unwrap_or_else(|e| e.into_inner());
                *done += taken;
                *done
            };
            if let Some(report) = control.progress {
                report(Progress {
                    work_done: done,
                    work_before,
                    work_planned: planned,
                    rays,
                    elapsed: start.elapsed(),
                    round: round + 1,
                    rounds: n_rounds,
                });
            }
            Ok(())
        })?;
        if stopped.load(Ordering::Relaxed) {
            break;
        }
    }
    let accum = shared.into_inner().unwrap_or_else(|e| e.into_inner());
    let bad = nonfinite.load(Ordering::Relaxed);
    let complete = !stopped.load(Ordering::Relaxed);
    if !complete {
        save_checkpoint(&accum, bad)?;
    }
    let warnings = [periodic, previews]
        .into_iter()
        .filter_map(|p| p.into_inner().unwrap_or_else(|e| e.into_inner()).warning())
        .collect();
    let counts = (bad, clamped.load(Ordering::Relaxed));
    Ok(finish(accum, rays_total.load(Ordering::Relaxed), counts, complete, warnings))
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
    fn for_plan(plan: &RenderPlan) -> Kernel {
        match plan.settings.path_loop {
            PathLoop::Scalar => Kernel::Scalar(plan.kernel.sample_fn()),
            PathLoop::Wavefront => Kernel::Wavefront(plan.kernel.batch_fn()),
        }
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

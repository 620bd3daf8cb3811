//! Render kernels specialised to a scene's effects.
//!
//! The path tracer is one generic function; five const-generic switches remove whole blocks of
//! it when the scene does not need them, so the compiled kernel has no per-sample branch on an
//! absent effect. The dimensions were chosen where the code they remove runs at every sample
//! or every bounce:
//!
//! - `LENS`: thin-lens sampling of the camera ray (off: pinhole rays only);
//! - `TEX`: texture lookups and texture coordinates at each hit (off: constant colours, no
//!   UV interpolation);
//! - `GLOSSY`: non-Lambertian opaque BSDFs (microfacet metal, plastic, mirrors). Off together
//!   with `GLASS`: every surface is Lambertian, and the BSDF is evaluated and sampled inline
//!   without dispatch;
//! - `GLASS`: refraction (off: every surface is opaque, shading-side flips are unconditional);
//! - `HIT_LIGHTS`: lights that BSDF-sampled rays can hit (area lights, sky, environment), so
//!   emission found by a path counts and is weighed by MIS. Off: only point lights exist, so
//!   emission is never found by BSDF-sampled rays, and neither MIS weights nor light
//!   densities are computed.
//!
//! Effects that need one of these switches leave with it: caustic light paths and their guide
//! (only beside mirrors or glass) with `GLOSSY` and `GLASS` both off, light vertices from
//! surfaces (only from area lights) with `HIT_LIGHTS` off.
//!
//! Every kernel takes the samples of a pixel in groups of [`LANES`] (8): their camera rays
//! share an origin and nearly a direction (an orthographic camera's: a direction, and origins
//! within the pixel), so they are traced as one Embree packet (`rtcIntersect8`, hinted
//! coherent); each path then continues on its own.
//!
//! 2⁵ = 32 instances are compiled; one is chosen per render. Geometry types a scene lacks are
//! not a dimension: they are simply not registered with the accelerator. The general kernel
//! (every switch on) is what `--no-specialize` runs; for any scene it computes the same image
//! as the specialised one, bit for bit, because every switch only removes work whose result
//! is known (zero emission, constant colours, a Lambertian BSDF) and random numbers are drawn
//! identically in both.

use super::aux::{AuxSample, aux_sample};
use super::context::PathContext;
use super::path::radiance;
use crate::accel::{Accel, AccelError, LANES};
use crate::geometry::{Ray, RayPacket};
use crate::sampler::{PixelSampler, SampleStream};
use crate::scene::Effects;
use glam::{Vec2, Vec3};
use std::fmt;
use std::ops::Range;

/// The feature switches of a kernel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct KernelChoice {
    pub lens: bool,
    pub textures: bool,
    pub glossy: bool,
    pub glass: bool,
    pub hit_lights: bool,
}

impl KernelChoice {
    /// Every switch on: correct for any scene.
    pub const GENERAL: KernelChoice =
        KernelChoice { lens: true, textures: true, glossy: true, glass: true, hit_lights: true };

    /// The smallest kernel that is correct for a scene with these effects.
    pub fn for_effects(e: &Effects) -> KernelChoice {
        KernelChoice {
            lens: e.depth_of_field,
            textures: e.textures,
            glossy: e.glossy || e.mirror,
            glass: e.glass,
            hit_lights: e.non_delta_lights(),
        }
    }

    /// The compiled kernel for these switches.
    pub(crate) fn sample_fn(self) -> SampleFn {
        self.instance::<ScalarLoop>()
    }

    /// The compiled wavefront kernel for these switches ([`super::wavefront`]).
    pub(crate) fn batch_fn(self) -> super::wavefront::BatchFn {
        self.instance::<super::wavefront::WavefrontLoop>()
    }

    /// `F`'s instance for these switches.
    fn instance<F: KernelFamily>(self) -> F::Fn {
        fn lens<F: KernelFamily, const L: bool>(k: KernelChoice) -> F::Fn {
            if k.textures { tex::<F, L, true>(k) } else { tex::<F, L, false>(k) }
        }
        fn tex<F: KernelFamily, const L: bool, const T: bool>(k: KernelChoice) -> F::Fn {
            if k.glossy { glossy::<F, L, T, true>(k) } else { glossy::<F, L, T, false>(k) }
        }
        fn glossy<F: KernelFamily, const L: bool, const T: bool, const G: bool>(k: KernelChoice) -> F::Fn {
            if k.glass { glass::<F, L, T, G, true>(k) } else { glass::<F, L, T, G, false>(k) }
        }
        fn glass<F: KernelFamily, const L: bool, const T: bool, const G: bool, const R: bool>(
            k: KernelChoice,
        ) -> F::Fn {
            if k.hit_lights { F::instance::<L, T, G, R, true>() } else { F::instance::<L, T, G, R, false>() }
        }
        if self.lens { lens::<F, true>(self) } else { lens::<F, false>(self) }
    }
}

/// A kernel compiled once per combination of the switches of [`KernelChoice`].
pub(crate) trait KernelFamily {
    type Fn;
    /// The instance for these switches (in [`KernelChoice`]'s order).
    fn instance<const LENS: bool, const TEX: bool, const GLOSSY: bool, const GLASS: bool, const HIT_LIGHTS: bool>()
    -> Self::Fn;
}

/// The path-at-a-time kernels ([`SampleFn`]).
struct ScalarLoop;

impl KernelFamily for ScalarLoop {
    type Fn = SampleFn;
    fn instance<const LENS: bool, const TEX: bool, const GLOSSY: bool, const GLASS: bool, const HIT_LIGHTS: bool>()
    -> SampleFn {
        sample::<LENS, TEX, GLOSSY, GLASS, HIT_LIGHTS>
    }
}

/// `kernel: lens off, textures off, glossy on, glass off, hit lights on`
impl fmt::Display for KernelChoice {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if *self == KernelChoice::GENERAL {
            return write!(f, "general (all effects)");
        }
        let on = |b: bool| if b { "on" } else { "off" };
        write!(
            f,
            "lens {}, textures {}, glossy {}, glass {}, hit lights {}",
            on(self.lens),
            on(self.textures),
            on(self.glossy),
            on(self.glass),
            on(self.hit_lights)
        )
    }
}

/// Samples `samples` (at most [`LANES`], within one group of `LANES` aligned on sample
/// index 0) of pixel (x, y), whose streams are `streams` (built once per pixel:
/// `PixelSampler::new` with the render's sampler, seed and the pixel's index), written to
/// `out[..samples.len()]`, and their auxiliary samples to `aux[..samples.len()]` if given;
/// `rays` counts the rays traced.
pub(crate) type SampleFn = fn(
    &PathContext,
    &PixelSampler,
    (u32, u32),
    Range<u32>,
    &mut [Vec3; LANES],
    Option<&mut [AuxSample; LANES]>,
    &mut u64,
) -> Result<(), AccelError>;

/// The samples of a pixel go together: their camera rays are coherent (one origin, directions
/// within the pixel), so they are traced as one packet; each path then continues alone. Every
/// sample draws its own random numbers, so its value does not depend on the others.
fn sample<const LENS: bool, const TEX: bool, const GLOSSY: bool, const GLASS: bool, const HIT_LIGHTS: bool>(
    ctx: &PathContext,
    streams: &PixelSampler,
    (x, y): (u32, u32),
    samples: Range<u32>,
    out: &mut [Vec3; LANES],
    aux: Option<&mut [AuxSample; LANES]>,
    rays: &mut u64,
) -> Result<(), AccelError> {
    let n = samples.len();
    let (camera_rays, mut rngs) = camera_stage::<LENS>(ctx, streams, (x, y), samples.clone());
    let pixel = y as u64 * ctx.settings.width as u64 + x as u64;
    let packet = CameraPacket {
        rays: &camera_rays,
        active: std::array::from_fn(|i| i < n),
        pixel,
        first_sample: samples.start as u64,
    };
    match ctx.accel.as_embree() {
        Some(embree) => trace::<_, TEX, GLOSSY, GLASS, HIT_LIGHTS>(ctx, embree, &packet, &mut rngs, out, aux, rays),
        None => trace::<_, TEX, GLOSSY, GLASS, HIT_LIGHTS>(ctx, ctx.accel, &packet, &mut rngs, out, aux, rays),
    }
}

/// The camera stage of the samples `samples` (at most [`LANES`], within one group of `LANES`
/// aligned on sample index 0) of pixel (x, y), whose streams are `streams`: their camera rays
/// as a packet hinted coherent, lane i for sample `samples.start + i`, and each sample's
/// stream after the numbers the camera drew. Lane by lane in structure-of-arrays form: each
/// sample's first four numbers place it on the film, in pixels (drawn from the pixel filter,
/// weight 1; for the box filter exactly x + u as always), and on the lens (drawn in every
/// kernel, so that all kernels consume the same numbers). Idle lanes (a group cut short by
/// the sample count) hold copies of the first lane's ray and stream, not their own: at 1 spp,
/// seven of every eight lanes are idle.
#[inline(always)]
pub(super) fn camera_stage<'s, const LENS: bool>(
    ctx: &PathContext,
    streams: &'s PixelSampler,
    (x, y): (u32, u32),
    samples: Range<u32>,
) -> (RayPacket, [SampleStream<'s>; LANES]) {
    let (w, h) = (ctx.settings.width, ctx.settings.height);
    let n = samples.len();
    debug_assert!(n <= LANES && (n == 0 || samples.start / LANES as u32 == (samples.end - 1) / LANES as u32));
    let (u, first) = streams.sample_after_first_four(samples.start as u64);
    let mut numbers = [u; LANES];
    let rngs: [SampleStream<'_>; LANES] = std::array::from_fn(|i| {
        if i == 0 || i >= n {
            return first.clone();
        }
        let (u, rng) = streams.sample_after_first_four(samples.start as u64 + i as u64);
        numbers[i] = u;
        rng
    });
    let (mut fx, mut fy) = ([0.0; LANES], [0.0; LANES]);
    for (i, u) in numbers.iter().enumerate() {
        let p = ctx.settings.filter.film_position(x, y, Vec2::new(u[0], u[1]));
        (fx[i], fy[i]) = (p.x / w as f32, p.y / h as f32);
    }
    let cam = ctx.camera;
    let mut camera_rays = RayPacket::splat(&Ray::new(cam.position, cam.forward()));
    camera_rays.coherent = true;
    if LENS {
        for (i, u) in numbers.iter().enumerate() {
            camera_rays.set(i, &cam.ray(Vec2::new(fx[i], fy[i]), Vec2::new(u[2], u[3])));
        }
    } else if cam.is_orthographic() {
        // Parallel rays from points across the view plane: one direction, eight origins.
        camera_rays.o = cam.ortho_origins(&fx, &fy);
    } else {
        camera_rays.d = cam.pinhole_dirs(&fx, &fy);
    }
    (camera_rays, rngs)
}

/// The camera rays of a pixel's samples `first_sample`.. in the `active` lanes.
struct CameraPacket<'a> {
    rays: &'a RayPacket,
    active: [bool; LANES],
    pixel: u64,
    first_sample: u64,
}

#[inline(always)]
fn trace<A: Accel + ?Sized, const TEX: bool, const GLOSSY: bool, const GLASS: bool, const HIT_LIGHTS: bool>(
    ctx: &PathContext,
    accel: &A,
    packet: &CameraPacket,
    rngs: &mut [SampleStream<'_>; LANES],
    out: &mut [Vec3; LANES],
    aux: Option<&mut [AuxSample; LANES]>,
    rays: &mut u64,
) -> Result<(), AccelError> {
    let &CameraPacket { rays: camera_rays, active, pixel, first_sample } = packet;
    let hits = accel.intersect_packet_deferred(camera_rays, active, 0.0, f32::INFINITY);
    for i in (0..LANES).filter(|&i| active[i]) {
        *rays += 1;
        let ray = camera_rays.ray(i);
        let y = ctx.light_vertices.map(|p| p.for_sample(pixel, first_sample + i as u64));
        out[i] = radiance::<A, TEX, GLOSSY, GLASS, HIT_LIGHTS>(ctx, accel, ray, hits[i], y, &mut rngs[i], rays);
    }
    // Beside the paths, from the same camera rays and first hits (see `super::aux`).
    if let Some(aux) = aux {
        for i in (0..LANES).filter(|&i| active[i]) {
            let sample = first_sample + i as u64;
            let ray = camera_rays.ray(i);
            aux[i] = aux_sample::<A, TEX, GLOSSY, GLASS>(ctx, accel, ray, hits[i], pixel, sample, rays);
        }
    }
    // Queries report errors (a panicked user-geometry callback) once per packet of paths.
    accel.deferred_error()
}

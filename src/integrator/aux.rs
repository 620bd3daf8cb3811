//! The auxiliary images a denoiser is given besides the image: per sample, the albedo and
//! shading normal of the first non-specular surface the camera ray leads to, through mirrors
//! and glass, as Open Image Denoise asks.
//!
//! They are worked out beside the path, never inside it: from the sample's camera ray and its
//! first hit (both already traced for the path), following specular bounces with rays of
//! their own and, where glass must choose between reflection and refraction, random numbers
//! of their own (a stream keyed apart from the path's). So the path, its random numbers and
//! the image are the same, bit for bit, whether the auxiliary images are taken or not, and a
//! render that does not take them runs exactly the code it ran before.

use super::context::PathContext;
use super::surface::surface_point;
use crate::accel::Accel;
use crate::geometry::{Frame, Hit, Ray, offset_ray_origin, offset_toward};
use crate::material::{Bsdf, BsdfModel};
use crate::sampler::PixelStreams;
use glam::Vec3;

/// "aux" in ASCII: keys the random streams of the auxiliary paths apart from the image's.
const AUX_STREAM_KEY: u64 = 0x6175_785f_7061_7468;

/// The auxiliary values of one sample. The albedo is the surface's
/// ([`crate::material::Bsdf::denoise_albedo`]) times the throughput of the specular chain
/// that leads to it (a tinted mirror tints it); glass reflects or refracts with the Fresnel
/// probabilities, so the mean over samples is the Fresnel blend of the surfaces seen both
/// ways. The normal is the unit shading normal in world space, on the side the surface is seen
/// from. Where the ray leaves the scene both are zero; where the chain is cut (the path depth)
/// on a specular surface, they are that surface's.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AuxSample {
    pub albedo: Vec3,
    pub normal: Vec3,
}

/// The [`AuxSample`] of sample `sample` of pixel `pixel`, whose camera ray is `ray` with the
/// closest hit `first`; `rays` counts the rays it traces (only through specular surfaces).
/// Queries defer their errors, as the path's do. The const switches are the kernel's.
#[inline(always)]
pub(crate) fn aux_sample<A: Accel + ?Sized, const TEX: bool, const GLOSSY: bool, const GLASS: bool>(
    ctx: &PathContext,
    accel: &A,
    mut ray: Ray,
    first: Option<Hit>,
    pixel: u64,
    sample: u64,
    rays: &mut u64,
) -> AuxSample {
    let mut chain = Vec3::ONE;
    let mut next_hit = first;
    // Only glass draws random numbers here: created when first needed.
    let mut rng = None;
    for depth in 0.. {
        let Some(hit) = next_hit else { return AuxSample::default() };
        let sp = surface_point::<TEX>(ctx.scene, ctx.normals, &ray, &hit);
        let mut bsdf = if GLOSSY || GLASS {
            sp.material.bsdf_at::<TEX>(&sp.tex)
        } else {
            Bsdf::Diffuse(sp.material.lambert_at::<TEX>(&sp.tex))
        };
        let wo = -ray.d;
        let facing = wo.dot(sp.ng) >= 0.0;
        let normal = if facing { sp.ns } else { -sp.ns };
        let albedo = (chain * bsdf.denoise_albedo()).clamp(Vec3::ZERO, Vec3::ONE);
        let here = AuxSample { albedo: if albedo.is_finite() { albedo } else { Vec3::ZERO }, normal };
        if !((GLOSSY || GLASS) && bsdf.is_delta()) || depth >= ctx.path_depth {
            return here;
        }
        // A mirror or glass: follow the bounce, as the path would.
        let transmissive = bsdf.is_transmissive();
        let (ng, ns) = if transmissive || facing { (sp.ng, sp.ns) } else { (-sp.ng, -sp.ns) };
        let frame = Frame::from_normal(ns);
        if let Some(n) = sp.coat_normal(ng) {
            bsdf.set_coat_normal(frame.to_local(n));
        }
        let rng =
            rng.get_or_insert_with(|| PixelStreams::new(ctx.settings.seed ^ AUX_STREAM_KEY, pixel).sample(sample));
        let Some(bs) = bsdf.sample(frame.to_local(wo), rng.next_2d(), rng.next_f32()) else { return here };
        let wi = frame.to_world(bs.wi);
        if (!transmissive && wi.dot(ng) <= 0.0) || !(bs.pdf > 0.0) {
            return here;
        }
        chain *= bs.f * (bs.wi.z.abs() / bs.pdf);
        let origin = if transmissive { offset_toward(sp.p, ng, wi) } else { offset_ray_origin(sp.p, ng) };
        ray = Ray::new(origin, wi);
        *rays += 1;
        next_hit = accel.intersect_deferred(&ray, 0.0, f32::INFINITY);
    }
    unreachable!("the loop returns")
}

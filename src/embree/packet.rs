//! Packets of 8 rays (`rtcIntersect8`): coherent rays, such as the samples of one pixel, are
//! traced together through the BVH, which costs Embree less per ray than one call per ray.

use super::ffi;
use crate::geometry::{Hit, Ray};
use glam::Vec3;

/// Rays per packet.
pub const LANES: usize = 8;

/// `RTCRayHit8` memory as large as the largest known layout: the ray block (12 × 8 words),
/// the hit block (8 × 8 words) and room for Embree 4.3+'s `instPrimID` lanes, which come last
/// (`layout.rs` explains the two layouts; a library with the smaller one never touches the
/// last 32 bytes). 32-byte aligned, as Embree requires of 8-wide packets.
#[repr(C, align(32))]
pub(super) struct RayHit8Mem {
    pub(super) ray: ffi::RTCRay8,
    pub(super) ng: [[f32; LANES]; 3],
    pub(super) u: [f32; LANES],
    pub(super) v: [f32; LANES],
    pub(super) prim_id: [u32; LANES],
    pub(super) geom_id: [u32; LANES],
    pub(super) inst_id: [u32; LANES],
    pub(super) inst_prim_id: [u32; LANES],
}

/// Embree's `valid` mask: -1 for an active lane, 0 for an inactive one; 32-byte aligned.
#[repr(C, align(32))]
pub(super) struct Valid8(pub(super) [i32; LANES]);

/// The ray block of a query for the `active` lanes of `rays` on `[tmin, tmax]`, and its valid
/// mask. Inactive lanes hold a harmless ray (Embree does not read them).
#[inline]
pub(super) fn ray8(rays: &[Ray; LANES], active: [bool; LANES], tmin: f32, tmax: f32) -> (ffi::RTCRay8, Valid8) {
    let mut ray = empty_ray8(tmin, tmax);
    let valid = fill_ray8(&mut ray, rays, active);
    (ray, valid)
}

/// An `RTCRay8` on `[tmin, tmax]` whose lanes all hold the harmless ray (origin 0, direction +z).
#[inline(always)]
fn empty_ray8(tmin: f32, tmax: f32) -> ffi::RTCRay8 {
    ffi::RTCRay8 {
        org_x: [0.0; LANES],
        org_y: [0.0; LANES],
        org_z: [0.0; LANES],
        tnear: [tmin; LANES],
        dir_x: [0.0; LANES],
        dir_y: [0.0; LANES],
        dir_z: [1.0; LANES],
        time: [0.0; LANES],
        tfar: [tmax; LANES],
        // A mask of 0 would hit nothing; every geometry keeps Embree's default mask.
        mask: [u32::MAX; LANES],
        id: [0; LANES],
        flags: [0; LANES],
    }
}

/// Writes the `active` lanes of `rays` into `ray` in place, in one pass over the lanes
/// (per-field closures over the lanes did not inline, and building the block apart from its
/// packet cost a copy of it), and gives the valid mask.
#[inline(always)]
fn fill_ray8(ray: &mut ffi::RTCRay8, rays: &[Ray; LANES], active: [bool; LANES]) -> Valid8 {
    let mut valid = Valid8([0; LANES]);
    for i in 0..LANES {
        if active[i] {
            let r = &rays[i];
            (ray.org_x[i], ray.org_y[i], ray.org_z[i]) = (r.o.x, r.o.y, r.o.z);
            (ray.dir_x[i], ray.dir_y[i], ray.dir_z[i]) = (r.d.x, r.d.y, r.d.z);
            valid.0[i] = -1;
        }
    }
    valid
}

impl RayHit8Mem {
    /// A closest-hit query for the `active` lanes of `rays` on `[tmin, tmax]` ([`ray8`]),
    /// with no hit yet.
    #[inline(always)]
    pub(super) fn new(rays: &[Ray; LANES], active: [bool; LANES], tmin: f32, tmax: f32) -> (RayHit8Mem, Valid8) {
        let none = ffi::INVALID_GEOMETRY_ID;
        let mut mem = RayHit8Mem {
            ray: empty_ray8(tmin, tmax),
            ng: [[0.0; LANES]; 3],
            u: [0.0; LANES],
            v: [0.0; LANES],
            prim_id: [none; LANES],
            geom_id: [none; LANES],
            inst_id: [none; LANES],
            inst_prim_id: [none; LANES],
        };
        let valid = fill_ray8(&mut mem.ray, rays, active);
        (mem, valid)
    }

    /// Lane `i`'s hit after the query, if any.
    #[inline]
    pub(super) fn hit(&self, i: usize) -> Option<Hit> {
        if self.geom_id[i] == ffi::INVALID_GEOMETRY_ID {
            return None;
        }
        Some(Hit {
            t: self.ray.tfar[i],
            geom: self.geom_id[i],
            prim: self.prim_id[i],
            u: self.u[i],
            v: self.v[i],
            ng: Vec3::new(self.ng[0][i], self.ng[1][i], self.ng[2][i]),
        })
    }
}

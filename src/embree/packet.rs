//! Packets of 8 rays (`rtcIntersect8`): coherent rays, such as the samples of one pixel, are
//! traced together through the BVH, which costs Embree less per ray than one call per ray.

use super::ffi;
use super::scene::{accepts_component, accepts_interval};
pub use crate::geometry::LANES;
use crate::geometry::{Hit, RayPacket};
use glam::Vec3;

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

/// The ray block of a query for the `active` lanes of `rays`, lane i on `[tmin, tmax[i]]`, and
/// its valid mask: the active lanes whose ray Embree accepts ([`accepts`]); a lane left out holds a
/// harmless ray (origin 0, direction +z: Embree does not read it). Both blocks are
/// structure-of-arrays, so this is six selects of eight floats, built where it is returned
/// (a query's memory made apart and then moved cost a copy of its 672 bytes).
///
/// [`accepts`]: super::scene::accepts
#[inline(always)]
pub(super) fn ray8(rays: &RayPacket, active: [bool; LANES], tmin: f32, tmax: [f32; LANES]) -> (ffi::RTCRay8, Valid8) {
    let valid = valid8(rays, active, tmin, tmax);
    let lanes = |x: &[f32; LANES], idle: f32| -> [f32; LANES] {
        std::array::from_fn(|i| if valid.0[i] != 0 { x[i] } else { idle })
    };
    let ray = ffi::RTCRay8 {
        org_x: lanes(&rays.o[0], 0.0),
        org_y: lanes(&rays.o[1], 0.0),
        org_z: lanes(&rays.o[2], 0.0),
        tnear: [tmin; LANES],
        dir_x: lanes(&rays.d[0], 0.0),
        dir_y: lanes(&rays.d[1], 0.0),
        dir_z: lanes(&rays.d[2], 1.0),
        time: [0.0; LANES],
        tfar: tmax,
        // A mask of 0 would hit nothing; every geometry keeps Embree's default mask.
        mask: [u32::MAX; LANES],
        id: [0; LANES],
        flags: [0; LANES],
    };
    (ray, valid)
}

/// The valid mask of a query: the `active` lanes whose ray Embree accepts, [`accepts`] tested
/// on every lane at once.
///
/// [`accepts`]: super::scene::accepts
#[inline(always)]
fn valid8(rays: &RayPacket, active: [bool; LANES], tmin: f32, tmax: [f32; LANES]) -> Valid8 {
    let within = accepts_component;
    Valid8(std::array::from_fn(|i| {
        let ok = active[i]
            & accepts_interval(tmin, tmax[i])
            & within(rays.o[0][i])
            & within(rays.o[1][i])
            & within(rays.o[2][i])
            & within(rays.d[0][i])
            & within(rays.d[1][i])
            & within(rays.d[2][i]);
        -(ok as i32)
    }))
}

impl RayHit8Mem {
    /// A closest-hit query for the `active` lanes of `rays` on `[tmin, tmax]` ([`ray8`]: lanes
    /// Embree would refuse are left out), with no hit yet.
    #[inline(always)]
    pub(super) fn new(rays: &RayPacket, active: [bool; LANES], tmin: f32, tmax: f32) -> (RayHit8Mem, Valid8) {
        let none = ffi::INVALID_GEOMETRY_ID;
        let (ray, valid) = ray8(rays, active, tmin, [tmax; LANES]);
        let mem = RayHit8Mem {
            ray,
            ng: [[0.0; LANES]; 3],
            u: [0.0; LANES],
            v: [0.0; LANES],
            prim_id: [none; LANES],
            geom_id: [none; LANES],
            inst_id: [none; LANES],
            inst_prim_id: [none; LANES],
        };
        (mem, valid)
    }

    /// Lane `i`'s hit after the query, if any.
    #[inline]
    pub(super) fn hit(&self, i: usize) -> Option<Hit> {
        if self.geom_id[i] == ffi::INVALID_GEOMETRY_ID {
            return None;
        }
        // A hit inside an instance is named by the instance (see `RayHitMem::hit`).
        let inst = self.inst_id[i];
        Some(Hit {
            t: self.ray.tfar[i],
            geom: if inst != ffi::INVALID_GEOMETRY_ID { inst } else { self.geom_id[i] },
            prim: self.prim_id[i],
            u: self.u[i],
            v: self.v[i],
            ng: Vec3::new(self.ng[0][i], self.ng[1][i], self.ng[2][i]),
        })
    }
}

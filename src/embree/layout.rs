//! The ray-hit memory layout of the *running* Embree library, decided from its version.
//!
//! Bindings fix `RTCRayHit` at compile time, but the library writes hits as its own headers
//! said: Embree 4.3+ built with instance arrays (the default) adds `instPrimID` to `RTCHit`,
//! making `RTCRayHit` 96 bytes where the 4.2 headers of `embree4-sys` say 80. Handing such a
//! library 80 bytes lets it write past them on every hit. So the layer reads the version when a
//! device is created, picks the layout from the table below, and refuses versions it does not
//! know. Queries always pass a [`RayHitMem`] (96 bytes: room for either layout), and
//! user-geometry callbacks write exactly the hit fields of the chosen layout.

use super::error::EmbreeError;
use super::ffi::{self, RTCRay};
use crate::geometry::{Hit, Ray};
use glam::Vec3;
use std::fmt;

/// An Embree library version, as the running library reports it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct EmbreeVersion {
    pub major: u32,
    pub minor: u32,
    pub patch: u32,
}

impl EmbreeVersion {
    pub const fn new(major: u32, minor: u32, patch: u32) -> Self {
        EmbreeVersion { major, minor, patch }
    }
}

impl fmt::Display for EmbreeVersion {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}.{}.{}", self.major, self.minor, self.patch)
    }
}

/// How a library lays out `RTCRayHit` (and the hit part of `RTCRayHitN` in callbacks). The ray
/// part is the same 12 words in every version.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RayHitLayout {
    /// Hit = `Ng_x, Ng_y, Ng_z, u, v, primID, geomID, instID[1]`: an 80-byte `RTCRayHit`.
    /// Embree 3 and Embree 4.0–4.2.
    NoInstPrimId,
    /// The same plus `instPrimID[1]`: a 96-byte `RTCRayHit` (16-byte aligned). Embree 4.3 and
    /// 4.4, built with instance arrays (their default).
    WithInstPrimId,
}

/// The versions whose layout is known: (major, first minor, last minor, layout).
const KNOWN: &[(u32, u32, u32, RayHitLayout)] = &[
    (3, 0, 13, RayHitLayout::NoInstPrimId),
    (4, 0, 2, RayHitLayout::NoInstPrimId),
    (4, 3, 4, RayHitLayout::WithInstPrimId),
];

impl RayHitLayout {
    /// The layout of a library of `version`, used through bindings for Embree `backend_major`;
    /// an error for a version not in the table (or of another major version) rather than a
    /// guess.
    pub fn for_library(backend_major: u32, version: EmbreeVersion) -> Result<RayHitLayout, EmbreeError> {
        KNOWN
            .iter()
            .find(|&&(major, lo, hi, _)| {
                major == backend_major && version.major == major && (lo..=hi).contains(&version.minor)
            })
            .map(|&(.., layout)| layout)
            .ok_or_else(|| EmbreeError::UnsupportedVersion {
                version: version.to_string(),
                backend: format!("embree{backend_major}"),
                known: Self::known_versions(backend_major),
            })
    }

    /// The versions this build can use with bindings for `backend_major`, e.g. "4.0–4.4".
    pub fn known_versions(backend_major: u32) -> String {
        let minors: Vec<(u32, u32)> =
            KNOWN.iter().filter(|k| k.0 == backend_major).map(|&(_, lo, hi, _)| (lo, hi)).collect();
        match (minors.iter().map(|m| m.0).min(), minors.iter().map(|m| m.1).max()) {
            (Some(lo), Some(hi)) => format!("{backend_major}.{lo}–{backend_major}.{hi}"),
            _ => "none".to_string(),
        }
    }

    /// `sizeof(RTCRayHit)` in this layout: 80 or 96 bytes.
    pub const fn ray_hit_bytes(self) -> usize {
        match self {
            RayHitLayout::NoInstPrimId => 80,
            RayHitLayout::WithInstPrimId => 96,
        }
    }

    /// Number of 32-bit hit fields (`Ng` … `instID`, and `instPrimID` if present): 8 or 9.
    pub const fn hit_words(self) -> usize {
        match self {
            RayHitLayout::NoInstPrimId => 8,
            RayHitLayout::WithInstPrimId => 9,
        }
    }

    pub const fn has_inst_prim_id(self) -> bool {
        matches!(self, RayHitLayout::WithInstPrimId)
    }
}

impl fmt::Display for RayHitLayout {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RayHitLayout::NoInstPrimId => write!(f, "80-byte RTCRayHit"),
            RayHitLayout::WithInstPrimId => write!(f, "96-byte RTCRayHit with instPrimID"),
        }
    }
}

/// Word number of `RTCRay::tfar` and of the first hit word in ray-hit memory (and, times N, in
/// `RTCRayHitN` blocks).
pub(super) const TFAR_WORD: usize = 8;
pub(super) const HIT_WORD: usize = 12;

/// The hit part of [`RayHitMem`]: the fields of both layouts, padded to 48 bytes.
#[repr(C)]
#[derive(Clone, Copy)]
pub(super) struct HitMem {
    pub(super) ng: [f32; 3],
    pub(super) u: f32,
    pub(super) v: f32,
    pub(super) prim_id: u32,
    pub(super) geom_id: u32,
    pub(super) inst_id: u32,
    /// Only in [`RayHitLayout::WithInstPrimId`]; padding otherwise.
    pub(super) inst_prim_id: u32,
    pub(super) _pad: [u32; 3],
}

/// Ray-hit memory handed to `rtcIntersect1`: the ray, then the hit, 16-byte aligned and as
/// large as the largest known `RTCRayHit` (96 bytes), so it is valid for either layout.
#[repr(C, align(16))]
#[derive(Clone, Copy)]
pub(super) struct RayHitMem {
    pub(super) ray: RTCRay,
    pub(super) hit: HitMem,
}

const _: () = assert!(size_of::<RayHitMem>() == RayHitLayout::WithInstPrimId.ray_hit_bytes());
const _: () = assert!(std::mem::offset_of!(RayHitMem, hit) == HIT_WORD * 4);
const _: () = assert!(std::mem::offset_of!(RTCRay, tfar) == TFAR_WORD * 4);
const _: () = assert!(std::mem::offset_of!(HitMem, inst_prim_id) == 8 * 4);

#[inline]
pub(super) fn rtc_ray(ray: &Ray, tmin: f32, tmax: f32) -> RTCRay {
    RTCRay {
        org_x: ray.o.x,
        org_y: ray.o.y,
        org_z: ray.o.z,
        tnear: tmin,
        dir_x: ray.d.x,
        dir_y: ray.d.y,
        dir_z: ray.d.z,
        time: 0.0,
        tfar: tmax,
        // A mask of 0 would hit nothing; every geometry keeps Embree's default mask.
        mask: u32::MAX,
        id: 0,
        flags: 0,
    }
}

impl RayHitMem {
    /// A query for `ray` on `[tmin, tmax]` with no hit yet (ids invalid, as Embree requires).
    #[inline]
    pub(super) fn new(ray: &Ray, tmin: f32, tmax: f32) -> RayHitMem {
        let none = ffi::INVALID_GEOMETRY_ID;
        RayHitMem {
            ray: rtc_ray(ray, tmin, tmax),
            hit: HitMem {
                ng: [0.0; 3],
                u: 0.0,
                v: 0.0,
                prim_id: none,
                geom_id: none,
                inst_id: none,
                inst_prim_id: none,
                _pad: [0; 3],
            },
        }
    }

    /// The hit after the query, if any.
    #[inline]
    pub(super) fn hit(&self) -> Option<Hit> {
        if self.hit.geom_id == ffi::INVALID_GEOMETRY_ID {
            return None;
        }
        // A hit inside an instance is named by the instance: its geometry id in our scene.
        let inst = self.hit.inst_id;
        Some(Hit {
            t: self.ray.tfar,
            geom: if inst != ffi::INVALID_GEOMETRY_ID { inst } else { self.hit.geom_id },
            prim: self.hit.prim_id,
            u: self.hit.u,
            v: self.hit.v,
            ng: Vec3::from_array(self.hit.ng),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn layout(backend: u32, v: (u32, u32, u32)) -> Result<RayHitLayout, EmbreeError> {
        RayHitLayout::for_library(backend, EmbreeVersion::new(v.0, v.1, v.2))
    }

    #[test]
    fn embree3_libraries_have_the_80_byte_layout() {
        for v in [(3, 13, 5), (3, 13, 0), (3, 0, 0), (3, 12, 2)] {
            assert_eq!(layout(3, v).unwrap(), RayHitLayout::NoInstPrimId, "{v:?}");
        }
        assert_eq!(RayHitLayout::NoInstPrimId.ray_hit_bytes(), 80);
    }

    #[test]
    fn embree4_layout_changes_at_4_3() {
        for v in [(4, 0, 0), (4, 1, 0), (4, 2, 0)] {
            assert_eq!(layout(4, v).unwrap(), RayHitLayout::NoInstPrimId, "{v:?}");
        }
        for v in [(4, 3, 0), (4, 3, 3), (4, 4, 0)] {
            assert_eq!(layout(4, v).unwrap(), RayHitLayout::WithInstPrimId, "{v:?}");
        }
        assert_eq!(RayHitLayout::WithInstPrimId.ray_hit_bytes(), 96);
        assert_eq!(RayHitLayout::WithInstPrimId.hit_words(), RayHitLayout::NoInstPrimId.hit_words() + 1);
    }

    #[test]
    fn unknown_versions_are_refused_with_a_clear_error() {
        for (backend, v) in
            [(4, (4, 5, 0)), (4, (5, 0, 0)), (3, (3, 14, 0)), (3, (4, 4, 0)), (4, (3, 13, 5)), (4, (2, 17, 7))]
        {
            let e = layout(backend, v).unwrap_err();
            let text = e.to_string();
            let version = format!("{}.{}.{}", v.0, v.1, v.2);
            assert!(matches!(e, EmbreeError::UnsupportedVersion { .. }), "{e:?}");
            assert!(text.contains(&version) && text.contains(&format!("embree{backend}")), "{text}");
            assert!(text.contains(&RayHitLayout::known_versions(backend)), "{text}");
        }
        assert_eq!(RayHitLayout::known_versions(4), "4.0–4.4");
        assert_eq!(RayHitLayout::known_versions(3), "3.0–3.13");
        assert_eq!(RayHitLayout::known_versions(2), "none");
        assert!(layout(2, (2, 17, 7)).is_err());
    }

    #[test]
    fn ray_hit_memory_starts_empty_and_reads_back_a_hit() {
        let mut m = RayHitMem::new(&Ray::new(Vec3::ZERO, Vec3::Z), 0.5, 9.0);
        assert_eq!((m.ray.tnear, m.ray.tfar, m.ray.mask), (0.5, 9.0, u32::MAX));
        assert!(m.hit().is_none());
        m.hit.geom_id = 2;
        m.hit.prim_id = 7;
        m.ray.tfar = 3.0;
        let h = m.hit().unwrap();
        assert_eq!((h.geom, h.prim, h.t), (2, 7, 3.0));
    }
}

//! Guard-word probes: a query run exactly as [`Scene::intersect`] / [`Scene::occluded`] run it
//! (same FFI call, same callbacks), but in memory whose words past what the layer initialises
//! are set to [`GUARD`], so a test can see every word Embree or a callback wrote there. This is
//! how `tests/abi_guard.rs` checks the ray-hit layout decided from the library's version.

use super::error::EmbreeError;
use super::ffi;
use super::layout::{HIT_WORD, RayHitLayout, RayHitMem, rtc_ray};
use super::packet::{LANES, RayHit8Mem};
use super::scene::Scene;
use crate::geometry::{Hit, Ray, RayPacket};

/// The value of every guard word before the query.
pub const GUARD: u32 = 0xA5A5_5A5A;
/// Words of probe memory: the 96-byte ray-hit memory and 32 bytes beyond it.
pub const PROBE_WORDS: usize = 32;

/// The memory of one probed query after the call.
#[derive(Clone, Debug, PartialEq)]
pub struct GuardProbe {
    /// The library's ray-hit layout, as decided at device creation.
    pub layout: RayHitLayout,
    /// Bytes the layer initialised before the call: the ray and the 8 hit words common to all
    /// layouts (80) for a closest-hit query, the ray (48) for an occlusion query. Every later
    /// word started as [`GUARD`].
    pub initialised: usize,
    /// All words after the call.
    pub words: [u32; PROBE_WORDS],
}

impl GuardProbe {
    /// Indices of words past the initialised bytes that the query changed.
    pub fn written_past_initialised(&self) -> Vec<usize> {
        (self.initialised / 4..PROBE_WORDS).filter(|&i| self.words[i] != GUARD).collect()
    }
}

#[repr(C, align(16))]
struct ProbeMem([u32; PROBE_WORDS]);

impl Scene {
    /// [`Scene::intersect`] in guarded memory: the hit and what the query wrote.
    pub fn probe_intersect(&self, ray: &Ray, tmin: f32, tmax: f32) -> Result<(Option<Hit>, GuardProbe), EmbreeError> {
        const COMMON_BYTES: usize = (HIT_WORD + 8) * 4;
        let mut mem = ProbeMem([GUARD; PROBE_WORDS]);
        let init = RayHitMem::new(ray, tmin, tmax);
        // SAFETY: RayHitMem is plain 32-bit words (repr C, no padding between fields); its
        // first COMMON_BYTES are the ray and the common hit fields.
        let init_words =
            unsafe { std::slice::from_raw_parts(&init as *const RayHitMem as *const u32, COMMON_BYTES / 4) };
        mem.0[..COMMON_BYTES / 4].copy_from_slice(init_words);
        let p = mem.0.as_mut_ptr().cast::<RayHitMem>();
        // SAFETY: committed scene; `p` is 16-byte aligned and points to 128 bytes, more than
        // any RTCRayHit; the fields Embree reads (ray, geomID, instID) are initialised, the
        // rest of the hit is output.
        unsafe { ffi::intersect1(self.scene.raw, p) };
        self.scene.failure.check()?;
        // SAFETY: `p` is aligned and its 96 bytes are initialised words.
        let hit = unsafe { (*p).hit() };
        Ok((hit, GuardProbe { layout: self.scene.layout, initialised: COMMON_BYTES, words: mem.0 }))
    }

    /// [`Scene::occluded`] in guarded memory: the answer and what the query wrote.
    pub fn probe_occluded(&self, ray: &Ray, tmin: f32, tmax: f32) -> Result<(bool, GuardProbe), EmbreeError> {
        let mut mem = ProbeMem([GUARD; PROBE_WORDS]);
        let r = rtc_ray(ray, tmin, tmax);
        let p = mem.0.as_mut_ptr().cast::<ffi::RTCRay>();
        // SAFETY: `p` is 16-byte aligned with room for an RTCRay.
        unsafe { p.write(r) };
        // SAFETY: committed scene; `p` is an initialised RTCRay.
        unsafe { ffi::occluded1(self.scene.raw, p) };
        self.scene.failure.check()?;
        // SAFETY: as above.
        let occluded = unsafe { (*p).tfar } == f32::NEG_INFINITY;
        Ok((occluded, GuardProbe { layout: self.scene.layout, initialised: size_of::<ffi::RTCRay>(), words: mem.0 }))
    }
}

/// Words of packet probe memory: the 672-byte 8-ray ray-hit memory and 64 bytes beyond it.
pub const PACKET_PROBE_WORDS: usize = 168 + 16;
/// Words of an 8-ray packet every layout has: the ray block (12 × 8) and the common hit
/// block (8 × 8). Embree 4.3+ adds the 8 `instPrimID` words after it.
pub const PACKET_COMMON_WORDS: usize = 160;

/// The memory of one probed packet query ([`Scene::intersect8_deferred`]) after the call.
#[derive(Clone, Debug, PartialEq)]
pub struct PacketProbe {
    /// The library's ray-hit layout, as decided at device creation.
    pub layout: RayHitLayout,
    /// All words after the call; those from [`PACKET_COMMON_WORDS`] on started as [`GUARD`].
    pub words: Vec<u32>,
}

impl PacketProbe {
    /// Indices of words past the common part that the query changed.
    pub fn written_past_common(&self) -> Vec<usize> {
        (PACKET_COMMON_WORDS..self.words.len()).filter(|&i| self.words[i] != GUARD).collect()
    }
}

#[repr(C, align(32))]
struct PacketProbeMem([u32; PACKET_PROBE_WORDS]);

impl Scene {
    /// [`Scene::intersect8_deferred`] in guarded memory: the hits and what the query wrote.
    pub fn probe_intersect8(
        &self,
        rays: &RayPacket,
        active: [bool; LANES],
        tmin: f32,
        tmax: f32,
    ) -> Result<([Option<Hit>; LANES], PacketProbe), EmbreeError> {
        let mut mem = PacketProbeMem([GUARD; PACKET_PROBE_WORDS]);
        let (init, valid) = RayHit8Mem::new(rays, active, tmin, tmax);
        // SAFETY: RayHit8Mem is plain 32-bit words (repr C, no padding between fields); its
        // first PACKET_COMMON_WORDS words are the ray block and the common hit block.
        let init_words =
            unsafe { std::slice::from_raw_parts(&init as *const RayHit8Mem as *const u32, PACKET_COMMON_WORDS) };
        mem.0[..PACKET_COMMON_WORDS].copy_from_slice(init_words);
        let p = mem.0.as_mut_ptr().cast::<RayHit8Mem>();
        // SAFETY: committed scene; `p` is 32-byte aligned and points to 736 bytes, more than
        // any RTCRayHit8; the fields Embree reads (rays, geomID, instID) are initialised, the
        // rest of the hit is output; `valid` is a 32-byte aligned mask.
        unsafe { ffi::intersect8(&valid, self.scene.raw, p, rays.coherent) };
        self.scene.failure.check()?;
        // SAFETY: `p` is aligned and its 672 bytes are initialised words.
        let after = unsafe { &*p };
        let hits = std::array::from_fn(|i| if active[i] { after.hit(i) } else { None });
        Ok((hits, PacketProbe { layout: self.scene.layout, words: mem.0.to_vec() }))
    }
}

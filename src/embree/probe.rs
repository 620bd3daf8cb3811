//! Guard-word probes: a query run exactly as [`Scene::intersect`] / [`Scene::occluded`] run it
//! (same FFI call, same callbacks), but in memory whose words past what the layer initialises
//! are set to [`GUARD`], so a test can see every word Embree or a callback wrote there. This is
//! how `tests/abi_guard.rs` checks the ray-hit layout decided from the library's version.

use super::error::EmbreeError;
use super::ffi;
use super::layout::{HIT_WORD, RayHitLayout, RayHitMem, rtc_ray};
use super::scene::Scene;
use crate::geometry::{Hit, Ray};

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
        let init_words = unsafe { std::slice::from_raw_parts(&init as *const RayHitMem as *const u32, COMMON_BYTES / 4) };
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

//! User-geometry callbacks: Embree calls these with raw pointers; they call the Rust
//! [`Shape`] methods, never unwind into C, and record panics for the scene to report.

use super::error::EmbreeError;
use super::ffi;
use super::layout::{HIT_WORD, RayHitLayout, TFAR_WORD};
use crate::geometry::{Ray, Shape, TriMesh};
use glam::Vec3;
use std::any::Any;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

/// Records the first panic of any callback of a scene. Sticky: once set, every later query on
/// the scene reports it, because Embree was handed a made-up answer.
#[derive(Default)]
pub(super) struct CallbackFailure {
    flag: AtomicBool,
    message: Mutex<Option<String>>,
}

impl CallbackFailure {
    fn record(&self, what: &str, payload: Box<dyn Any + Send>) {
        let text = payload
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "non-string panic payload".to_string());
        let mut m = self.message.lock().unwrap_or_else(|e| e.into_inner());
        if m.is_none() {
            *m = Some(format!("{what} callback: {text}"));
        }
        self.flag.store(true, Ordering::Release);
    }

    /// After every query: one load on the fast path; the error is built out of line.
    #[inline(always)]
    pub(super) fn check(&self) -> Result<(), EmbreeError> {
        if !self.flag.load(Ordering::Acquire) {
            return Ok(());
        }
        Err(self.error())
    }

    #[cold]
    #[inline(never)]
    fn error(&self) -> EmbreeError {
        let m = self.message.lock().unwrap_or_else(|e| e.into_inner());
        EmbreeError::CallbackPanic(m.clone().unwrap_or_default())
    }
}

/// What Embree's user pointer points at: boxed and owned by the scene, so it neither moves nor
/// dies while Embree may call back.
pub(super) struct UserData<S> {
    pub(super) shapes: Arc<[S]>,
    pub(super) failure: Arc<CallbackFailure>,
    /// The running library's ray-hit layout: which hit words a hit writes.
    pub(super) layout: RayHitLayout,
}

/// Index of 32-bit word `k` of lane `i` in an `RTCRayN`/`RTCRayHitN` block of width `n`.
#[inline]
fn word(k: usize, i: usize, n: usize) -> usize {
    k * n + i
}

// Word numbers of RTCRayN (12 words) followed by RTCHitN: Ng_x, Ng_y, Ng_z, u, v, primID,
// geomID, instID[0], and instPrimID[0] in the layout that has it.
const ORG: usize = 0;
const TNEAR: usize = 3;
const DIR: usize = 4;
const TFAR: usize = TFAR_WORD;
const HIT: usize = HIT_WORD;

/// Reads lane `i` of a ray block.
///
/// # Safety
/// `p` points to an `RTCRayN` block of width `n` and `i < n`.
#[inline]
unsafe fn read_ray(p: *const f32, i: usize, n: usize) -> (Ray, f32, f32) {
    // SAFETY: the caller guarantees the block holds 12·n words and i < n.
    unsafe {
        let f = |k: usize| *p.add(word(k, i, n));
        let ray = Ray::new(Vec3::new(f(ORG), f(ORG + 1), f(ORG + 2)), Vec3::new(f(DIR), f(DIR + 1), f(DIR + 2)));
        (ray, f(TNEAR), f(TFAR))
    }
}

pub(super) unsafe extern "C" fn bounds<S: Shape>(args: *const ffi::RTCBoundsFunctionArguments) {
    // SAFETY: Embree passes valid arguments whose user pointer is the `UserData<S>` this
    // function was registered with (see `SceneBuilder::add_shapes`).
    let args = unsafe { &*args };
    let data = unsafe { &*(args.geometryUserPtr as *const UserData<S>) };
    let b = catch_unwind(AssertUnwindSafe(|| data.shapes[args.primID as usize].bounds()));
    let b = match b {
        Ok(b) if b.is_valid() => b,
        Ok(_) => crate::geometry::Aabb::new(Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        Err(p) => {
            data.failure.record("bounds", p);
            crate::geometry::Aabb::new(Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY))
        }
    };
    // SAFETY: `bounds_o` points to one writable RTCBounds. An inverted (invalid) box makes
    // Embree skip the primitive.
    unsafe {
        let o = &mut *args.bounds_o;
        o.lower_x = b.min.x;
        o.lower_y = b.min.y;
        o.lower_z = b.min.z;
        o.upper_x = b.max.x;
        o.upper_y = b.max.y;
        o.upper_z = b.max.z;
    }
}

pub(super) unsafe extern "C" fn intersect<S: Shape>(args: *const ffi::RTCIntersectFunctionNArguments) {
    // SAFETY: Embree passes valid arguments: `valid` has N entries, `rayhit` is an RTCRayHitN
    // of width N in the library's layout, and the user pointer is our `UserData<S>`.
    let args = unsafe { &*args };
    let data = unsafe { &*(args.geometryUserPtr as *const UserData<S>) };
    let n = args.N as usize;
    let prim = args.primID;
    let Some(shape) = data.shapes.get(prim as usize) else { return };
    let layout = data.layout;
    // SAFETY: these are intersect-callback arguments and `layout` is the library's.
    let (inst, inst_prim) = unsafe { ffi::hit_instance(args, layout) };
    let p = args.rayhit as *mut f32;
    let r = catch_unwind(AssertUnwindSafe(|| {
        for i in 0..n {
            // SAFETY: `valid` has n entries. Only lanes marked -1 are active.
            if unsafe { *args.valid.add(i) } != -1 {
                continue;
            }
            // SAFETY: `p` is an RTCRayHitN of width n (12·n ray words, then the hit words).
            let (ray, tnear, tfar) = unsafe { read_ray(p, i, n) };
            if let Some(h) = shape.intersect(&ray, tnear, tfar) {
                // SAFETY: as above; hit words start at 12·n, and the block has the
                // `layout.hit_words()` hit words written here, no more.
                unsafe {
                    *p.add(word(TFAR, i, n)) = h.t;
                    *p.add(word(HIT, i, n)) = h.ng.x;
                    *p.add(word(HIT + 1, i, n)) = h.ng.y;
                    *p.add(word(HIT + 2, i, n)) = h.ng.z;
                    *p.add(word(HIT + 3, i, n)) = h.u;
                    *p.add(word(HIT + 4, i, n)) = h.v;
                    let q = p as *mut u32;
                    *q.add(word(HIT + 5, i, n)) = prim;
                    *q.add(word(HIT + 6, i, n)) = args.geomID;
                    *q.add(word(HIT + 7, i, n)) = inst;
                    if layout.has_inst_prim_id() {
                        *q.add(word(HIT + 8, i, n)) = inst_prim;
                    }
                }
            } else if ffi::MISS_CLEARS_VALID {
                // SAFETY: `valid` has n entries; Embree 4 reads a lane left at -1 as a hit.
                unsafe { *args.valid.add(i) = 0 };
            }
        }
    }));
    if let Err(payload) = r {
        data.failure.record("intersect", payload);
        // SAFETY: `valid` has n entries; the query is reported as failed anyway.
        unsafe { report_misses(args.valid, n) };
    }
}

pub(super) unsafe extern "C" fn occluded<S: Shape>(args: *const ffi::RTCOccludedFunctionNArguments) {
    // SAFETY: Embree passes valid arguments: `valid` has N entries, `ray` is an RTCRayN of
    // width N, and the user pointer is our `UserData<S>`.
    let args = unsafe { &*args };
    let data = unsafe { &*(args.geometryUserPtr as *const UserData<S>) };
    let n = args.N as usize;
    let Some(shape) = data.shapes.get(args.primID as usize) else { return };
    let p = args.ray as *mut f32;
    let r = catch_unwind(AssertUnwindSafe(|| {
        for i in 0..n {
            // SAFETY: `valid` has n entries.
            if unsafe { *args.valid.add(i) } != -1 {
                continue;
            }
            // SAFETY: `p` is an RTCRayN of width n.
            let (ray, tnear, tfar) = unsafe { read_ray(p, i, n) };
            if shape.occludes(&ray, tnear, tfar) {
                // SAFETY: as above; tfar = -inf is Embree's "occluded" mark.
                unsafe { *p.add(word(TFAR, i, n)) = f32::NEG_INFINITY };
            } else if ffi::MISS_CLEARS_VALID {
                // SAFETY: `valid` has n entries; Embree 4 reads a lane left at -1 as occluded.
                unsafe { *args.valid.add(i) = 0 };
            }
        }
    }));
    if let Err(payload) = r {
        data.failure.record("occluded", payload);
        // SAFETY: `valid` has n entries.
        unsafe { report_misses(args.valid, n) };
    }
}

/// After a panic, reports every lane as a miss to a library that reads `valid` (Embree 4).
///
/// # Safety
/// `valid` points to `n` writable ints.
unsafe fn report_misses(valid: *mut std::ffi::c_int, n: usize) {
    if ffi::MISS_CLEARS_VALID {
        for i in 0..n {
            // SAFETY: per the contract.
            unsafe { *valid.add(i) = 0 };
        }
    }
}

/// What a cut-out mesh's user pointer points at (see `SceneBuilder::add_mesh`).
pub(super) struct CutoutData {
    pub(super) mesh: Arc<TriMesh>,
    pub(super) failure: Arc<CallbackFailure>,
}

/// Embree's intersect and occluded filter for a mesh with holes: a candidate hit where the
/// mesh's [`crate::geometry::Cutout`] says the surface is not there is rejected (`valid`
/// cleared), and Embree goes on looking behind it.
pub(super) unsafe extern "C" fn cutout_filter(args: *const ffi::RTCFilterFunctionNArguments) {
    // SAFETY: Embree passes valid arguments: `valid` has N entries, `ray` is an RTCRayN and
    // `hit` an RTCHitN of width N, and the user pointer is the `CutoutData` this function was
    // registered with.
    let args = unsafe { &*args };
    let data = unsafe { &*(args.geometryUserPtr as *const CutoutData) };
    let n = args.N as usize;
    let (ray, hit) = (args.ray as *const f32, args.hit as *const f32);
    let Some(cutout) = data.mesh.cutout.as_deref() else { return };
    let r = catch_unwind(AssertUnwindSafe(|| {
        for i in 0..n {
            // SAFETY: `valid` has n entries; only lanes marked -1 are candidates.
            if unsafe { *args.valid.add(i) } != -1 {
                continue;
            }
            // SAFETY: `ray` is an RTCRayN of width n (12·n words); `hit` an RTCHitN of width n
            // whose words 3, 4 and 5 are u, v and primID.
            let (r, u, v, prim) = unsafe {
                let (r, _, _) = read_ray(ray, i, n);
                (r, *hit.add(word(3, i, n)), *hit.add(word(4, i, n)), *(hit as *const u32).add(word(5, i, n)))
            };
            if (prim as usize) < data.mesh.indices.len() && !cutout.keeps(&data.mesh, prim, u, v, &r) {
                // SAFETY: `valid` has n entries; 0 rejects the hit.
                unsafe { *args.valid.add(i) = 0 };
            }
        }
    }));
    if let Err(payload) = r {
        // The hits stand as Embree found them; the query is reported as failed anyway.
        data.failure.record("cut-out filter", payload);
    }
}

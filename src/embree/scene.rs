use super::device::Device;
use super::error::EmbreeError;
use super::sys;
use super::user::{self, CallbackFailure, UserData};
use crate::geometry::{Aabb, Hit, Ray, Shape};
use glam::Vec3;
use std::any::Any;
use std::sync::Arc;

/// BVH build quality (`RTC_BUILD_QUALITY_*`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum BuildQuality {
    Low,
    #[default]
    Medium,
    High,
}

/// How a scene is built.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BuildOptions {
    pub quality: BuildQuality,
    /// `RTC_SCENE_FLAG_ROBUST`: avoid optimisations that reduce arithmetic accuracy.
    pub robust: bool,
    /// `RTC_SCENE_FLAG_COMPACT`: a smaller BVH at some tracing cost.
    pub compact: bool,
}

/// The owned scene handle plus everything Embree may call back into. Dropped as one: the
/// scene is released before the user data it points to.
struct RawScene {
    raw: sys::RTCScene,
    failure: Arc<CallbackFailure>,
    _user_data: Vec<Box<dyn Any + Send + Sync>>,
    device: Device,
}

impl Drop for RawScene {
    fn drop(&mut self) {
        // SAFETY: `raw` is a scene we hold the only reference to; after this no callback can
        // run, and only then are the user data (fields) dropped.
        unsafe { sys::rtcReleaseScene(self.raw) };
    }
}

/// An owned geometry handle, released on drop (the scene keeps its own reference once
/// attached).
struct GeomHandle(sys::RTCGeometry);

impl Drop for GeomHandle {
    fn drop(&mut self) {
        // SAFETY: we own one reference to this valid geometry.
        unsafe { sys::rtcReleaseGeometry(self.0) };
    }
}

/// A scene being assembled. Geometry ids are given in the order geometries are added, from 0.
pub struct SceneBuilder {
    scene: RawScene,
    next_id: u32,
}

// SAFETY: the builder owns its scene exclusively (no shared references exist before commit),
// and Embree scenes may be modified from any one thread at a time.
unsafe impl Send for SceneBuilder {}

/// A committed scene: immutable, answers ray queries.
pub struct Scene {
    scene: RawScene,
    bounds: Aabb,
}

// SAFETY: Embree's API documentation guarantees that rtcIntersect*/rtcOccluded* on a committed
// scene may be called from multiple threads concurrently, as long as the scene is not modified
// or committed meanwhile. `Scene` exposes no method that modifies or commits it; the user data
// it keeps is `Send + Sync` and only read by callbacks; the failure record is synchronised.
unsafe impl Send for Scene {}
// SAFETY: see `Send` above.
unsafe impl Sync for Scene {}

impl SceneBuilder {
    pub fn new(device: &Device, options: BuildOptions) -> Result<SceneBuilder, EmbreeError> {
        // SAFETY: the device handle is valid for the device's lifetime, which the scene extends
        // by holding a clone.
        let raw = unsafe { sys::rtcNewScene(device.inner.raw) };
        device.take_error()?;
        if raw.is_null() {
            return Err(EmbreeError::InvalidInput("rtcNewScene returned NULL".into()));
        }
        let scene = RawScene {
            raw,
            failure: Arc::new(CallbackFailure::default()),
            _user_data: Vec::new(),
            device: device.clone(),
        };
        let quality = match options.quality {
            BuildQuality::Low => sys::RTC_BUILD_QUALITY_LOW,
            BuildQuality::Medium => sys::RTC_BUILD_QUALITY_MEDIUM,
            BuildQuality::High => sys::RTC_BUILD_QUALITY_HIGH,
        };
        let mut flags = sys::RTC_SCENE_FLAG_NONE;
        if options.robust {
            flags |= sys::RTC_SCENE_FLAG_ROBUST;
        }
        if options.compact {
            flags |= sys::RTC_SCENE_FLAG_COMPACT;
        }
        // SAFETY: `raw` is a valid, uncommitted scene; quality and flags are header constants.
        unsafe {
            sys::rtcSetSceneBuildQuality(raw, quality);
            sys::rtcSetSceneFlags(raw, flags);
        }
        device.take_error()?;
        Ok(SceneBuilder { scene, next_id: 0 })
    }

    fn device(&self) -> &Device {
        &self.scene.device
    }

    fn new_geometry(&self, kind: sys::RTCGeometryType) -> Result<GeomHandle, EmbreeError> {
        // SAFETY: valid device; `kind` is a header constant.
        let g = unsafe { sys::rtcNewGeometry(self.device().inner.raw, kind) };
        self.device().take_error()?;
        if g.is_null() {
            return Err(EmbreeError::InvalidInput("rtcNewGeometry returned NULL".into()));
        }
        Ok(GeomHandle(g))
    }

    /// Commits `g` and attaches it under the next id.
    fn attach(&mut self, g: GeomHandle) -> Result<u32, EmbreeError> {
        let id = self.next_id;
        // SAFETY: `g` is a valid geometry with all its buffers/callbacks set; the scene takes
        // its own reference, ours is released when `g` drops.
        unsafe {
            sys::rtcCommitGeometry(g.0);
            sys::rtcAttachGeometryByID(self.scene.raw, g.0, id);
        }
        self.device().take_error()?;
        self.next_id += 1;
        Ok(id)
    }

    /// Adds a triangle mesh; returns its geometry id. Vertices and indices are copied into
    /// buffers Embree allocates (and pads for its 16-byte loads).
    pub fn add_triangles(&mut self, vertices: &[Vec3], indices: &[[u32; 3]]) -> Result<u32, EmbreeError> {
        if indices.is_empty() {
            return Err(EmbreeError::InvalidInput("a triangle mesh needs at least one triangle".into()));
        }
        if let Some((t, i)) = indices
            .iter()
            .enumerate()
            .find_map(|(t, idx)| idx.iter().find(|&&i| i as usize >= vertices.len()).map(|&i| (t, i)))
        {
            return Err(EmbreeError::InvalidInput(format!(
                "triangle {t} uses vertex {i}, but there are {} vertices",
                vertices.len()
            )));
        }
        let g = self.new_geometry(sys::RTC_GEOMETRY_TYPE_TRIANGLE)?;
        // SAFETY: `g` is a valid triangle geometry; Embree allocates `vertices.len()` items of
        // 12 bytes (plus padding) and returns a pointer to them, or NULL with an error.
        let vb = unsafe {
            sys::rtcSetNewGeometryBuffer(g.0, sys::RTC_BUFFER_TYPE_VERTEX, 0, sys::RTC_FORMAT_FLOAT3, 12, vertices.len())
        } as *mut f32;
        self.device().take_error()?;
        if vb.is_null() {
            return Err(EmbreeError::InvalidInput("Embree could not allocate the vertex buffer".into()));
        }
        // SAFETY: as above, for the index buffer of `indices.len()` UINT3 items.
        let ib = unsafe {
            sys::rtcSetNewGeometryBuffer(g.0, sys::RTC_BUFFER_TYPE_INDEX, 0, sys::RTC_FORMAT_UINT3, 12, indices.len())
        } as *mut u32;
        self.device().take_error()?;
        if ib.is_null() {
            return Err(EmbreeError::InvalidInput("Embree could not allocate the index buffer".into()));
        }
        // SAFETY: `vb` holds 3·len floats and `ib` 3·len u32s (Embree allocated them for us,
        // 4-byte aligned); the sources are plain arrays of the same element counts.
        unsafe {
            let v = std::slice::from_raw_parts_mut(vb, vertices.len() * 3);
            for (dst, p) in v.chunks_exact_mut(3).zip(vertices) {
                dst.copy_from_slice(&p.to_array());
            }
            let ix = std::slice::from_raw_parts_mut(ib, indices.len() * 3);
            for (dst, t) in ix.chunks_exact_mut(3).zip(indices) {
                dst.copy_from_slice(t);
            }
        }
        self.attach(g)
    }

    /// Adds an array of analytic shapes as one Embree user geometry (primitive id = index);
    /// returns its geometry id. Embree calls back into `S::bounds`, `S::intersect` and
    /// `S::occludes`.
    pub fn add_shapes<S: Shape>(&mut self, shapes: Arc<[S]>) -> Result<u32, EmbreeError> {
        if shapes.is_empty() {
            return Err(EmbreeError::InvalidInput("a user geometry needs at least one primitive".into()));
        }
        let count = u32::try_from(shapes.len())
            .map_err(|_| EmbreeError::InvalidInput(format!("{} primitives exceed 2^32", shapes.len())))?;
        let g = self.new_geometry(sys::RTC_GEOMETRY_TYPE_USER)?;
        let data = Box::new(UserData { shapes, failure: self.scene.failure.clone() });
        let ptr = &*data as *const UserData<S> as *mut std::ffi::c_void;
        // SAFETY: `g` is a valid user geometry. `ptr` points into a box the scene owns until
        // after it is released (RawScene field order), so it is stable and outlives every
        // callback. The callbacks are instantiated for exactly this `S`.
        unsafe {
            sys::rtcSetGeometryUserPrimitiveCount(g.0, count);
            sys::rtcSetGeometryUserData(g.0, ptr);
            sys::rtcSetGeometryBoundsFunction(g.0, Some(user::bounds::<S>), std::ptr::null_mut());
            sys::rtcSetGeometryIntersectFunction(g.0, Some(user::intersect::<S>));
            sys::rtcSetGeometryOccludedFunction(g.0, Some(user::occluded::<S>));
        }
        self.scene._user_data.push(data);
        self.device().take_error()?;
        self.attach(g)
    }

    /// Number of geometries added so far.
    pub fn geometry_count(&self) -> u32 {
        self.next_id
    }

    /// Builds the BVH. Errors from Embree or from a panicking bounds callback are returned.
    pub fn commit(self) -> Result<Scene, EmbreeError> {
        let scene = self.scene;
        // SAFETY: `raw` is a valid scene owned exclusively by us.
        unsafe { sys::rtcCommitScene(scene.raw) };
        scene.device.take_error()?;
        scene.failure.check()?;
        let mut b = sys::RTCBounds::default();
        // SAFETY: committed scene; `b` is a writable RTCBounds.
        unsafe { sys::rtcGetSceneBounds(scene.raw, &mut b) };
        let bounds = Aabb::new(Vec3::new(b.lower_x, b.lower_y, b.lower_z), Vec3::new(b.upper_x, b.upper_y, b.upper_z));
        Ok(Scene { scene, bounds })
    }
}

/// A fresh intersection context, as `rtcInitIntersectContext` (force-inlined in the header,
/// so bindgen cannot bind it) would make it.
#[inline]
fn context() -> sys::RTCIntersectContext {
    sys::RTCIntersectContext {
        flags: sys::RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT,
        filter: None,
        instID: [sys::RTC_INVALID_GEOMETRY_ID; 1],
    }
}

#[inline]
fn rtc_ray(ray: &Ray, tmin: f32, tmax: f32) -> sys::RTCRay {
    sys::RTCRay {
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

impl Scene {
    /// Bounds of everything in the scene, as Embree computed them.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// Closest hit with `tmin <= t <= tmax`.
    #[inline]
    pub fn intersect(&self, ray: &Ray, tmin: f32, tmax: f32) -> Result<Option<Hit>, EmbreeError> {
        let mut ctx = context();
        let mut rh = sys::RTCRayHit {
            ray: rtc_ray(ray, tmin, tmax),
            hit: sys::RTCHit {
                geomID: sys::RTC_INVALID_GEOMETRY_ID,
                primID: sys::RTC_INVALID_GEOMETRY_ID,
                instID: [sys::RTC_INVALID_GEOMETRY_ID; 1],
                ..Default::default()
            },
        };
        // SAFETY: committed scene (Scene is only made by commit); `ctx` and `rh` are valid,
        // initialised and `rh` has the 16-byte alignment the header requires (bindgen repr).
        unsafe { sys::rtcIntersect1(self.scene.raw, &mut ctx, &mut rh) };
        self.scene.failure.check()?;
        if rh.hit.geomID == sys::RTC_INVALID_GEOMETRY_ID {
            return Ok(None);
        }
        Ok(Some(Hit {
            t: rh.ray.tfar,
            geom: rh.hit.geomID,
            prim: rh.hit.primID,
            u: rh.hit.u,
            v: rh.hit.v,
            ng: Vec3::new(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z),
        }))
    }

    /// Whether anything is hit with `tmin <= t <= tmax`.
    #[inline]
    pub fn occluded(&self, ray: &Ray, tmin: f32, tmax: f32) -> Result<bool, EmbreeError> {
        let mut ctx = context();
        let mut r = rtc_ray(ray, tmin, tmax);
        // SAFETY: as in `intersect`.
        unsafe { sys::rtcOccluded1(self.scene.raw, &mut ctx, &mut r) };
        self.scene.failure.check()?;
        Ok(r.tfar == f32::NEG_INFINITY)
    }

    /// The device this scene was built on.
    pub fn device(&self) -> &Device {
        &self.scene.device
    }
}

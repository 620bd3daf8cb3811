use super::device::Device;
use super::error::EmbreeError;
use super::ffi;
use super::kernels::Kernels;
use super::layout::{RayHitLayout, RayHitMem, rtc_ray};
use super::packet::{LANES, RayHit8Mem, ray8};
use super::user::{self, CallbackFailure, CutoutData, UserData};
use crate::geometry::{Aabb, Hit, Ray, RayPacket, Shape, TriMesh};
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

impl BuildQuality {
    pub const ALL: [BuildQuality; 3] = [BuildQuality::Low, BuildQuality::Medium, BuildQuality::High];

    /// The name on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            BuildQuality::Low => "low",
            BuildQuality::Medium => "medium",
            BuildQuality::High => "high",
        }
    }
}

crate::choice::named_choice!(BuildQuality, "BVH quality");

/// How a scene is built. The default is medium quality, robust, not compact.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BuildOptions {
    pub quality: BuildQuality,
    /// `RTC_SCENE_FLAG_ROBUST`: avoid optimisations that reduce arithmetic accuracy. On by
    /// default: without it Embree 3.13 misses rays passing exactly through a shared edge of a
    /// closed mesh (a light leak; hard case `axis-parallel-rays`). Its cost is measured by
    /// `ember bench` (robust vs. non-robust strategies).
    pub robust: bool,
    /// `RTC_SCENE_FLAG_COMPACT`: a smaller BVH at some tracing cost.
    pub compact: bool,
    /// The kernel set of the device to build on (by default the widest the CPU runs): a
    /// property of the device, carried here so that the build's settings name it
    /// (`crate::accel::AccelKind::image_key`).
    pub kernels: Kernels,
}

impl Default for BuildOptions {
    fn default() -> Self {
        BuildOptions { quality: BuildQuality::default(), robust: true, compact: false, kernels: Kernels::widest() }
    }
}

/// `medium BVH, robust` (the flags that are set, after the quality).
impl std::fmt::Display for BuildOptions {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} BVH", self.quality)?;
        if self.robust {
            write!(f, ", robust")?;
        }
        if self.compact {
            write!(f, ", compact")?;
        }
        Ok(())
    }
}

/// The owned scene handle plus everything Embree may call back into. Dropped as one: the
/// scene is released before the user data it points to.
pub(super) struct RawScene {
    pub(super) raw: ffi::RTCScene,
    /// The device's ray-hit layout (copied: read on every query).
    pub(super) layout: RayHitLayout,
    pub(super) failure: Arc<CallbackFailure>,
    _user_data: Vec<Box<dyn Any + Send + Sync>>,
    device: Device,
}

impl Drop for RawScene {
    fn drop(&mut self) {
        // SAFETY: `raw` is a scene we hold the only reference to; after this no callback can
        // run, and only then are the user data (fields) dropped.
        unsafe { ffi::rtcReleaseScene(self.raw) };
    }
}

/// An owned geometry handle, released on drop (the scene keeps its own reference once
/// attached).
struct GeomHandle(ffi::RTCGeometry);

impl Drop for GeomHandle {
    fn drop(&mut self) {
        // SAFETY: we own one reference to this valid geometry.
        unsafe { ffi::rtcReleaseGeometry(self.0) };
    }
}

/// A scene being assembled. Geometry ids are given in the order geometries are added, from 0.
pub struct SceneBuilder {
    scene: RawScene,
    next_id: u32,
    options: BuildOptions,
    /// The committed scene of each instanced mesh (by the address of its data), built once
    /// and placed by every instance of it; owned by `scene`'s user data.
    instanced: std::collections::HashMap<*const TriMesh, ffi::RTCScene>,
}

// SAFETY: the builder owns its scene exclusively (no shared references exist before commit),
// and Embree scenes may be modified from any one thread at a time.
unsafe impl Send for SceneBuilder {}

/// A committed scene: immutable, answers ray queries.
pub struct Scene {
    pub(super) scene: RawScene,
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
        let raw = unsafe { ffi::rtcNewScene(device.inner.raw) };
        device.take_error()?;
        if raw.is_null() {
            return Err(EmbreeError::InvalidInput("rtcNewScene returned NULL".into()));
        }
        let scene = RawScene {
            raw,
            layout: device.inner.layout,
            failure: Arc::new(CallbackFailure::default()),
            _user_data: Vec::new(),
            device: device.clone(),
        };
        let quality = match options.quality {
            BuildQuality::Low => ffi::BUILD_QUALITY_LOW,
            BuildQuality::Medium => ffi::BUILD_QUALITY_MEDIUM,
            BuildQuality::High => ffi::BUILD_QUALITY_HIGH,
        };
        let flags = ffi::scene_flags(options.robust, options.compact);
        // SAFETY: `raw` is a valid, uncommitted scene; quality and flags are header constants.
        unsafe {
            ffi::rtcSetSceneBuildQuality(raw, quality);
            ffi::rtcSetSceneFlags(raw, flags);
        }
        device.take_error()?;
        Ok(SceneBuilder { scene, next_id: 0, options, instanced: Default::default() })
    }

    fn device(&self) -> &Device {
        &self.scene.device
    }

    fn new_geometry(&self, kind: ffi::RTCGeometryType) -> Result<GeomHandle, EmbreeError> {
        // SAFETY: valid device; `kind` is a header constant.
        let g = unsafe { ffi::rtcNewGeometry(self.device().inner.raw, kind) };
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
            ffi::rtcCommitGeometry(g.0);
            ffi::rtcAttachGeometryByID(self.scene.raw, g.0, id);
        }
        self.device().take_error()?;
        self.next_id += 1;
        Ok(id)
    }

    /// Adds a triangle mesh; returns its geometry id. Vertices and indices are copied into
    /// buffers Embree allocates (and pads for its 16-byte loads).
    pub fn add_triangles(&mut self, vertices: &[Vec3], indices: &[[u32; 3]]) -> Result<u32, EmbreeError> {
        let g = self.triangle_geometry(vertices, indices)?;
        self.attach(g)
    }

    /// Adds a triangle mesh with holes ([`TriMesh::cutout`]; without one, as
    /// [`SceneBuilder::add_triangles`]): Embree asks a filter callback of every candidate hit,
    /// which asks the cut-out whether the surface is there.
    pub fn add_mesh(&mut self, mesh: &Arc<TriMesh>) -> Result<u32, EmbreeError> {
        let g = self.triangle_geometry(&mesh.positions, &mesh.indices)?;
        if mesh.cutout.is_some() {
            let data = Box::new(CutoutData { mesh: mesh.clone(), failure: self.scene.failure.clone() });
            let ptr = &*data as *const CutoutData as *mut std::ffi::c_void;
            // SAFETY: `g` is a valid triangle geometry. `ptr` points into a box the scene owns
            // until after it is released (RawScene field order), so it outlives every callback,
            // which reads it as the `CutoutData` it is.
            unsafe {
                ffi::rtcSetGeometryUserData(g.0, ptr);
                ffi::rtcSetGeometryIntersectFilterFunction(g.0, Some(user::cutout_filter));
                ffi::rtcSetGeometryOccludedFilterFunction(g.0, Some(user::cutout_filter));
            }
            self.scene._user_data.push(data);
            self.device().take_error()?;
        }
        self.attach(g)
    }

    /// Adds `mesh` placed by `to_world` as an Embree instance; returns its geometry id, which
    /// hits inside it report ([`Hit::geom`]; their `prim` is the mesh's triangle, their `ng`
    /// in the mesh's space). The mesh is built into a scene of its own the first time it is
    /// placed; later instances of the same mesh (the same `Arc`) place that scene again, so
    /// its vertices and BVH exist once however many times it is placed.
    pub fn add_instance(&mut self, mesh: &Arc<TriMesh>, to_world: &glam::Affine3A) -> Result<u32, EmbreeError> {
        let key = Arc::as_ptr(mesh);
        let child = match self.instanced.get(&key) {
            Some(&raw) => raw,
            None => {
                let mut b = SceneBuilder::new(self.device(), self.options)?;
                // A cut-out's callback failing inside the instance fails this scene's queries.
                b.scene.failure = self.scene.failure.clone();
                b.add_mesh(mesh)?;
                let child = b.commit()?;
                let raw = child.scene.raw;
                self.scene._user_data.push(Box::new(child));
                self.instanced.insert(key, raw);
                raw
            }
        };
        let g = self.new_geometry(ffi::GEOMETRY_TYPE_INSTANCE)?;
        let xfm = to_world.to_cols_array();
        // SAFETY: `g` is a valid instance geometry; `child` is a committed scene of the same
        // device, kept alive by this scene's user data (and Embree's own reference) for as
        // long as this scene; `xfm` holds the 12 floats of a column-major 3x4 matrix, which
        // Embree copies.
        unsafe {
            ffi::rtcSetGeometryInstancedScene(g.0, child);
            ffi::rtcSetGeometryTransform(g.0, 0, ffi::FORMAT_FLOAT3X4_COLUMN_MAJOR, xfm.as_ptr().cast());
        }
        self.device().take_error()?;
        self.attach(g)
    }

    /// A new triangle geometry holding copies of `vertices` and `indices`, not yet attached.
    fn triangle_geometry(&self, vertices: &[Vec3], indices: &[[u32; 3]]) -> Result<GeomHandle, EmbreeError> {
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
        let g = self.new_geometry(ffi::GEOMETRY_TYPE_TRIANGLE)?;
        // SAFETY: `g` is a valid triangle geometry; Embree allocates `vertices.len()` items of
        // 12 bytes (plus padding) and returns a pointer to them, or NULL with an error.
        let vb = unsafe {
            ffi::rtcSetNewGeometryBuffer(g.0, ffi::BUFFER_TYPE_VERTEX, 0, ffi::FORMAT_FLOAT3, 12, vertices.len())
        } as *mut f32;
        self.device().take_error()?;
        if vb.is_null() {
            return Err(EmbreeError::InvalidInput("Embree could not allocate the vertex buffer".into()));
        }
        // SAFETY: as above, for the index buffer of `indices.len()` UINT3 items.
        let ib = unsafe {
            ffi::rtcSetNewGeometryBuffer(g.0, ffi::BUFFER_TYPE_INDEX, 0, ffi::FORMAT_UINT3, 12, indices.len())
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
        Ok(g)
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
        let g = self.new_geometry(ffi::GEOMETRY_TYPE_USER)?;
        let data = Box::new(UserData { shapes, failure: self.scene.failure.clone(), layout: self.scene.layout });
        let ptr = &*data as *const UserData<S> as *mut std::ffi::c_void;
        // SAFETY: `g` is a valid user geometry. `ptr` points into a box the scene owns until
        // after it is released (RawScene field order), so it is stable and outlives every
        // callback. The callbacks are instantiated for exactly this `S`.
        unsafe {
            ffi::rtcSetGeometryUserPrimitiveCount(g.0, count);
            ffi::rtcSetGeometryUserData(g.0, ptr);
            ffi::rtcSetGeometryBoundsFunction(g.0, Some(user::bounds::<S>), std::ptr::null_mut());
            ffi::rtcSetGeometryIntersectFunction(g.0, Some(user::intersect::<S>));
            ffi::rtcSetGeometryOccludedFunction(g.0, Some(user::occluded::<S>));
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
        unsafe { ffi::rtcCommitScene(scene.raw) };
        scene.device.take_error()?;
        scene.failure.check()?;
        let mut b = ffi::RTCBounds::default();
        // SAFETY: committed scene; `b` is a writable RTCBounds.
        unsafe { ffi::rtcGetSceneBounds(scene.raw, &mut b) };
        let bounds = Aabb::new(Vec3::new(b.lower_x, b.lower_y, b.lower_z), Vec3::new(b.upper_x, b.upper_y, b.upper_z));
        Ok(Scene { scene, bounds })
    }
}

/// Embree's `FLT_LARGE`: the largest ray origin or direction component it accepts.
pub const FLT_LARGE: f32 = 1.844e18;

/// Whether Embree accepts the ray (its `RayK::valid`): origin and direction components within
/// ±[`FLT_LARGE`] (so not NaN), `tmin` and `tmax` not NaN. Embree asserts on any other ray —
/// the Debian build aborts the process — so the queries here answer such a ray themselves
/// (no hit; blocked) instead of passing it on. A scene within ember's coordinate range never
/// makes one; a NaN from elsewhere must not take the process down.
#[inline(always)]
pub fn accepts(ray: &Ray, tmin: f32, tmax: f32) -> bool {
    let c = accepts_component;
    accepts_interval(tmin, tmax) & c(ray.o.x) & c(ray.o.y) & c(ray.o.z) & c(ray.d.x) & c(ray.d.y) & c(ray.d.z)
}

/// [`accepts`] on one origin or direction component: within ±[`FLT_LARGE`], so not NaN. The
/// packet queries test their lanes with it (`packet.rs`).
#[inline(always)]
pub(super) fn accepts_component(x: f32) -> bool {
    x.abs() <= FLT_LARGE
}

/// [`accepts`] on the interval: neither end NaN.
#[inline(always)]
pub(super) fn accepts_interval(tmin: f32, tmax: f32) -> bool {
    !tmin.is_nan() & !tmax.is_nan()
}

impl Scene {
    /// Bounds of everything in the scene, as Embree computed them.
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// Closest hit with `tmin <= t <= tmax`, without the callback-failure check: for loops
    /// that call [`Scene::callback_failure`] once after a batch of queries (a failure is
    /// sticky, so none is missed; answers given after one are discarded with the batch). A
    /// ray Embree would refuse ([`accepts`]) hits nothing.
    #[inline(always)]
    pub fn intersect_deferred(&self, ray: &Ray, tmin: f32, tmax: f32) -> Option<Hit> {
        if !accepts(ray, tmin, tmax) {
            return None;
        }
        let mut mem = RayHitMem::new(ray, tmin, tmax);
        // SAFETY: committed scene (Scene is only made by commit); `mem` is initialised,
        // 16-byte aligned and as large as the running library's RTCRayHit (layout.rs).
        unsafe { ffi::intersect1(self.scene.raw, &mut mem) };
        mem.hit()
    }

    /// [`Scene::occluded`] without the callback-failure check (see
    /// [`Scene::intersect_deferred`]). A ray Embree would refuse ([`accepts`]) is blocked.
    #[inline(always)]
    pub fn occluded_deferred(&self, ray: &Ray, tmin: f32, tmax: f32) -> bool {
        if !accepts(ray, tmin, tmax) {
            return true;
        }
        let mut r = rtc_ray(ray, tmin, tmax);
        // SAFETY: committed scene; `r` is an initialised RTCRay (the same 48 bytes in every
        // Embree version).
        unsafe { ffi::occluded1(self.scene.raw, &mut r) };
        r.tfar == f32::NEG_INFINITY
    }

    /// Closest hits of the `active` lanes of 8 rays on `[tmin, tmax]`, with one
    /// `rtcIntersect8` (inactive lanes, and rays Embree would refuse, give `None`); errors
    /// deferred as in [`Scene::intersect_deferred`]. Embree is told the rays are coherent if
    /// the packet says so ([`RayPacket::coherent`]).
    #[inline]
    pub fn intersect8_deferred(
        &self,
        rays: &RayPacket,
        active: [bool; LANES],
        tmin: f32,
        tmax: f32,
    ) -> [Option<Hit>; LANES] {
        // Rays Embree would refuse are left out of the query (and hit nothing).
        let (mut mem, valid) = RayHit8Mem::new(rays, active, tmin, tmax);
        // SAFETY: committed scene; `mem` is initialised, 32-byte aligned and as large as the
        // largest known RTCRayHit8 (packet.rs); `valid` is a 32-byte aligned mask.
        unsafe { ffi::intersect8(&valid, self.scene.raw, &mut mem, rays.coherent) };
        // Lanes not traced keep the invalid geometry id `RayHit8Mem::new` gave them: no hit.
        let mut hits = [None; LANES];
        for (i, hit) in hits.iter_mut().enumerate() {
            *hit = mem.hit(i);
        }
        hits
    }

    /// Whether each `active` lane i of 8 rays is blocked on `[tmin, tmax[i]]`, with one
    /// `rtcOccluded8` (inactive lanes give `false`, rays Embree would refuse `true`); errors
    /// deferred; the packet's coherence hint as in [`Scene::intersect8_deferred`].
    #[inline]
    pub fn occluded8_deferred(
        &self,
        rays: &RayPacket,
        active: [bool; LANES],
        tmin: f32,
        tmax: [f32; LANES],
    ) -> [bool; LANES] {
        let (mut ray, valid) = ray8(rays, active, tmin, tmax);
        // SAFETY: committed scene; `ray` is an initialised, 32-byte aligned RTCRay8 (the same
        // 384 bytes in every Embree version); `valid` is a 32-byte aligned mask.
        unsafe { ffi::occluded8(&valid, self.scene.raw, &mut ray, rays.coherent) };
        // An active lane left out of the query was refused: blocked.
        std::array::from_fn(|i| active[i] && (valid.0[i] == 0 || ray.tfar[i] == f32::NEG_INFINITY))
    }

    /// The error of the first user-geometry callback that panicked on this scene, if any.
    #[inline(always)]
    pub fn callback_failure(&self) -> Result<(), EmbreeError> {
        self.scene.failure.check()
    }

    /// Closest hit with `tmin <= t <= tmax`.
    #[inline]
    pub fn intersect(&self, ray: &Ray, tmin: f32, tmax: f32) -> Result<Option<Hit>, EmbreeError> {
        let hit = self.intersect_deferred(ray, tmin, tmax);
        self.callback_failure()?;
        Ok(hit)
    }

    /// Whether anything is hit with `tmin <= t <= tmax`.
    #[inline]
    pub fn occluded(&self, ray: &Ray, tmin: f32, tmax: f32) -> Result<bool, EmbreeError> {
        let blocked = self.occluded_deferred(ray, tmin, tmax);
        self.callback_failure()?;
        Ok(blocked)
    }

    /// The ray-hit layout of the library this scene runs on.
    pub fn ray_hit_layout(&self) -> RayHitLayout {
        self.scene.layout
    }

    /// The device this scene was built on.
    pub fn device(&self) -> &Device {
        &self.scene.device
    }
}

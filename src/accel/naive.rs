use super::{Accel, AccelError};
use crate::geometry::{Cylinder, Geometry, Hit, MeshInstance, Ray, Shape, Sphere, TriMesh, WatertightRay};
use glam::Vec3;
use std::sync::Arc;

/// The seed paper's strategy: every ray is tested against every triangle, sphere and cylinder.
/// Triangles use the watertight test (see [`crate::geometry::WatertightRay`]).
pub struct NaiveAccel {
    geometry: Vec<Prims>,
}

/// Primitives laid out for the loop: triangle corners contiguous (no index indirection).
enum Prims {
    Triangles(Vec<[Vec3; 3]>),
    /// A mesh with holes: each candidate hit is asked of its cut-out.
    CutTriangles(Vec<[Vec3; 3]>, Arc<TriMesh>),
    /// A placed mesh: rays are taken into its space (the triangles are shared by its
    /// instances; the mesh is kept for a cut-out).
    Instance(Arc<Vec<[Vec3; 3]>>, Arc<MeshInstance>),
    Spheres(Arc<[Sphere]>),
    Cylinders(Arc<[Cylinder]>),
}

impl NaiveAccel {
    pub fn new(geometry: &[Geometry]) -> Self {
        let corners = |m: &TriMesh| -> Vec<[Vec3; 3]> { (0..m.triangle_count()).map(|i| m.triangle(i)).collect() };
        let mut shared: std::collections::HashMap<*const TriMesh, Arc<Vec<[Vec3; 3]>>> = Default::default();
        let geometry = geometry
            .iter()
            .map(|g| match g {
                Geometry::Mesh(m) => {
                    let tris = corners(m);
                    if m.cutout.is_some() { Prims::CutTriangles(tris, m.clone()) } else { Prims::Triangles(tris) }
                }
                Geometry::Instance(i) => {
                    let tris = shared.entry(Arc::as_ptr(&i.mesh)).or_insert_with(|| Arc::new(corners(&i.mesh)));
                    Prims::Instance(tris.clone(), i.clone())
                }
                Geometry::Spheres(s) => Prims::Spheres(s.clone()),
                Geometry::Cylinders(c) => Prims::Cylinders(c.clone()),
            })
            .collect();
        NaiveAccel { geometry }
    }
}

impl Accel for NaiveAccel {
    fn name(&self) -> &'static str {
        "naive"
    }

    /// The naive loop cannot fail: there is never a deferred error.
    fn deferred_error(&self) -> Result<(), AccelError> {
        Ok(())
    }

    fn intersect_deferred(&self, ray: &Ray, tmin: f32, tmax: f32) -> Option<Hit> {
        let mut best: Option<Hit> = None;
        let mut tmax = tmax;
        let wt = WatertightRay::new(ray);
        for (gi, g) in self.geometry.iter().enumerate() {
            let geom = gi as u32;
            match g {
                Prims::Triangles(tris) => {
                    for (pi, &[a, b, c]) in tris.iter().enumerate() {
                        if let Some(h) = wt.intersect(a, b, c, tmin, tmax) {
                            tmax = h.t;
                            best =
                                Some(Hit { t: h.t, geom, prim: pi as u32, u: h.u, v: h.v, ng: (b - a).cross(c - a) });
                        }
                    }
                }
                Prims::CutTriangles(tris, mesh) => closest_cut(tris, mesh, ray, tmin, &mut tmax, geom, &mut best),
                Prims::Instance(tris, inst) => {
                    closest_cut(tris, &inst.mesh, &inst.ray_to_object(ray), tmin, &mut tmax, geom, &mut best)
                }
                Prims::Spheres(s) => closest_shape(s, ray, tmin, &mut tmax, geom, &mut best),
                Prims::Cylinders(c) => closest_shape(c, ray, tmin, &mut tmax, geom, &mut best),
            }
        }
        best
    }

    fn occluded_deferred(&self, ray: &Ray, tmin: f32, tmax: f32) -> bool {
        let wt = WatertightRay::new(ray);
        self.geometry.iter().any(|g| match g {
            Prims::Triangles(tris) => tris.iter().any(|&[a, b, c]| wt.intersect(a, b, c, tmin, tmax).is_some()),
            Prims::CutTriangles(tris, mesh) => occluded_cut(tris, mesh, ray, tmin, tmax),
            Prims::Instance(tris, inst) => occluded_cut(tris, &inst.mesh, &inst.ray_to_object(ray), tmin, tmax),
            Prims::Spheres(s) => s.iter().any(|p| p.occludes(ray, tmin, tmax)),
            Prims::Cylinders(c) => c.iter().any(|p| p.occludes(ray, tmin, tmax)),
        })
    }
}

/// The closest hit on `tris`, the corners of `mesh`'s triangles in the space of `ray`, each
/// candidate asked of the mesh's cut-out if it has one.
fn closest_cut(
    tris: &[[Vec3; 3]],
    mesh: &TriMesh,
    ray: &Ray,
    tmin: f32,
    tmax: &mut f32,
    geom: u32,
    best: &mut Option<Hit>,
) {
    let wt = WatertightRay::new(ray);
    let cutout = mesh.cutout.as_deref();
    for (pi, &[a, b, c]) in tris.iter().enumerate() {
        if let Some(h) = wt.intersect(a, b, c, tmin, *tmax)
            && cutout.is_none_or(|k| k.keeps(mesh, pi as u32, h.u, h.v, ray))
        {
            *tmax = h.t;
            *best = Some(Hit { t: h.t, geom, prim: pi as u32, u: h.u, v: h.v, ng: (b - a).cross(c - a) });
        }
    }
}

/// Whether any of `tris` (as in [`closest_cut`]) blocks `ray` where the cut-out keeps it.
fn occluded_cut(tris: &[[Vec3; 3]], mesh: &TriMesh, ray: &Ray, tmin: f32, tmax: f32) -> bool {
    let wt = WatertightRay::new(ray);
    let cutout = mesh.cutout.as_deref();
    tris.iter().enumerate().any(|(pi, &[a, b, c])| {
        wt.intersect(a, b, c, tmin, tmax)
            .is_some_and(|h| cutout.is_none_or(|k| k.keeps(mesh, pi as u32, h.u, h.v, ray)))
    })
}

fn closest_shape<S: Shape>(shapes: &[S], ray: &Ray, tmin: f32, tmax: &mut f32, geom: u32, best: &mut Option<Hit>) {
    for (pi, s) in shapes.iter().enumerate() {
        if let Some(h) = s.intersect(ray, tmin, *tmax) {
            *tmax = h.t;
            *best = Some(Hit::from_shape(h, geom, pi as u32));
        }
    }
}

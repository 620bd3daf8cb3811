//! From a hit to a shading point: position refined from the primitive (barycentrics for
//! triangles, re-projection for spheres), normals, texture coordinates, material.

use crate::geometry::{Frame, Geometry, Hit, Ray, TriMesh};
use crate::material::{Bsdf, Material, MaterialModel};
use crate::scene::Scene;
use crate::texture::TexCoords;
use glam::{Vec2, Vec3};
use std::collections::HashMap;
use std::sync::Arc;

pub struct SurfacePoint<'a> {
    pub p: Vec3,
    /// Unit geometric normal as the primitive defines it (outward for spheres/cylinders,
    /// winding order for triangles).
    pub ng: Vec3,
    /// Unit shading normal, on the same side as `ng`.
    pub ns: Vec3,
    /// A clear coat's own unit shading normal (from its normal map, in the tangent frame of
    /// `ns` before the base's normal map), on the same side as `ng`; `None`: the coat, if
    /// any, has `ns`.
    pub coat_ns: Option<Vec3>,
    /// Where textures are looked up.
    pub tex: TexCoords,
    pub material: &'a Material,
}

impl SurfacePoint<'_> {
    /// [`SurfacePoint::coat_ns`] on the side of `ng`, the geometric normal turned (or not) to
    /// the side the surface is shaded from: turned over with it.
    #[inline]
    pub fn coat_normal(&self, ng: Vec3) -> Option<Vec3> {
        self.coat_ns.map(|n| if ng.dot(self.ng) < 0.0 { -n } else { n })
    }

    /// The geometric and shading normals of [`SurfacePoint::shading`] (before the frame).
    #[inline(always)]
    pub fn facing(&self, wo: Vec3, transmissive: bool) -> (Vec3, Vec3) {
        let (mut ng, mut ns) = (self.ng, self.ns);
        if !transmissive {
            if wo.dot(ng) < 0.0 {
                // Opaque surfaces are shaded on the side they are seen from.
                ng = -ng;
                ns = -ns;
            }
            ns = facing_shading_normal(wo, ng, ns);
        }
        (ng, ns)
    }

    /// How the point is shaded seen from `wo` (a unit direction), with `bsdf` its BSDF: the
    /// geometric normal and the shading frame, both turned to `wo`'s side unless `transmissive`
    /// (glass is shaded from both sides), the shading normal made to face `wo`
    /// ([`facing_shading_normal`]); with `COAT`, `bsdf`'s clear coat gets its own normal,
    /// turned and made to face `wo` the same way. The path from the camera and the light paths
    /// shade with it, so both see one BSDF.
    #[inline(always)]
    pub fn shading<const COAT: bool>(&self, wo: Vec3, transmissive: bool, bsdf: &mut Bsdf) -> (Vec3, Frame) {
        let (ng, ns) = self.facing(wo, transmissive);
        let frame = Frame::from_normal(ns);
        // (Set in place: rebinding `bsdf` would copy it at every vertex.)
        if COAT && let Some(n) = self.coat_normal(ng) {
            bsdf.set_coat_normal(frame.to_local(facing_shading_normal(wo, ng, n)));
        }
        (ng, frame)
    }
}

/// The share of light that crosses `distance` of a medium of `absorption` (Beer–Lambert), per
/// channel; a channel that absorbs nothing keeps all of its light, even over an endless one.
#[inline(always)]
pub fn transmittance(absorption: Vec3, distance: f32) -> Vec3 {
    Vec3::select(absorption.cmpeq(Vec3::ZERO), Vec3::ONE, (-absorption * distance).exp())
}

/// The shading normal `ns` perturbed by a normal map's `local` normal (tangent space: x along
/// the tangent, y along the bitangent, z along `ns`), in the frame of the interpolated
/// `tangent` (w: the bitangent's handedness) made orthogonal to `ns`. Where that frame does
/// not exist (a zero tangent: no texture-space direction there), or the mapped normal would
/// face away from the geometric normal `ng`, `ns` is kept.
#[inline]
fn normal_mapped(ns: Vec3, ng: Vec3, tangent: glam::Vec4, local: Vec3) -> Vec3 {
    let t = tangent.truncate();
    let Some(t) = (t - ns * ns.dot(t)).try_normalize() else {
        return ns;
    };
    let b = if tangent.w < 0.0 { -ns.cross(t) } else { ns.cross(t) };
    match (t * local.x + b * local.y + ns * local.z).try_normalize() {
        Some(n) if n.dot(ng) > 0.0 => n,
        _ => ns,
    }
}

/// A shading normal from which `wo` is seen: `ns` itself where the mirror reflection of `wo`
/// about it leaves above the surface (at least `min(0.01, 0.9 cos θg)` along `ng`), and
/// otherwise `ns` bent toward `ng` until it does: the half vector between `wo` and that
/// reflection turned up to the least height. `ng` is the geometric normal on `wo`'s side.
/// A normal map (or interpolated normals at a silhouette) can tilt `ns` away from the viewer,
/// where every BSDF is zero: a black rim along the edges of a normal-mapped sphere, which
/// Cycles avoids the same way.
#[inline]
pub fn facing_shading_normal(wo: Vec3, ng: Vec3, ns: Vec3) -> Vec3 {
    let cos_g = wo.dot(ng);
    let least = (0.9 * cos_g).min(0.01);
    let r = 2.0 * wo.dot(ns) * ns - wo;
    let height = r.dot(ng);
    if height >= least || !(cos_g > 0.0) {
        return ns;
    }
    // The reflection turned up to `least` in its own vertical plane (or wo's, where it
    // points straight down).
    let Some(across) = (r - ng * height).try_normalize().or_else(|| (wo - ng * cos_g).try_normalize()) else {
        return ng;
    };
    let r = across * (1.0 - least * least).sqrt() + ng * least;
    (wo + r).try_normalize().unwrap_or(ng)
}

/// The unit geometric normal of every mesh triangle, (p1 − p0) × (p2 − p0) normalised (the
/// orientation of both accelerators' `Hit::ng`), computed once per render: a hit on a triangle
/// reads it instead of normalising the hit's, which put a square root and a division at the
/// head of every bounce. Zero for a triangle that has none (zero area). A placed mesh's are in
/// its own space, computed once for all its instances.
pub struct FaceNormals(Vec<Arc<[Vec3]>>);

impl FaceNormals {
    pub fn of(scene: &Scene) -> FaceNormals {
        let of = |m: &TriMesh| -> Arc<[Vec3]> {
            (0..m.triangle_count())
                .map(|i| {
                    let [a, b, c] = m.triangle(i);
                    let n = (b - a).cross(c - a).normalize_or_zero();
                    if n.is_finite() { n } else { Vec3::ZERO }
                })
                .collect()
        };
        let mut shared: HashMap<*const TriMesh, Arc<[Vec3]>> = HashMap::new();
        FaceNormals(
            scene
                .geometry
                .iter()
                .map(|g| match g {
                    Geometry::Mesh(m) => of(m),
                    Geometry::Instance(i) => shared.entry(Arc::as_ptr(&i.mesh)).or_insert_with(|| of(&i.mesh)).clone(),
                    _ => Arc::from([]),
                })
                .collect(),
        )
    }
}

/// The shading point of `hit`; `normals` are the scene's [`FaceNormals`]. With `TEX == false`
/// texture coordinates are not interpolated (`uv` is then the raw hit parametrisation), for
/// scenes without textures.
#[inline(always)]
pub fn surface_point<'a, const TEX: bool>(
    scene: &'a Scene,
    normals: &FaceNormals,
    ray: &Ray,
    hit: &Hit,
) -> SurfacePoint<'a> {
    let material = scene.material(hit.geom, hit.prim);
    match &scene.geometry[hit.geom as usize] {
        Geometry::Mesh(m) => {
            let n = normals.0[hit.geom as usize][hit.prim as usize];
            let ng = if n != Vec3::ZERO { n } else { -ray.d };
            on_mesh::<TEX>(m, ng, hit, material)
        }
        Geometry::Instance(inst) => {
            // Shaded in the mesh's space, then placed.
            let n = normals.0[hit.geom as usize][hit.prim as usize];
            let ng = if n != Vec3::ZERO { n } else { inst.to_object.transform_vector3(-ray.d) };
            let local = on_mesh::<TEX>(&inst.mesh, ng, hit, material);
            let ng = Some(inst.normal(local.ng)).filter(|n| *n != Vec3::ZERO).unwrap_or(-ray.d);
            let placed = |n: Vec3| {
                let n = inst.normal(n);
                if n == Vec3::ZERO {
                    ng
                } else if n.dot(ng) < 0.0 {
                    -n
                } else {
                    n
                }
            };
            let (ns, coat_ns) = (placed(local.ns), local.coat_ns.map(placed));
            SurfacePoint { p: inst.to_world.transform_point3(local.p), ng, ns, coat_ns, ..local }
        }
        Geometry::Spheres(s) => {
            let ng = hit.ng.normalize_or(-ray.d);
            let s = &s[hit.prim as usize];
            // Re-projected onto the sphere along the hit's normal (which the sphere has already
            // turned to face the ray at near-tangent hits, where o + t·d rounds to the far side).
            let n = ng;
            SurfacePoint {
                p: s.center + s.radius * n,
                ng: n,
                ns: n,
                coat_ns: None,
                tex: TexCoords::new(Vec2::new(hit.u, hit.v)),
                material,
            }
        }
        Geometry::Cylinders(c) => {
            let ng = hit.ng.normalize_or(-ray.d);
            // o + t·d carries the rounding error of a distant origin: project onto the surface.
            let (p, _) = c[hit.prim as usize].project(ray.at(hit.t), ng);
            SurfacePoint { p, ng, ns: ng, coat_ns: None, tex: TexCoords::new(Vec2::new(hit.u, hit.v)), material }
        }
    }
}

/// The shading point at `hit` on triangle mesh `m` whose face there has unit normal `ng`
/// (all in the mesh's space).
#[inline(always)]
fn on_mesh<'a, const TEX: bool>(m: &TriMesh, ng: Vec3, hit: &Hit, material: &'a Material) -> SurfacePoint<'a> {
    let [i0, i1, i2] = m.indices[hit.prim as usize].map(|i| i as usize);
    let (u, v) = (hit.u, hit.v);
    let w = 1.0 - u - v;
    // The hit point from barycentrics: no error from o + t·d far from the origin.
    let p = w * m.positions[i0] + u * m.positions[i1] + v * m.positions[i2];
    let ns = if m.normals.is_empty() {
        ng
    } else {
        let n = (w * m.normals[i0] + u * m.normals[i1] + v * m.normals[i2]).normalize_or(ng);
        if n.dot(ng) < 0.0 { -n } else { n }
    };
    let at = |a: &[Vec2]| w * a[i0] + u * a[i1] + v * a[i2];
    let uv = if !TEX || m.uvs.is_empty() { Vec2::new(u, v) } else { at(&m.uvs) };
    let uv1 = if !TEX || m.uvs1.is_empty() { uv } else { at(&m.uvs1) };
    let tex = TexCoords { uv: [uv, uv1], width: 0.0 };
    // Both normal maps perturb the interpolated normal, in the same tangent frame.
    let (ns, coat_ns) = if TEX && !m.tangents.is_empty() {
        let [t0, t1, t2] = m.tangents[hit.prim as usize];
        let tangent = w * t0 + u * t1 + v * t2;
        let mapped = |local: Option<Vec3>| local.map(|local| normal_mapped(ns, ng, tangent, local));
        let coat_ns = mapped(material.kind.coat_normal_at::<TEX>(&tex));
        (mapped(material.kind.normal_at::<TEX>(&tex)).unwrap_or(ns), coat_ns)
    } else {
        (ns, None)
    };
    SurfacePoint { p, ng, ns, coat_ns, tex, material }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_shading_normal_seen_from_wo_is_kept_and_one_turned_away_is_bent_until_seen() {
        let ng = Vec3::Z;
        let wo = Vec3::new(0.8, 0.0, 0.6);
        // Facing the viewer: unchanged, whether or not it equals ng.
        assert_eq!(facing_shading_normal(wo, ng, ng), ng);
        let tilted = Vec3::new(0.3, 0.1, 1.0).normalize();
        assert_eq!(facing_shading_normal(wo, ng, tilted), tilted);
        // Tilted away (a normal map at a grazing view): wo would reflect below the surface.
        for ns in [Vec3::new(-0.7, 0.0, 0.7).normalize(), Vec3::new(-0.5, 0.4, 0.3).normalize()] {
            let n = facing_shading_normal(wo, ng, ns);
            assert!((n.length() - 1.0).abs() < 1e-5 && n.dot(wo) > 0.0, "{n}");
            let r = 2.0 * wo.dot(n) * n - wo;
            assert!((r.dot(ng) - 0.01).abs() < 1e-4, "reflection height {}", r.dot(ng));
        }
        // Straight down along ng, a normal far from it: bent within wo's vertical plane.
        let n = facing_shading_normal(Vec3::Z, ng, Vec3::X);
        assert!(n.dot(Vec3::Z) > 0.0 && n.is_finite());
    }
}

//! The three ray workloads, generated deterministically from a seed and shared by every
//! strategy of a run.

use crate::accel::{Accel, AccelError};
use crate::camera::Camera;
use crate::geometry::{Aabb, Ray, offset_toward};
use crate::sampler::Rng;
use glam::{Vec2, Vec3};
use std::fmt;

/// Which workload.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RayKind {
    /// Primary rays of a pinhole camera framing the scene, one per pixel centre of a square
    /// image, in scanline order; closest hit.
    Coherent,
    /// Origins uniform in the scene's bounding box, directions uniform on the sphere; closest
    /// hit.
    Incoherent,
    /// Shadow rays: from each visible point of the coherent set (offset off the surface) to a
    /// random point of a square light above the scene, where that point is on the visible side;
    /// any hit up to the light.
    Occlusion,
}

impl RayKind {
    pub const ALL: [RayKind; 3] = [RayKind::Coherent, RayKind::Incoherent, RayKind::Occlusion];

    pub fn name(self) -> &'static str {
        match self {
            RayKind::Coherent => "coherent",
            RayKind::Incoherent => "incoherent",
            RayKind::Occlusion => "occlusion",
        }
    }

    /// Whether the workload asks for the closest hit (else: any hit).
    pub fn closest(self) -> bool {
        self != RayKind::Occlusion
    }
}

impl fmt::Display for RayKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// One query: the segment `tmin = 0 .. tmax` of a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Query {
    pub ray: Ray,
    pub tmax: f32,
}

/// The camera rays: `side` × `side` pixel centres of a camera framing `bounds`.
pub fn coherent(bounds: &Aabb, side: u32) -> Vec<Query> {
    let cam = Camera::framing(bounds, 40.0, 1.0);
    let n = side as f32;
    (0..side * side)
        .map(|i| {
            let film = Vec2::new(((i % side) as f32 + 0.5) / n, ((i / side) as f32 + 0.5) / n);
            Query { ray: cam.ray(film, Vec2::ZERO), tmax: f32::INFINITY }
        })
        .collect()
}

/// `count` random rays inside `bounds`.
pub fn incoherent(bounds: &Aabb, count: usize, seed: u64) -> Vec<Query> {
    let ext = bounds.diagonal();
    (0..count)
        .map(|i| {
            let mut r = Rng::new(seed, i as u64);
            let o = bounds.min + ext * Vec3::new(r.next_f32(), r.next_f32(), r.next_f32());
            let z = 1.0 - 2.0 * r.next_f32();
            let s = (1.0 - z * z).max(0.0).sqrt();
            let phi = std::f32::consts::TAU * r.next_f32();
            Query { ray: Ray::new(o, Vec3::new(s * phi.cos(), s * phi.sin(), z)), tmax: f32::INFINITY }
        })
        .collect()
}

/// Shadow rays from the hits of `camera` (found with `accel`) to a square light of side
/// `radius` centred `1.5 radius` above the bounds' centre (slightly off-axis), `radius` being
/// half the bounds' diagonal. The direction spans the whole segment, so `tmax = 1` stops at
/// the light.
pub fn occlusion(accel: &dyn Accel, bounds: &Aabb, camera: &[Query], seed: u64) -> Result<Vec<Query>, AccelError> {
    let radius = 0.5 * bounds.diagonal().length();
    let light = bounds.center() + radius * Vec3::new(0.3, 1.5, 0.2);
    let mut out = Vec::with_capacity(camera.len());
    for (i, q) in camera.iter().enumerate() {
        let Some(hit) = accel.intersect(&q.ray, 0.0, q.tmax)? else { continue };
        let n = hit.ng.normalize_or_zero();
        if n == Vec3::ZERO {
            continue;
        }
        let n = if n.dot(q.ray.d) < 0.0 { n } else { -n }; // the side the camera sees
        let mut r = Rng::new(seed ^ 0x0cc1_u64, i as u64);
        let target = light + radius * Vec3::new(r.next_f32() - 0.5, 0.0, r.next_f32() - 0.5);
        let p = q.ray.at(hit.t);
        if (target - p).dot(n) <= 0.0 {
            continue; // the light is behind the surface: an integrator would not trace this
        }
        let o = offset_toward(p, n, target - p);
        out.push(Query { ray: Ray::new(o, target - o), tmax: 1.0 });
    }
    Ok(out)
}

/// Every `len / count`-th query (at most `count`, at least one if any): a subsample spread over the
/// whole set, the same for every strategy.
pub fn subsample(queries: &[Query], count: usize) -> Vec<Query> {
    if queries.is_empty() || count == 0 {
        return Vec::new();
    }
    let step = queries.len().div_ceil(count.min(queries.len()));
    queries.iter().step_by(step).copied().collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn subsample_spreads_and_bounds() {
        let q: Vec<Query> =
            (0..10).map(|i| Query { ray: Ray::new(Vec3::splat(i as f32), Vec3::X), tmax: 1.0 }).collect();
        let s = subsample(&q, 3);
        assert_eq!(s.iter().map(|q| q.ray.o.x).collect::<Vec<_>>(), vec![0.0, 4.0, 8.0]);
        assert_eq!(subsample(&q, 100).len(), 10);
        assert!(subsample(&q, 0).is_empty());
    }

    #[test]
    fn random_rays_start_in_the_box_with_unit_directions_and_repeat() {
        let b = Aabb::new(Vec3::new(-1.0, 0.0, 2.0), Vec3::new(3.0, 1.0, 5.0));
        let a = incoherent(&b, 1000, 9);
        assert_eq!(a, incoherent(&b, 1000, 9));
        for q in &a {
            assert!(q.ray.o.cmpge(b.min).all() && q.ray.o.cmple(b.max).all());
            assert!((q.ray.d.length() - 1.0).abs() < 1e-5);
        }
        // Directions cover the sphere: the mean is near 0 (σ ≈ 0.58/√1000 per component).
        let mean = a.iter().map(|q| q.ray.d).sum::<Vec3>() / 1000.0;
        assert!(mean.abs().max_element() < 0.1, "{mean}");
    }
}

//! Ray/triangle intersection for the naive loop.
//!
//! The watertight test of Woop, Benthin and Wald, "Watertight Ray/Triangle Intersection"
//! (JCGT 2013). Chosen over Möller–Trumbore because it is the test a baseline should be
//! judged by: a ray through a shared edge or vertex of a closed mesh hits at least one of the
//! triangles (Möller–Trumbore can slip between them), and its edge functions are exact in sign
//! (a double-precision fallback when one is 0), so the naive loop is a trustworthy reference
//! for Embree's answers. The per-ray shear is computed once and reused for every triangle.

use super::Ray;
use glam::Vec3;

/// A ray prepared for the watertight test: permutation and shear computed once.
#[derive(Clone, Copy, Debug)]
pub struct WatertightRay {
    o: Vec3,
    /// Rows of the permute-and-shear transform: `x = p·rx = p[kx] − Sx·p[kz]`, likewise y, and
    /// `z = p·rz = Sz·p[kz]`. The zero entries make each dot product exactly the paper's
    /// expression while avoiding data-dependent indexing in the per-triangle loop.
    rx: Vec3,
    ry: Vec3,
    rz: Vec3,
}

/// Result of a triangle test: distance and barycentrics `u`, `v` (weights of vertices 1, 2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleTest {
    pub t: f32,
    pub u: f32,
    pub v: f32,
}

impl WatertightRay {
    pub fn new(ray: &Ray) -> Self {
        let d = ray.d;
        let ad = d.abs();
        let kz = if ad.x > ad.y {
            if ad.x > ad.z { 0 } else { 2 }
        } else if ad.y > ad.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        // Swap to preserve the winding (and so the sign of the edge functions).
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let (sx, sy, sz) = (d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]);
        let e = |i: usize| Vec3::AXES[i];
        WatertightRay { o: ray.o, rx: e(kx) - sx * e(kz), ry: e(ky) - sy * e(kz), rz: sz * e(kz) }
    }

    /// Hit with `tmin < t < tmax`, both faces.
    #[inline]
    pub fn intersect(&self, p0: Vec3, p1: Vec3, p2: Vec3, tmin: f32, tmax: f32) -> Option<TriangleTest> {
        let a = p0 - self.o;
        let b = p1 - self.o;
        let c = p2 - self.o;
        let (ax, ay) = (a.dot(self.rx), a.dot(self.ry));
        let (bx, by) = (b.dot(self.rx), b.dot(self.ry));
        let (cx, cy) = (c.dot(self.rx), c.dot(self.ry));
        let mut u = cx * by - cy * bx;
        let mut v = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        if u == 0.0 || v == 0.0 || w == 0.0 {
            let (ax, ay, bx, by, cx, cy) = (ax as f64, ay as f64, bx as f64, by as f64, cx as f64, cy as f64);
            u = (cx * by - cy * bx) as f32;
            v = (ax * cy - ay * cx) as f32;
            w = (bx * ay - by * ax) as f32;
        }
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let (az, bz, cz) = (a.dot(self.rz), b.dot(self.rz), c.dot(self.rz));
        let t_scaled = u * az + v * bz + w * cz;
        let inv = 1.0 / det;
        let t = t_scaled * inv;
        if !(t > tmin && t < tmax) {
            return None;
        }
        Some(TriangleTest { t, u: v * inv, v: w * inv })
    }
}

//! Emitting triangles (of meshes whose material emits): sampled uniformly by area, the
//! density converted to solid angle at the shading point. The triangles of one mesh form one
//! group for the choice by importance (a quad light is two; an emitting model thousands).

use super::choice::LightBounds;
use super::{LightSample, luminance};
use crate::geometry::Aabb;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

#[derive(Clone, Debug, PartialEq)]
pub(super) struct EmissiveTriangle {
    pub p: [Vec3; 3],
    /// The unit normal of the winding order, computed once here, not per sample.
    pub normal: Vec3,
    pub area: f32,
    pub emission: Vec3,
}

impl EmissiveTriangle {
    pub(super) fn new(p: [Vec3; 3], emission: Vec3) -> EmissiveTriangle {
        let area = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length();
        let area = if area.is_finite() { area } else { 0.0 };
        let normal = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
        EmissiveTriangle { p, normal, area, emission }
    }

    /// Luminance of the power it emits (both faces).
    pub(super) fn power(&self) -> f32 {
        luminance(self.emission) * self.area * PI
    }

    /// A point on the triangle uniform by area, seen from `p`; the triangle was chosen with
    /// probability `sel`.
    #[inline(always)]
    pub(super) fn sample(&self, p: Vec3, sel: f32, u: Vec2) -> Option<LightSample> {
        let (tri, area) = (&self.p, self.area);
        if area <= 0.0 {
            return None;
        }
        let su = u.x.sqrt();
        let (b0, b1) = (1.0 - su, u.y * su);
        let q = b0 * tri[0] + b1 * tri[1] + (1.0 - b0 - b1) * tri[2];
        let n = self.normal;
        let d = q - p;
        let d2 = d.length_squared();
        let wi = d / d2.sqrt();
        let cos = n.dot(wi).abs();
        if !(cos > 0.0 && d2 > 0.0) {
            return None;
        }
        let pdf = sel * d2 / (cos * area);
        pdf.is_finite().then_some(LightSample {
            wi,
            point: Some(q),
            normal: n,
            radiance: self.emission,
            pdf,
            delta: false,
            light: 0,
        })
    }

    /// Solid-angle density of [`EmissiveTriangle::sample`] from `p` at the point `q` (normal
    /// `n`) on it, chosen with probability `sel`.
    pub(super) fn pdf(&self, sel: f32, p: Vec3, q: Vec3, n: Vec3) -> f32 {
        let d = q - p;
        let d2 = d.length_squared();
        let cos = n.normalize().dot(d / d2.sqrt()).abs();
        if self.area <= 0.0 || cos <= 0.0 { 0.0 } else { sel * d2 / (cos * self.area) }
    }
}

/// The bounds of a mesh's emitting triangles, taken as one group: their box, the sum of
/// luminance × area, and their common normal when they all face one way (a quad light).
pub(super) fn group_bounds<'a>(triangles: impl Iterator<Item = &'a EmissiveTriangle>) -> LightBounds {
    let mut bounds = Aabb::EMPTY;
    let mut scale = 0.0;
    let mut normal: Option<Vec3> = None;
    let mut flat = true;
    for t in triangles {
        if t.area <= 0.0 {
            continue;
        }
        bounds = t.p.iter().fold(bounds, |b, v| b.grow(*v));
        scale += luminance(t.emission) * t.area;
        match normal {
            None => normal = Some(t.normal),
            Some(m) => flat &= m.dot(t.normal).abs() > 0.9999,
        }
    }
    if !bounds.is_valid() {
        return LightBounds::surfaces(Vec3::ZERO, 0.0, Vec3::ZERO, 0.0);
    }
    let center = bounds.center();
    let radius = 0.5 * bounds.diagonal().length();
    let normal = if flat { normal.unwrap_or(Vec3::ZERO) } else { Vec3::ZERO };
    LightBounds::surfaces(center, radius, normal, scale)
}

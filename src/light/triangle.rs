//! Emitting triangles (of meshes whose material emits): sampled uniformly by area, the
//! density converted to solid angle at the shading point. The triangles of one mesh form one
//! group for the choice by importance (a quad light is two; an emitting model thousands).

use super::choice::LightBounds;
use super::{LightSample, luminance};
use crate::geometry::{Aabb, TriMesh};
use crate::texture::{TexCoords, Texture};
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

#[derive(Clone, Debug, PartialEq)]
pub(super) struct EmissiveTriangle {
    pub p: [Vec3; 3],
    /// The unit normal of the winding order, computed once here, not per sample.
    pub normal: Vec3,
    pub area: f32,
    /// Its radiance, or for a texture its mean over the triangle (for power and bounds).
    pub emission: Vec3,
    /// A radiance that varies over the triangle.
    pub texture: Option<Box<TriangleTexture>>,
}

/// An emission texture on one triangle: the texture and its corners' coordinates (both sets).
#[derive(Clone, Debug, PartialEq)]
pub(super) struct TriangleTexture {
    texture: Texture,
    uv: [[Vec2; 3]; 2],
}

impl TriangleTexture {
    /// The texture at barycentric coordinates (b0, b1, 1 − b0 − b1).
    #[inline]
    fn at(&self, b0: f32, b1: f32, width: f32) -> Vec3 {
        let b2 = 1.0 - b0 - b1;
        let uv = self.uv.map(|c| b0 * c[0] + b1 * c[1] + b2 * c[2]);
        self.texture.eval(&TexCoords { uv, width })
    }
}

/// Points per side of the grid that estimates a textured triangle's mean emission.
const MEAN_STRATA: usize = 4;

impl EmissiveTriangle {
    /// A triangle of constant radiance `emission`; `None` if it has no area.
    pub(super) fn new(p: [Vec3; 3], emission: Vec3) -> Option<EmissiveTriangle> {
        let area = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length();
        let area = if area.is_finite() { area } else { 0.0 };
        let normal = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
        Some(EmissiveTriangle { p, normal, area, emission, texture: None })
    }

    /// Triangle `i` of `mesh`, with world corners `placed`, under an emission texture: sampled, like any emitting triangle,
    /// uniformly by area, with the texture's radiance at the sampled point; chosen among
    /// lights by its power, the area times the texture's mean over it (estimated from 4×4
    /// stratified points, each reading the texture's pyramid at a quarter of the triangle's
    /// extent in texture space). A triangle whose estimate is black is no light (BSDF
    /// sampling still finds any light it has: the estimate only guides).
    pub(super) fn textured(mesh: &TriMesh, i: usize, placed: [Vec3; 3], texture: &Texture) -> Option<EmissiveTriangle> {
        let idx = mesh.indices[i].map(|k| k as usize);
        let corners = |a: &[Vec2]| if a.is_empty() { [Vec2::ZERO; 3] } else { idx.map(|k| a[k]) };
        let uv0 = corners(&mesh.uvs);
        let uv1 = if mesh.uvs1.is_empty() { uv0 } else { corners(&mesh.uvs1) };
        let tex = TriangleTexture { texture: texture.clone(), uv: [uv0, uv1] };
        let uv_area = 0.5 * (uv0[1] - uv0[0]).perp_dot(uv0[2] - uv0[0]).abs();
        let width = uv_area.sqrt() / MEAN_STRATA as f32;
        let mut sum = Vec3::ZERO;
        for a in 0..MEAN_STRATA {
            for b in 0..MEAN_STRATA {
                let u = Vec2::new((a as f32 + 0.5) / MEAN_STRATA as f32, (b as f32 + 0.5) / MEAN_STRATA as f32);
                let (b0, b1) = uniform_barycentrics(u);
                sum += tex.at(b0, b1, width);
            }
        }
        let mut t = EmissiveTriangle::new(placed, sum / (MEAN_STRATA * MEAN_STRATA) as f32)?;
        t.texture = Some(Box::new(tex));
        Some(t)
    }

    /// Its box, luminance × area and normal, for the light tree.
    pub(super) fn tree_bounds(&self) -> super::tree::Bounds {
        let aabb = self.p.iter().fold(Aabb::EMPTY, |b, v| b.grow(*v));
        let phi = if self.area > 0.0 { luminance(self.emission) * self.area } else { 0.0 };
        super::tree::Bounds { aabb, phi, cone: super::tree::Cone::normal(self.normal) }
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
        let (b0, b1) = uniform_barycentrics(u);
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
            radiance: match &self.texture {
                None => self.emission,
                Some(t) => t.at(b0, b1, 0.0),
            },
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

/// Barycentric coordinates (of the first two corners) uniform over a triangle's area, for
/// `u` in [0, 1)².
#[inline(always)]
fn uniform_barycentrics(u: Vec2) -> (f32, f32) {
    let su = u.x.sqrt();
    (1.0 - su, u.y * su)
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

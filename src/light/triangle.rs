//! Emitting triangles (of meshes whose material emits): sampled uniformly by area, or under
//! an emission texture that varies over the triangle in proportion to it, cell by cell (see
//! [`TriangleTexture`]); the density converted to solid angle at the shading point. The
//! triangles of one mesh form one group for the choice by importance (a quad light is two; an
//! emitting model thousands).

use super::choice::LightBounds;
use super::distribution::{normalized_cdf, pick, probability};
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

/// An emission texture on one triangle: the texture and its corners' coordinates (both sets),
/// and where it varies, a distribution of sample points that follows it.
///
/// Points on the triangle are made from points u of the unit square by an area-preserving map
/// ([`uniform_barycentrics`]), so the square's [`CELLS`]² equal cells are equal parts of the
/// triangle. Each cell is weighted by the largest of the texture's luminances at its centre
/// and corners, read at the cell's footprint, mixed with a uniform share ([`UNIFORM_SHARE`]),
/// so that no cell is left unsampled where those points miss light the cell has: unbiased
/// whatever the texture. A triangle whose texture is within
/// [`FLAT_RATIO`] over it (at the points of its mean, then at the cells') is sampled uniformly.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct TriangleTexture {
    texture: Texture,
    uv: [[Vec2; 3]; 2],
    /// Cumulative probabilities of the cells, row a = ⌊u.x · CELLS⌋ first; `None`: uniform.
    cells: Option<Box<[f32]>>,
}

/// Cells per side of the unit square's grid (see [`TriangleTexture`]).
const CELLS: usize = 8;
/// The memory of a textured triangle's cell distribution.
pub(super) const CELL_BYTES: usize = CELLS * CELLS * size_of::<f32>();
/// The share of the probability spread uniformly over the cells.
const UNIFORM_SHARE: f64 = 0.1;
/// A triangle whose texture varies by less than this factor over it is sampled uniformly.
const FLAT_RATIO: f32 = 1.5;

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

    /// Triangle `i` of `mesh`, with world corners `placed`, under an emission texture: sampled
    /// in proportion to the texture cell by cell where it varies (see [`TriangleTexture`]),
    /// with the texture's radiance at the sampled point; chosen among
    /// lights by its power, the area times the texture's mean over it (estimated from 4×4
    /// stratified points, each reading the texture's pyramid at a quarter of the triangle's
    /// extent in texture space). A triangle whose estimate is black is no light (BSDF
    /// sampling still finds any light it has: the estimate only guides).
    pub(super) fn textured(mesh: &TriMesh, i: usize, placed: [Vec3; 3], texture: &Texture) -> Option<EmissiveTriangle> {
        let idx = mesh.indices[i].map(|k| k as usize);
        let corners = |a: &[Vec2]| if a.is_empty() { [Vec2::ZERO; 3] } else { idx.map(|k| a[k]) };
        let uv0 = corners(&mesh.uvs);
        let uv1 = if mesh.uvs1.is_empty() { uv0 } else { corners(&mesh.uvs1) };
        let mut tex = TriangleTexture { texture: texture.clone(), uv: [uv0, uv1], cells: None };
        let uv_area = 0.5 * (uv0[1] - uv0[0]).perp_dot(uv0[2] - uv0[0]).abs();
        let width = uv_area.sqrt() / MEAN_STRATA as f32;
        let mut sum = Vec3::ZERO;
        let (mut lo, mut hi) = (f32::INFINITY, 0.0f32);
        for a in 0..MEAN_STRATA {
            for b in 0..MEAN_STRATA {
                let u = Vec2::new((a as f32 + 0.5) / MEAN_STRATA as f32, (b as f32 + 0.5) / MEAN_STRATA as f32);
                let (b0, b1) = uniform_barycentrics(u);
                let e = tex.at(b0, b1, width);
                sum += e;
                (lo, hi) = (lo.min(luminance(e)), hi.max(luminance(e)));
            }
        }
        // Cells only where the texture, seen at a quarter of the triangle's extent, varies
        // (most triangles of a large emitting model are one colour across).
        if hi > FLAT_RATIO * lo {
            tex.cells = cell_distribution(&tex, uv_area.sqrt() / CELLS as f32);
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

    /// A point on the triangle (uniform by area, or following its emission texture), seen
    /// from `p`; the triangle was chosen with probability `sel`.
    #[inline(always)]
    pub(super) fn sample(&self, p: Vec3, sel: f32, u: Vec2) -> Option<LightSample> {
        let (tri, area) = (&self.p, self.area);
        if area <= 0.0 {
            return None;
        }
        let cells = self.texture.as_ref().and_then(|t| t.cells.as_deref());
        let u = match cells {
            Some(cdf) => {
                let (c, fx) = pick(cdf, u.x);
                Vec2::new(((c / CELLS) as f32 + fx) / CELLS as f32, ((c % CELLS) as f32 + u.y) / CELLS as f32)
            }
            None => u,
        };
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
        // The density over the square where the point fell, read back from its barycentrics
        // as `pdf` reads it (the same value for the same point).
        let square = cells.map_or(1.0, |cdf| cell_density(cdf, b0, b1));
        let pdf = sel * square * d2 / (cos * area);
        pdf.is_finite().then_some(LightSample {
            wi,
            point: Some(q),
            normal: n,
            radiance: self.radiance_at(b0, b1),
            pdf,
            delta: false,
            light: 0,
        })
    }

    /// A point light leaves the triangle from, for a path from the light: uniform by area
    /// (`u`), with the radiance there; both faces emit.
    pub(super) fn emit_point(&self, u: Vec2) -> Option<super::emission::EmissionPoint> {
        if !(self.area > 0.0) {
            return None;
        }
        let (b0, b1) = uniform_barycentrics(u);
        let [p0, p1, p2] = self.p;
        let p = b0 * p0 + b1 * p1 + (1.0 - b0 - b1) * p2;
        let le = self.radiance_at(b0, b1);
        Some(super::emission::EmissionPoint { p, n: self.normal, le, area: self.area, two_sided: true })
    }

    /// The radiance at barycentric coordinates (b0, b1, 1 − b0 − b1).
    #[inline(always)]
    fn radiance_at(&self, b0: f32, b1: f32) -> Vec3 {
        match &self.texture {
            None => self.emission,
            Some(t) => t.at(b0, b1, 0.0),
        }
    }

    /// Solid-angle density of [`EmissiveTriangle::sample`] from `p` at the point `q` (normal
    /// `n`) on it, chosen with probability `sel`.
    pub(super) fn pdf(&self, sel: f32, p: Vec3, q: Vec3, n: Vec3) -> f32 {
        let d = q - p;
        let d2 = d.length_squared();
        let cos = n.normalize().dot(d / d2.sqrt()).abs();
        if self.area <= 0.0 || cos <= 0.0 {
            return 0.0;
        }
        let square = match self.texture.as_ref().and_then(|t| t.cells.as_deref()) {
            Some(cdf) => {
                // q's barycentrics: the areas of the triangles it makes with the other corners.
                let [p0, p1, p2] = self.p;
                let twice = 2.0 * self.area;
                let b0 = (p1 - q).cross(p2 - q).dot(self.normal) / twice;
                let b1 = (p2 - q).cross(p0 - q).dot(self.normal) / twice;
                cell_density(cdf, b0, b1)
            }
            None => 1.0,
        };
        sel * square * d2 / (cos * self.area)
    }
}

/// The cell distribution of a textured triangle (see [`TriangleTexture`]): each cell weighted
/// by the largest luminance at its centre and four corners (the texture read at footprint
/// `width`), so that a cell with light anywhere near its points is not left to the uniform
/// share; `None` where uniform sampling does as well.
fn cell_distribution(tex: &TriangleTexture, width: f32) -> Option<Box<[f32]>> {
    let g = CELLS as f32;
    let lum_at = |x: f32, y: f32| {
        let (b0, b1) = uniform_barycentrics(Vec2::new(x, y));
        luminance(tex.at(b0, b1, width)).max(0.0)
    };
    let corners: Vec<f32> = (0..=CELLS)
        .flat_map(|a| (0..=CELLS).map(move |b| (a, b)))
        .map(|(a, b)| lum_at(a as f32 / g, b as f32 / g))
        .collect();
    let corner = |a: usize, b: usize| corners[a * (CELLS + 1) + b];
    let lum: Vec<f32> = (0..CELLS * CELLS)
        .map(|c| {
            let (a, b) = (c / CELLS, c % CELLS);
            let centre = lum_at((a as f32 + 0.5) / g, (b as f32 + 0.5) / g);
            centre.max(corner(a, b)).max(corner(a + 1, b)).max(corner(a, b + 1)).max(corner(a + 1, b + 1))
        })
        .collect();
    let (lo, hi) = lum.iter().fold((f32::INFINITY, 0.0f32), |(lo, hi), &l| (lo.min(l), hi.max(l)));
    if !(hi > FLAT_RATIO * lo) || !hi.is_finite() {
        return None;
    }
    let total: f64 = lum.iter().map(|&l| l as f64).sum();
    let uniform = UNIFORM_SHARE / (CELLS * CELLS) as f64;
    let weights: Vec<f64> = lum.iter().map(|&l| (1.0 - UNIFORM_SHARE) * l as f64 / total + uniform).collect();
    normalized_cdf(weights.iter().copied(), weights.iter().sum()).map(Vec::into_boxed_slice)
}

/// The density over the unit square of a cell distribution `cdf` at the point whose
/// barycentrics are (b0, b1): the inverse of [`uniform_barycentrics`] gives the cell.
#[inline]
fn cell_density(cdf: &[f32], b0: f32, b1: f32) -> f32 {
    let su = (1.0 - b0).clamp(0.0, 1.0);
    let (x, y) = (su * su, if su > 0.0 { (b1 / su).clamp(0.0, 1.0) } else { 0.0 });
    let cell = |v: f32| ((v * CELLS as f32) as usize).min(CELLS - 1);
    probability(cdf, cell(x) * CELLS + cell(y)) * (CELLS * CELLS) as f32
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Rng;

    /// A right triangle of legs 2 in the plane z = 0 under a checker of bright and black
    /// squares (2 per unit of u and v, the triangle covering 0 to 1): a texture that varies over it
    /// on a scale larger than its cells.
    fn checker_triangle() -> EmissiveTriangle {
        let p = [Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0), Vec3::new(0.0, 2.0, 0.0)];
        let uv = vec![Vec2::ZERO, Vec2::new(1.0, 0.0), Vec2::new(0.0, 1.0)];
        let mesh = TriMesh::new("t", p.to_vec(), vec![[0, 1, 2]], Vec::new(), uv).unwrap();
        let checker = Texture::Checker { a: Vec3::splat(10.0), b: Vec3::ZERO, scale: 2.0 };
        EmissiveTriangle::textured(&mesh, 0, p, &checker).unwrap()
    }

    /// The texture's cells are sampled in proportion to it: every sample's density is the one
    /// `pdf` gives for its point (so MIS weighs both ways alike), the densities integrate to
    /// the triangle (E[1/p_area] = area: unbiased), and the estimate of the emitted power
    /// ∫ L dA is less noisy than by area (fixed seed, 20,000 samples each).
    #[test]
    fn a_textured_triangle_is_sampled_where_it_emits_without_bias() {
        let t = checker_triangle();
        assert!(t.texture.as_ref().unwrap().cells.is_some(), "the checker varies: cells");
        let uniform = EmissiveTriangle {
            texture: t.texture.as_ref().map(|x| Box::new(TriangleTexture { cells: None, ..(**x).clone() })),
            ..t.clone()
        };
        let p = Vec3::new(0.3, 0.4, 1.5);
        let n = 20_000;
        let estimate = |tri: &EmissiveTriangle| {
            let mut rng = Rng::new(7, 0);
            let (mut inv, mut sum, mut sum2) = (0.0f64, 0.0f64, 0.0f64);
            for _ in 0..n {
                let s = tri.sample(p, 1.0, Vec2::new(rng.next_f32(), rng.next_f32())).unwrap();
                let q = s.point.unwrap();
                let back = tri.pdf(1.0, p, q, s.normal);
                assert!((back / s.pdf - 1.0).abs() < 1e-3, "sample pdf {} and pdf {back} at {q}", s.pdf);
                // Area density: the solid-angle one times cos / d².
                let d = q - p;
                let p_area = (s.pdf * s.normal.dot(d.normalize()).abs() / d.length_squared()) as f64;
                inv += 1.0 / p_area;
                let x = luminance(s.radiance) as f64 / p_area;
                sum += x;
                sum2 += x * x;
            }
            let mean = sum / n as f64;
            (inv / n as f64, mean, (sum2 / n as f64 - mean * mean).max(0.0))
        };
        let (area_c, power_c, var_c) = estimate(&t);
        let (area_u, power_u, var_u) = estimate(&uniform);
        println!(
            "cells: area {area_c:.4} power {power_c:.4} var {var_c:.3}; uniform: area {area_u:.4} power {power_u:.4} var {var_u:.3}"
        );
        assert!((area_c / 2.0 - 1.0).abs() < 0.03 && (area_u / 2.0 - 1.0).abs() < 0.03, "{area_c} {area_u}");
        // Half the triangle's area is bright (10): ∫ L dA ≈ 10 (the squares along the
        // hypotenuse are cut, so allow 5%), the same by both.
        assert!((power_c / 10.0 - 1.0).abs() < 0.05 && (power_c / power_u - 1.0).abs() < 0.03, "{power_c} {power_u}");
        assert!(var_c < 0.5 * var_u, "variance with cells {var_c}, by area {var_u}");
    }
}

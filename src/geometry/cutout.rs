//! Surfaces with holes: where a mesh's alpha (a constant times a texture's alpha channel) says
//! the surface is not there, rays pass through it, camera, bounce and shadow rays alike. Both
//! accelerators ask [`Cutout::keeps`] of every candidate hit on such a mesh: the naive loop in
//! its triangle loop, Embree through a filter callback (`src/embree/`). glTF's `alphaMode`
//! `MASK` is a threshold ([`Cutout::cutoff`]); `BLEND` is stochastic transparency, a hit kept
//! with probability alpha, decided by a hash of the ray and the hit so that the same ray
//! always meets the same surface (images stay reproducible).

use super::{Ray, TriMesh};
use crate::texture::{TexCoords, TextureMap};

/// The alpha of a mesh's surface and what it means.
#[derive(Clone, Debug, PartialEq)]
pub struct Cutout {
    /// Alpha where no map says otherwise, and the map's alpha's factor.
    pub alpha: f32,
    /// A texture whose alpha channel multiplies [`Cutout::alpha`].
    pub map: Option<TextureMap>,
    /// `Some(c)`: the surface is there where alpha ≥ c (a cut-out); `None`: it is there with
    /// probability alpha (stochastic transparency).
    pub cutoff: Option<f32>,
}

impl Cutout {
    /// The alpha at barycentrics (`u`, `v`) of triangle `prim` of `mesh`, at the finest level
    /// of the map.
    pub fn alpha_at(&self, mesh: &TriMesh, prim: u32, u: f32, v: f32) -> f32 {
        let Some(map) = &self.map else { return self.alpha };
        let [a, b, c] = mesh.indices[prim as usize].map(|i| i as usize);
        let w = 1.0 - u - v;
        let lerp = |set: &[glam::Vec2]| set.get(a).map(|&p| w * p + u * set[b] + v * set[c]).unwrap_or_default();
        let uv0 = lerp(&mesh.uvs);
        let uv1 = if mesh.uvs1.is_empty() { uv0 } else { lerp(&mesh.uvs1) };
        self.alpha * map.sample(&TexCoords { uv: [uv0, uv1], width: 0.0 }).w
    }

    /// Whether `ray` meets the surface at barycentrics (`u`, `v`) of triangle `prim`.
    #[inline]
    pub fn keeps(&self, mesh: &TriMesh, prim: u32, u: f32, v: f32, ray: &Ray) -> bool {
        let alpha = self.alpha_at(mesh, prim, u, v);
        match self.cutoff {
            Some(c) => alpha >= c,
            None => alpha >= 1.0 || (alpha > 0.0 && unit_hash(ray, prim, u, v) < alpha),
        }
    }
}

/// A number in [0, 1) from the ray and the hit, the same every time they are the same.
fn unit_hash(ray: &Ray, prim: u32, u: f32, v: f32) -> f32 {
    let words = [ray.o.x, ray.o.y, ray.o.z, ray.d.x, ray.d.y, ray.d.z, u, v];
    let mut h = 0x9e37_79b9_7f4a_7c15u64 ^ prim as u64;
    for w in words {
        // SplitMix64's finaliser on each word in turn.
        h = (h ^ w.to_bits() as u64).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        h ^= h >> 31;
        h = h.wrapping_mul(0x94d0_49bb_1331_11eb);
        h ^= h >> 29;
    }
    (h >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Vec2, Vec3};

    #[test]
    fn blend_keeps_a_hit_as_often_as_alpha_says() {
        let mesh =
            TriMesh::new("t", vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]], Vec::new(), Vec::<Vec2>::new())
                .unwrap();
        for alpha in [0.0, 0.25, 0.5, 0.9, 1.0] {
            let c = Cutout { alpha, map: None, cutoff: None };
            let n = 20_000;
            let kept = (0..n)
                .filter(|&i| {
                    let d = Vec3::new((i % 141) as f32 * 0.01 - 0.7, (i / 141) as f32 * 0.01 - 0.7, -1.0);
                    c.keeps(&mesh, 0, 0.2, 0.3, &Ray::new(Vec3::new(0.2, 0.3, 1.0), d))
                })
                .count();
            let f = kept as f32 / n as f32;
            // 4 standard deviations of a binomial fraction at n = 20000: at most 0.0142.
            assert!((f - alpha).abs() < 0.015, "alpha {alpha}: kept {f}");
        }
        let mask = Cutout { alpha: 0.4, map: None, cutoff: Some(0.5) };
        assert!(!mask.keeps(&mesh, 0, 0.1, 0.1, &Ray::new(Vec3::Z, Vec3::NEG_Z)));
        assert!(Cutout { cutoff: Some(0.4), ..mask }.keeps(&mesh, 0, 0.1, 0.1, &Ray::new(Vec3::Z, Vec3::NEG_Z)));
    }
}

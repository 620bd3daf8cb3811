//! A fingerprint of a loaded scene: a 64-bit hash of everything that affects the image
//! (geometry, bindings, materials with their texture pixels, lights, background, camera), so a
//! checkpoint can refuse to resume against a different scene. Computed from the loaded data,
//! not the file bytes: editing a comment does not invalidate a checkpoint, editing a referenced
//! mesh or texture does.

use super::{MaterialBinding, MaterialKind, Scene};
use crate::geometry::Geometry;
use crate::hash::Fnv1a;
use crate::light::Background;
use crate::texture::{Image, Texture};
use glam::{Vec2, Vec3};

/// [`Fnv1a`] (stable across builds) fed with the scene's values.
struct Fnv(Fnv1a);

impl Fnv {
    fn bytes(&mut self, b: &[u8]) {
        self.0.write(b);
    }
    fn u32(&mut self, x: u32) {
        self.bytes(&x.to_le_bytes());
    }
    fn f32s(&mut self, v: &[f32]) {
        self.u32(v.len() as u32);
        for x in v {
            self.bytes(&x.to_bits().to_le_bytes());
        }
    }
    fn v3(&mut self, v: &[Vec3]) {
        self.u32(v.len() as u32);
        v.iter().for_each(|p| self.f32s(&p.to_array()));
    }
    fn v2(&mut self, v: &[Vec2]) {
        self.u32(v.len() as u32);
        v.iter().for_each(|p| self.f32s(&p.to_array()));
    }
    fn str(&mut self, s: &str) {
        self.u32(s.len() as u32);
        self.bytes(s.as_bytes());
    }
    fn image(&mut self, img: &Image) {
        self.u32(img.width);
        self.u32(img.height);
        self.v3(&img.pixels);
    }
    fn texture(&mut self, t: &Texture) {
        match t {
            Texture::Constant(c) => {
                self.u32(0);
                self.v3(&[*c]);
            }
            Texture::Image(img) => {
                self.u32(1);
                self.image(img);
            }
            Texture::Checker { a, b, scale } => {
                self.u32(2);
                self.v3(&[*a, *b]);
                self.f32s(&[*scale]);
            }
        }
    }
}

impl Scene {
    /// See the module documentation.
    pub fn fingerprint(&self) -> u64 {
        let mut h = Fnv(Fnv1a::default());
        for g in &self.geometry {
            match g {
                Geometry::Mesh(m) => {
                    h.u32(0);
                    h.v3(&m.positions);
                    h.u32(m.indices.len() as u32);
                    m.indices.iter().for_each(|t| t.iter().for_each(|&i| h.u32(i)));
                    h.v3(&m.normals);
                    h.v2(&m.uvs);
                }
                Geometry::Spheres(s) => {
                    h.u32(1);
                    s.iter().for_each(|s| h.f32s(&[s.center.x, s.center.y, s.center.z, s.radius]));
                }
                Geometry::Cylinders(c) => {
                    h.u32(2);
                    c.iter().for_each(|c| h.f32s(&[c.p0.x, c.p0.y, c.p0.z, c.p1.x, c.p1.y, c.p1.z, c.radius]));
                }
            }
        }
        for b in &self.bindings {
            match b {
                MaterialBinding::Uniform(m) => {
                    h.u32(0);
                    h.u32(*m);
                }
                MaterialBinding::PerPrim(v) => {
                    h.u32(1);
                    h.u32(v.len() as u32);
                    v.iter().for_each(|&m| h.u32(m));
                }
            }
        }
        for m in &self.materials {
            h.str(&m.name);
            h.v3(&[m.emission]);
            match &m.kind {
                MaterialKind::Diffuse { color } => {
                    h.u32(0);
                    h.texture(color);
                }
                MaterialKind::Metal { color, roughness } | MaterialKind::Plastic { color, roughness } => {
                    h.u32(if matches!(m.kind, MaterialKind::Metal { .. }) { 1 } else { 2 });
                    h.texture(color);
                    h.f32s(&[*roughness]);
                }
                MaterialKind::Glass { ior, tint } => {
                    h.u32(3);
                    h.f32s(&[*ior]);
                    h.v3(&[*tint]);
                }
                MaterialKind::Emissive => h.u32(4),
            }
        }
        for l in &self.point_lights {
            h.v3(&[l.position, l.intensity]);
        }
        match &self.background {
            Background::Image { image, scale } => {
                h.image(image);
                h.f32s(&[*scale]);
            }
            other => h.str(&format!("{other:?}")),
        }
        h.str(&format!("{:?}", self.camera));
        h.0.finish()
    }
}

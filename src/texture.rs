//! Textures: constant colours, images (sRGB decoded to linear, bilinear filtering, wrapping)
//! and a procedural checker. Looked up by surface coordinates (u, v) in [0, 1]².

use crate::film::srgb_to_linear;
use glam::{Vec2, Vec3};
use std::path::Path;
use std::sync::Arc;

/// A linear-RGB image.
#[derive(Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<Vec3>,
}

/// Why an image could not be loaded.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct ImageError(pub String);

impl Image {
    /// Loads an 8-bit image (PNG, JPEG), decoding sRGB to linear.
    pub fn load(path: &Path) -> Result<Image, ImageError> {
        let img = image::open(path).map_err(|e| match e {
            image::ImageError::IoError(io) if io.kind() == std::io::ErrorKind::NotFound => {
                ImageError("no such file".into())
            }
            e => ImageError(e.to_string()),
        })?;
        let rgb = img.to_rgb8();
        let (width, height) = rgb.dimensions();
        let pixels =
            rgb.pixels().map(|p| Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32) / 255.0).map(|c| c.map(srgb_to_linear)).collect();
        Ok(Image { width, height, pixels })
    }

    #[inline]
    fn texel(&self, x: i64, y: i64) -> Vec3 {
        let x = x.rem_euclid(self.width as i64) as usize;
        let y = y.clamp(0, self.height as i64 - 1) as usize;
        self.pixels[y * self.width as usize + x]
    }

    /// Bilinear lookup; u wraps around, v is clamped; v = 1 is the top row.
    pub fn bilinear(&self, uv: Vec2) -> Vec3 {
        let x = uv.x * self.width as f32 - 0.5;
        let y = (1.0 - uv.y) * self.height as f32 - 0.5;
        if !x.is_finite() || !y.is_finite() {
            return Vec3::ZERO;
        }
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let top = self.texel(x0, y0).lerp(self.texel(x0 + 1, y0), fx);
        let bottom = self.texel(x0, y0 + 1).lerp(self.texel(x0 + 1, y0 + 1), fx);
        top.lerp(bottom, fy)
    }

    /// Mean colour.
    pub fn mean(&self) -> Vec3 {
        self.pixels.iter().copied().sum::<Vec3>() / self.pixels.len().max(1) as f32
    }
}

/// A colour that may vary over a surface.
#[derive(Clone, Debug, PartialEq)]
pub enum Texture {
    Constant(Vec3),
    Image(Arc<Image>),
    /// Alternating squares, `scale` squares per unit of u and v.
    Checker { a: Vec3, b: Vec3, scale: f32 },
}

impl Texture {
    #[inline]
    pub fn eval(&self, uv: Vec2) -> Vec3 {
        match self {
            Texture::Constant(c) => *c,
            Texture::Image(img) => img.bilinear(uv),
            Texture::Checker { a, b, scale } => {
                let s = (uv * *scale).floor();
                if (s.x + s.y).rem_euclid(2.0) < 1.0 { *a } else { *b }
            }
        }
    }

    /// Whether the value is the same everywhere.
    pub fn is_constant(&self) -> bool {
        matches!(self, Texture::Constant(_))
    }

    /// Average colour (for light power estimates and reports).
    pub fn average(&self) -> Vec3 {
        match self {
            Texture::Constant(c) => *c,
            Texture::Image(img) => img.mean(),
            Texture::Checker { a, b, .. } => 0.5 * (*a + *b),
        }
    }
}

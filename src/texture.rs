//! Textures: constant colours, texture maps (8-bit images with mip pyramids, samplers and
//! coordinate transforms: `map.rs`) and a procedural checker, looked up at a surface's
//! [`TexCoords`]; and [`Image`], linear RGB images read as they are or decoded from sRGB
//! (environment images).

mod map;

pub use map::{Encoding, MipImage, Sampler, TextureMap, UvTransform, Wrap};

use crate::film::srgb_to_linear;
use crate::hash::Fingerprint;
use crate::memory::{self, LoadBudget};
use glam::{Vec2, Vec3};
use std::path::Path;
use std::sync::Arc;

/// Bytes a decoded `width` x `height` texture keeps (linear RGB, f32).
fn pixels_bytes(width: u32, height: u32) -> u64 {
    width as u64 * height as u64 * size_of::<Vec3>() as u64
}

/// Reads an image file's bytes within `budget`: a regular file only, no more than its size.
pub(crate) fn read_image_file(path: &Path, budget: &LoadBudget) -> Result<Vec<u8>, TextureError> {
    let io = |e: std::io::Error| TextureError(crate::regular_file::describe(&e));
    let (file, len) = crate::regular_file::open(path).map_err(io)?;
    let what = format!("texture file of {}", memory::format_bytes(len));
    budget.admit(what, len).map_err(|e| TextureError(e.to_string()))?;
    crate::regular_file::read_opened(file, len).map_err(io)
}

/// An 8-bit image's pixels, decoded from sRGB to linear: through a table of the 256 values
/// (the same numbers as `srgb_to_linear(v / 255)`, whose `powf` per channel had made a
/// 1-megapixel texture's loading cost more than a small render).
fn srgb_pixels(decoded: image::DynamicImage) -> Vec<Vec3> {
    let table: [f32; 256] = std::array::from_fn(|v| srgb_to_linear(v as f32 / 255.0));
    decoded
        .to_rgb8()
        .pixels()
        .map(|p| Vec3::new(table[p[0] as usize], table[p[1] as usize], table[p[2] as usize]))
        .collect()
}

/// An HDR image's pixels as they are (linear), without a copy of the decoded image: negative
/// values become 0, a NaN or infinite one is an error naming the pixel.
fn linear_pixels(decoded: image::DynamicImage) -> Result<Vec<Vec3>, TextureError> {
    let width = decoded.width() as usize;
    let (channels, values): (usize, Vec<f32>) = match decoded {
        image::DynamicImage::ImageRgb32F(b) => (3, b.into_raw()),
        image::DynamicImage::ImageRgba32F(b) => (4, b.into_raw()),
        other => (3, other.to_rgb32f().into_raw()),
    };
    values
        .chunks_exact(channels)
        .enumerate()
        .map(|(i, c)| {
            let p = Vec3::new(c[0], c[1], c[2]);
            if p.is_finite() {
                Ok(p.max(Vec3::ZERO))
            } else {
                Err(TextureError(format!("pixel ({}, {}) is {p}: not a finite value", i % width, i / width)))
            }
        })
        .collect()
}

/// Decodes an image file's bytes after the checks every image gets: a format ember reads
/// (PNG or JPEG; also OpenEXR and Radiance HDR if `hdr`), memory for it admitted in `budget`
/// before decoding (`ldr_bytes` of the size for an 8-bit image, [`memory::hdr_image_bytes`]
/// for an HDR one, plus the file's bytes), a JPEG that ends with its end-of-image marker.
/// Returns the decoded image and whether its format is HDR (linear values).
pub(crate) fn decode_checked(
    bytes: &[u8],
    budget: &LoadBudget,
    hdr: bool,
    ldr_bytes: fn(u32, u32) -> u64,
) -> Result<(image::DynamicImage, bool), TextureError> {
    let open = || {
        image::ImageReader::new(std::io::Cursor::new(bytes))
            .with_guessed_format()
            .map_err(|e| TextureError(format!("cannot read: {e}")))
    };
    let format = open()?.format();
    if format.is_none() {
        return Err(TextureError(format!(
            "not an image ember reads: {}",
            if hdr { "expected OpenEXR, Radiance HDR, PNG or JPEG" } else { "expected PNG or JPEG" }
        )));
    }
    let is_hdr = matches!(format, Some(image::ImageFormat::OpenExr | image::ImageFormat::Hdr));
    if is_hdr && !hdr {
        return Err(TextureError(format!(
            "{} is a high-dynamic-range format, for [background] type = \"image\" only: \
             a surface's colour must be an 8-bit PNG or JPEG",
            if format == Some(image::ImageFormat::OpenExr) { "OpenEXR" } else { "Radiance HDR" }
        )));
    }
    // The header gives the size; refuse what would not fit before decoding (by ember's
    // estimate: the decoders' own allowance is lifted to read the header).
    let mut header = open()?;
    header.no_limits();
    // The png crate refuses a header whose byte count overflows its arithmetic, in its own
    // words ("Memory limit exceeded"); its size is then read from the IHDR chunk, and the
    // budget below says what it would take.
    let (w, h) = match header.into_dimensions() {
        Ok(size) => size,
        Err(e) => match png_header_size(bytes) {
            Some(size) if format == Some(image::ImageFormat::Png) => size,
            _ => return Err(TextureError(e.to_string())),
        },
    };
    if w == 0 || h == 0 {
        return Err(TextureError(format!("the image is {w}x{h} pixels: empty")));
    }
    let per_pixel = if is_hdr { memory::hdr_image_bytes(w, h) } else { ldr_bytes(w, h) };
    let peak = per_pixel.saturating_add(bytes.len() as u64);
    budget.admit(format!("{w}x{h} image"), peak).map_err(|e| TextureError(e.to_string()))?;
    let mut reader = open()?;
    // The decoder fills data that ends early with grey, and ignores data left over.
    if reader.format() == Some(image::ImageFormat::Jpeg) {
        crate::jpeg_scan::check(bytes).map_err(|e| TextureError(format!("truncated or damaged JPEG: {e}")))?;
    }
    // Our limit replaces the image crate's fixed 512 MiB decoding allowance.
    let mut decode_limits = image::Limits::default();
    decode_limits.max_alloc = budget.limit().bytes;
    reader.limits(decode_limits);
    let decoded = reader.decode().map_err(|e| match e {
        // The Radiance decoder reports a short file as a bare I/O error.
        image::ImageError::IoError(e) if e.kind() == std::io::ErrorKind::UnexpectedEof => {
            TextureError(format!("truncated or damaged: the file ends early ({e})"))
        }
        e => TextureError(e.to_string()),
    })?;
    Ok((decoded, is_hdr))
}

/// The width and height a PNG file's IHDR chunk (the first, right after the signature) gives.
fn png_header_size(bytes: &[u8]) -> Option<(u32, u32)> {
    let ihdr = bytes.get(8..24)?;
    if &ihdr[4..8] != b"IHDR" {
        return None;
    }
    let be = |b: &[u8]| u32::from_be_bytes([b[0], b[1], b[2], b[3]]);
    Some((be(&ihdr[8..12]), be(&ihdr[12..16])))
}

/// A linear-RGB image.
#[derive(Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<Vec3>,
}

/// Why a texture image could not be loaded.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct TextureError(pub String);

impl Image {
    /// Loads an environment image: an 8-bit PNG or JPEG (decoded from sRGB to linear), or a
    /// high-dynamic-range OpenEXR (`.exr`) or Radiance RGBE (`.hdr`) file, whose values are
    /// linear radiance already: read as they are, neither decoded from sRGB nor clamped to 1
    /// (negative values, which some tools write for colours out of gamut, are read as 0; NaN
    /// and infinite ones are refused).
    pub fn load_environment(path: &Path, budget: &LoadBudget) -> Result<Image, TextureError> {
        Image::decode(&read_image_file(path, budget)?, budget)
    }

    /// Decodes an environment image held in memory, as [`Image::load_environment`] does.
    pub fn environment_from_memory(bytes: &[u8], budget: &LoadBudget) -> Result<Image, TextureError> {
        Image::decode(bytes, budget)
    }

    /// Decodes an 8-bit image from sRGB to linear, or an HDR image as it is.
    fn decode(bytes: &[u8], budget: &LoadBudget) -> Result<Image, TextureError> {
        let (decoded, is_hdr) = decode_checked(bytes, budget, true, memory::texture_bytes)?;
        let (width, height) = (decoded.width(), decoded.height());
        let pixels = if is_hdr { linear_pixels(decoded)? } else { srgb_pixels(decoded) };
        budget.keep(pixels_bytes(width, height));
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

    /// Feeds the image's size and pixels to a fingerprint.
    pub fn fingerprint(&self, h: &mut Fingerprint) {
        h.u32(self.width);
        h.u32(self.height);
        h.v3(&self.pixels);
    }

    /// Mean colour.
    pub fn mean(&self) -> Vec3 {
        self.pixels.iter().copied().sum::<Vec3>() / self.pixels.len().max(1) as f32
    }

    /// The largest value of each channel over all texels (bilinear lookups never exceed it).
    pub fn max(&self) -> Vec3 {
        self.pixels.iter().copied().fold(Vec3::ZERO, Vec3::max)
    }
}

/// Where a texture is looked up: the surface's texture coordinates (sets 0 and 1, as glTF's
/// `TEXCOORD_0` and `TEXCOORD_1`; a surface with one set has it in both) and the width of the
/// footprint there, in units of set 0 (0: the finest detail).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TexCoords {
    pub uv: [Vec2; 2],
    pub width: f32,
}

impl TexCoords {
    /// One set of coordinates, a point footprint.
    #[inline(always)]
    pub fn new(uv: Vec2) -> TexCoords {
        TexCoords { uv: [uv, uv], width: 0.0 }
    }
}

/// An 8-bit image file (PNG or JPEG) as a colour map: sRGB, coordinates whose v runs up
/// (OBJ's and ember's spheres'), u wrapping around and v clamped, as scene files and MTL
/// libraries give textures.
pub fn colour_map(image: Arc<MipImage>) -> Texture {
    let map = TextureMap { transform: Some(UvTransform::FLIP_V), ..TextureMap::new(image, Sampler::WRAP_U_CLAMP_V) };
    Texture::Map { map, factor: Vec3::ONE }
}

/// A colour that may vary over a surface.
#[derive(Clone, Debug, PartialEq)]
pub enum Texture {
    Constant(Vec3),
    /// A texture map's colour (RGB) times `factor`.
    Map {
        map: TextureMap,
        factor: Vec3,
    },
    /// Alternating squares, `scale` squares per unit of u and v.
    Checker {
        a: Vec3,
        b: Vec3,
        scale: f32,
    },
}

impl Texture {
    #[inline]
    pub fn eval(&self, at: &TexCoords) -> Vec3 {
        let uv = at.uv[0];
        match self {
            Texture::Constant(c) => *c,
            Texture::Map { map, factor } => *factor * map.sample(at).truncate(),
            Texture::Checker { a, b, scale } => {
                // The parity of the square's integer coordinates (no float remainder, a call).
                let s = uv * *scale;
                if floor_to_int(s.x).wrapping_add(floor_to_int(s.y)) & 1 == 0 { *a } else { *b }
            }
        }
    }

    /// The value at `uv` when `TEX`; otherwise (the caller knows no texture is in use) the
    /// constant it is, without looking at `uv`.
    #[inline(always)]
    pub fn at<const TEX: bool>(&self, at: &TexCoords) -> Vec3 {
        if TEX { self.eval(at) } else { self.average() }
    }

    /// Whether the value is the same everywhere.
    pub fn is_constant(&self) -> bool {
        matches!(self, Texture::Constant(_))
    }

    /// The texture if its value varies over the surface.
    pub fn varying(&self) -> Option<&Texture> {
        (!self.is_constant()).then_some(self)
    }

    /// The smallest value of each channel anywhere on the surface.
    pub fn min(&self) -> Vec3 {
        match self {
            Texture::Constant(c) => *c,
            Texture::Map { map, factor } => *factor * map.image.min().truncate(),
            Texture::Checker { a, b, .. } => a.min(*b),
        }
    }

    /// The largest value of each channel anywhere on the surface.
    pub fn max(&self) -> Vec3 {
        match self {
            Texture::Constant(c) => *c,
            Texture::Map { map, factor } => *factor * map.image.max().truncate(),
            Texture::Checker { a, b, .. } => a.max(*b),
        }
    }

    /// Feeds the texture (an image's every pixel) to a fingerprint.
    pub fn fingerprint(&self, h: &mut Fingerprint) {
        match self {
            Texture::Constant(c) => {
                h.u32(0);
                h.v3(&[*c]);
            }
            Texture::Map { map, factor } => {
                h.u32(1);
                map.fingerprint(h);
                h.v3(&[*factor]);
            }
            Texture::Checker { a, b, scale } => {
                h.u32(2);
                h.v3(&[*a, *b]);
                h.f32s(&[*scale]);
            }
        }
    }

    /// Average colour (for light power estimates and reports).
    pub fn average(&self) -> Vec3 {
        match self {
            Texture::Constant(c) => *c,
            Texture::Map { map, factor } => *factor * map.image.mean().truncate(),
            Texture::Checker { a, b, .. } => 0.5 * (*a + *b),
        }
    }
}

/// `x.floor() as i64` (saturating, NaN to 0) without the `floorf` call that baseline x86-64
/// makes for `floor`: truncate, then step down where truncation rounded a negative value up.
/// Exact: below 2²⁴ the truncated integer converts back to `f32` exactly, and above it every
/// `f32` is already an integer.
#[inline]
fn floor_to_int(x: f32) -> i64 {
    let t = x as i64;
    t.saturating_sub((t as f32 > x) as i64)
}

#[cfg(test)]
mod floor_tests {
    use super::floor_to_int;

    #[test]
    fn floor_to_int_is_floor_then_cast() {
        let mut xs = vec![0.0f32, -0.0, 0.5, -0.5, 1.0, -1.0, 2.999_999_8, -2.999_999_8, 16_777_215.5, -16_777_215.5];
        xs.extend([16_777_216.0, -16_777_217.0, 1e10, -1e10, 9.3e18, -9.3e18, 1e30, -1e30, f32::MAX, f32::MIN]);
        xs.extend([f32::INFINITY, f32::NEG_INFINITY, f32::NAN, f32::MIN_POSITIVE, -f32::MIN_POSITIVE, -1e-40]);
        xs.extend((-4000..4000).map(|i| i as f32 * 0.013_7));
        for x in xs {
            assert_eq!(floor_to_int(x), x.floor() as i64, "{x}");
        }
    }
}

#[cfg(test)]
mod srgb_tests {
    use super::{srgb_pixels, srgb_to_linear};
    use glam::Vec3;

    #[test]
    fn the_table_gives_the_transfer_function_of_every_8_bit_value() {
        // Every value in every channel (shifted per channel), against the formula per texel.
        let img =
            image::RgbImage::from_fn(256, 1, |x, _| image::Rgb([x as u8, (x as u8).wrapping_add(85), !(x as u8)]));
        let pixels = srgb_pixels(image::DynamicImage::ImageRgb8(img.clone()));
        for (p, q) in img.pixels().zip(&pixels) {
            let expected = (Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32) / 255.0).map(srgb_to_linear);
            assert_eq!(q.to_array().map(f32::to_bits), expected.to_array().map(f32::to_bits), "{p:?}");
        }
        assert_eq!(pixels[0].x, 0.0);
        assert_eq!(pixels[255].x, 1.0);
    }
}

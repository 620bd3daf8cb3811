//! Texture maps: 8-bit RGBA images kept with their mip pyramid ([`MipImage`]), looked up
//! through a [`Sampler`] (wrap mode per axis), a coordinate transform and a choice of
//! coordinate set ([`TextureMap`]), as glTF describes textures (and OBJ/TOML textures are a
//! case of).
//!
//! - **Coordinates**: a map is looked up at (u, v) with v running *down* the image from its
//!   top row (glTF's convention, and the image's own); a source whose v runs up (OBJ, ember's
//!   spheres) flips it in the map's transform ([`UvTransform::FLIP_V`]).
//! - **Filtering**: bilinear within a level, linear between the two levels that bracket the
//!   footprint ([`TexCoords::width`]; trilinear mipmapping, as pbrt-v4's default). A point
//!   footprint reads level 0 bilinearly.
//! - **Values**: colour maps are sRGB-encoded and decoded to linear at lookup (through a
//!   table), data maps (normals, metal-roughness) are read as they are; alpha is always
//!   linear. The pyramid is built by averaging 2×2 texels in linear space.
//! - **Memory**: 4 bytes per texel and a third more for the pyramid, counted in the load's
//!   budget before the image is decoded.

use super::{TexCoords, TextureError, decode_checked};
use crate::film::{linear_to_srgb, srgb_to_linear};
use crate::hash::Fingerprint;
use crate::memory::{self, LoadBudget};
use glam::{Affine2, Vec2, Vec4};
use std::path::Path;

/// What happens to a coordinate outside [0, 1] (glTF sampler `wrapS` / `wrapT`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Wrap {
    /// The image tiles (glTF `REPEAT`, its default).
    #[default]
    Repeat,
    /// The image tiles, every other copy mirrored (`MIRRORED_REPEAT`).
    MirroredRepeat,
    /// The edge texels extend outward (`CLAMP_TO_EDGE`).
    ClampToEdge,
}

impl Wrap {
    /// The texel index `i` lands on in a row (or column) of `n` texels.
    #[inline(always)]
    fn index(self, i: i64, n: u32) -> usize {
        let n = n as i64;
        (match self {
            Wrap::Repeat => i.rem_euclid(n),
            Wrap::MirroredRepeat => {
                let m = i.rem_euclid(2 * n);
                if m >= n { 2 * n - 1 - m } else { m }
            }
            Wrap::ClampToEdge => i.clamp(0, n - 1),
        }) as usize
    }

    fn code(self) -> u32 {
        self as u32
    }
}

/// How a map's coordinates wrap, per axis (u, v), and how it is magnified.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Sampler {
    pub wrap: [Wrap; 2],
    /// Magnified (a footprint within a texel), the nearest texel rather than a bilinear blend
    /// (glTF's `magFilter` NEAREST: pixel art, normal maps with hard edges). Minified, the
    /// pyramid is read either way.
    pub nearest: bool,
}

impl Sampler {
    /// u wraps around, v is clamped: an image spread over a sphere or a surface once.
    pub const WRAP_U_CLAMP_V: Sampler = Sampler { wrap: [Wrap::Repeat, Wrap::ClampToEdge], nearest: false };

    /// Wrapping as `wrap`, bilinear.
    pub const fn wrapping(wrap: [Wrap; 2]) -> Sampler {
        Sampler { wrap, nearest: false }
    }
}

/// An affine map of texture coordinates applied before the lookup.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvTransform(pub Affine2);

impl UvTransform {
    /// v → 1 − v: for coordinates whose v runs up the image (OBJ, spheres).
    pub const FLIP_V: UvTransform =
        UvTransform(Affine2::from_cols(Vec2::new(1.0, 0.0), Vec2::new(0.0, -1.0), Vec2::new(0.0, 1.0)));

    /// glTF's `KHR_texture_transform`: scale, then rotate by `rotation` radians, then
    /// offset (translation · rotation · scale). The rotation takes (u, v) to
    /// (u cos + v sin, −u sin + v cos): the direction of the extension's worked example
    /// (offset [0, 1], a quarter turn and scale ½ read the lower left quadrant) and of the
    /// Khronos TextureTransformTest model.
    pub fn offset_rotation_scale(offset: Vec2, rotation: f32, scale: Vec2) -> UvTransform {
        let (s, c) = rotation.sin_cos();
        let m = glam::Mat2::from_cols(Vec2::new(c, -s), Vec2::new(s, c)) * glam::Mat2::from_diagonal(scale);
        UvTransform(Affine2::from_mat2_translation(m, offset))
    }

    #[inline(always)]
    fn apply(&self, uv: Vec2) -> Vec2 {
        self.0.transform_point2(uv)
    }

    /// How much it scales lengths (the square root of its determinant's magnitude).
    fn scale(&self) -> f32 {
        self.0.matrix2.determinant().abs().sqrt()
    }
}

/// How a map's 8-bit colour channels become numbers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Encoding {
    /// sRGB-encoded colour (base colour, emission), decoded to linear.
    Srgb,
    /// Data read as it is, v / 255 (normal maps, metallic-roughness).
    Linear,
}

/// One level of a pyramid.
#[derive(Debug, PartialEq)]
struct Level {
    width: u32,
    height: u32,
    texels: Vec<[u8; 4]>,
}

/// An 8-bit RGBA image and its mip pyramid (level 0 the image, each next level half the size,
/// down to 1×1).
#[derive(Debug)]
pub struct MipImage {
    levels: Vec<Level>,
    encoding: Encoding,
    /// The value of each 8-bit number: the sRGB decoding or v / 255.
    table: Box<[f32; 256]>,
    /// Per channel over level 0 (linear): the mean, the smallest and the largest value.
    mean: Vec4,
    min: Vec4,
    max: Vec4,
}

impl PartialEq for MipImage {
    fn eq(&self, other: &MipImage) -> bool {
        self.encoding == other.encoding && self.levels[0] == other.levels[0]
    }
}

/// Bytes kept per texel of level 0: 4 for the texel and 4/3 for the pyramid, rounded up.
const KEPT_BYTES_PER_TEXEL: u64 = 6;

impl MipImage {
    /// The image of `texels` (row by row from the top, RGBA), with its pyramid.
    pub fn new(width: u32, height: u32, texels: Vec<[u8; 4]>, encoding: Encoding) -> MipImage {
        assert!(width > 0 && height > 0 && texels.len() == width as usize * height as usize);
        let table: Box<[f32; 256]> = Box::new(std::array::from_fn(|v| match encoding {
            Encoding::Srgb => srgb_to_linear(v as f32 / 255.0),
            Encoding::Linear => v as f32 / 255.0,
        }));
        let mut levels = vec![Level { width, height, texels }];
        while let Some(last) = levels.last().filter(|l| l.width > 1 || l.height > 1) {
            levels.push(downsample(last, &table, encoding));
        }
        let l0 = &levels[0];
        let (mut sum, mut min, mut max) = (glam::DVec4::ZERO, Vec4::ONE, Vec4::ZERO);
        for t in &l0.texels {
            let v = texel_value(t, &table);
            sum += v.as_dvec4();
            min = min.min(v);
            max = max.max(v);
        }
        let mean = (sum / l0.texels.len() as f64).as_vec4();
        MipImage { levels, encoding, table, mean, min, max }
    }

    /// Decodes a PNG or JPEG file's bytes (held in memory: a file's, or an image embedded in
    /// a mesh file) within `budget`, refused before decoding if it would not fit.
    pub fn decode(bytes: &[u8], budget: &LoadBudget, encoding: Encoding) -> Result<MipImage, TextureError> {
        let (decoded, _) = decode_checked(bytes, budget, false, memory::texture_bytes)?;
        let rgba = decoded.into_rgba8();
        let (width, height) = rgba.dimensions();
        let texels: Vec<[u8; 4]> = rgba.pixels().map(|p| p.0).collect();
        budget.keep((width as u64 * height as u64).saturating_mul(KEPT_BYTES_PER_TEXEL));
        Ok(MipImage::new(width, height, texels, encoding))
    }

    /// Loads a PNG or JPEG file as [`MipImage::decode`] does: a regular file only.
    pub fn load(path: &Path, budget: &LoadBudget, encoding: Encoding) -> Result<MipImage, TextureError> {
        MipImage::decode(&super::read_image_file(path, budget)?, budget, encoding)
    }

    pub fn width(&self) -> u32 {
        self.levels[0].width
    }

    pub fn height(&self) -> u32 {
        self.levels[0].height
    }

    /// Bytes held by the texels of every level.
    pub fn heap_bytes(&self) -> u64 {
        self.levels.iter().map(|l| l.texels.capacity() as u64 * 4).sum()
    }

    /// Per channel, linear: the mean over the image.
    pub fn mean(&self) -> Vec4 {
        self.mean
    }

    /// Per channel, linear: the smallest value anywhere (no lookup is below it).
    pub fn min(&self) -> Vec4 {
        self.min
    }

    /// Per channel, linear: the largest value anywhere (no lookup exceeds it).
    pub fn max(&self) -> Vec4 {
        self.max
    }

    /// Feeds the image (level 0, every texel) and its encoding to a fingerprint.
    pub fn fingerprint(&self, h: &mut Fingerprint) {
        let l0 = &self.levels[0];
        h.u32(l0.width);
        h.u32(l0.height);
        h.u32(self.encoding as u32);
        h.bytes(l0.texels.as_flattened());
    }

    /// The texel at (x, y) of `level`, wrapped, as linear values.
    #[inline(always)]
    fn texel(&self, level: &Level, x: i64, y: i64, wrap: [Wrap; 2]) -> Vec4 {
        let x = wrap[0].index(x, level.width);
        let y = wrap[1].index(y, level.height);
        texel_value(&level.texels[y * level.width as usize + x], &self.table)
    }

    /// Bilinear lookup in `level` at (u, v), v down from the top row.
    #[inline]
    fn bilinear(&self, level: usize, uv: Vec2, wrap: [Wrap; 2]) -> Vec4 {
        let l = &self.levels[level];
        let x = uv.x * l.width as f32 - 0.5;
        let y = uv.y * l.height as f32 - 0.5;
        if !x.is_finite() || !y.is_finite() {
            return Vec4::ZERO;
        }
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let top = self.texel(l, x0, y0, wrap).lerp(self.texel(l, x0 + 1, y0, wrap), fx);
        let bottom = self.texel(l, x0, y0 + 1, wrap).lerp(self.texel(l, x0 + 1, y0 + 1, wrap), fx);
        top.lerp(bottom, fy)
    }

    /// The texel of level 0 that (u, v) falls in.
    #[inline]
    fn nearest(&self, uv: Vec2, wrap: [Wrap; 2]) -> Vec4 {
        let l = &self.levels[0];
        let (x, y) = ((uv.x * l.width as f32).floor(), (uv.y * l.height as f32).floor());
        if !x.is_finite() || !y.is_finite() {
            return Vec4::ZERO;
        }
        self.texel(l, x as i64, y as i64, wrap)
    }

    /// Trilinear lookup for a footprint `width` (in units of the image's side): the two
    /// levels bracketing it, blended; level 0 bilinearly (or its nearest texel, as `sampler`
    /// says) for footprints within a texel.
    #[inline]
    fn lookup(&self, uv: Vec2, width: f32, sampler: Sampler) -> Vec4 {
        let wrap = sampler.wrap;
        let texels = width * self.width().max(self.height()) as f32;
        if !(texels > 1.0) {
            return if sampler.nearest { self.nearest(uv, wrap) } else { self.bilinear(0, uv, wrap) };
        }
        let last = self.levels.len() - 1;
        let lod = texels.log2().min(last as f32);
        let l0 = lod as usize;
        if l0 >= last {
            return self.bilinear(last, uv, wrap);
        }
        let t = lod - l0 as f32;
        self.bilinear(l0, uv, wrap).lerp(self.bilinear(l0 + 1, uv, wrap), t)
    }
}

/// The linear value of an 8-bit RGBA texel: colour through `table`, alpha v / 255.
#[inline(always)]
fn texel_value(t: &[u8; 4], table: &[f32; 256]) -> Vec4 {
    Vec4::new(table[t[0] as usize], table[t[1] as usize], table[t[2] as usize], t[3] as f32 * (1.0 / 255.0))
}

/// The next level of a pyramid: each texel the mean of (up to) 2×2 texels of `l`, averaged as
/// linear values and encoded back.
fn downsample(l: &Level, table: &[f32; 256], encoding: Encoding) -> Level {
    let (w, h) = ((l.width / 2).max(1), (l.height / 2).max(1));
    let encode = |v: f32| -> u8 {
        let v = match encoding {
            Encoding::Srgb => linear_to_srgb(v),
            Encoding::Linear => v,
        };
        (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8
    };
    let mut texels = Vec::with_capacity(w as usize * h as usize);
    for y in 0..h {
        for x in 0..w {
            let mut sum = Vec4::ZERO;
            let mut n = 0.0;
            for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                let (sx, sy) = (2 * x + dx, 2 * y + dy);
                if sx < l.width && sy < l.height {
                    sum += texel_value(&l.texels[(sy * l.width + sx) as usize], table);
                    n += 1.0;
                }
            }
            let m = sum / n;
            texels.push([encode(m.x), encode(m.y), encode(m.z), (m.w.clamp(0.0, 1.0) * 255.0 + 0.5) as u8]);
        }
    }
    Level { width: w, height: h, texels }
}

/// An image looked up through a sampler: which coordinate set, transformed how, wrapped how.
#[derive(Clone, Debug, PartialEq)]
pub struct TextureMap {
    pub image: std::sync::Arc<MipImage>,
    pub sampler: Sampler,
    /// Applied to the coordinates first (`None`: as they are).
    pub transform: Option<UvTransform>,
    /// Which coordinate set of [`TexCoords::uv`] (0 or 1).
    pub set: usize,
}

impl TextureMap {
    /// `image` looked up at coordinate set 0 as it is, with `sampler`.
    pub fn new(image: std::sync::Arc<MipImage>, sampler: Sampler) -> TextureMap {
        TextureMap { image, sampler, transform: None, set: 0 }
    }

    /// The linear RGBA value at `at`.
    #[inline]
    pub fn sample(&self, at: &TexCoords) -> Vec4 {
        let uv = at.uv[self.set];
        let (uv, width) = match &self.transform {
            None => (uv, at.width),
            Some(t) => (t.apply(uv), at.width * t.scale()),
        };
        self.image.lookup(uv, width, self.sampler)
    }

    /// Feeds the image, sampler, transform and set to a fingerprint.
    pub fn fingerprint(&self, h: &mut Fingerprint) {
        self.image.fingerprint(h);
        h.u32(self.sampler.wrap[0].code());
        h.u32(self.sampler.wrap[1].code());
        if self.sampler.nearest {
            h.u32(1);
        }
        if let Some(t) = &self.transform {
            h.f32s(&t.0.to_cols_array());
        }
        h.u32(self.set as u32);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Arc;

    /// A 4×1 image of grey levels 0, 85, 170, 255 (linear), texel centres at u = 1/8, 3/8 …
    fn ramp() -> Arc<MipImage> {
        let texels = [0u8, 85, 170, 255].iter().map(|&v| [v, v, v, 255]).collect();
        Arc::new(MipImage::new(4, 1, texels, Encoding::Linear))
    }

    fn at(u: f32) -> f32 {
        TextureMap::new(ramp(), Sampler::wrapping([Wrap::Repeat, Wrap::Repeat]))
            .sample(&TexCoords::new(Vec2::new(u, 0.5)))
            .x
    }

    #[test]
    fn wrap_modes_fold_indices_as_the_gltf_specification_says() {
        let idx = |w: Wrap| (-6..10).map(|i| w.index(i, 4)).collect::<Vec<_>>();
        assert_eq!(idx(Wrap::Repeat), [2, 3, 0, 1, 2, 3, 0, 1, 2, 3, 0, 1, 2, 3, 0, 1]);
        assert_eq!(idx(Wrap::MirroredRepeat), [2, 3, 3, 2, 1, 0, 0, 1, 2, 3, 3, 2, 1, 0, 0, 1]);
        assert_eq!(idx(Wrap::ClampToEdge), [0, 0, 0, 0, 0, 0, 0, 1, 2, 3, 3, 3, 3, 3, 3, 3]);
    }

    #[test]
    fn lookups_repeat_mirror_and_clamp_outside_the_unit_square() {
        let look = |wrap: Wrap, u: f32| {
            TextureMap::new(ramp(), Sampler::wrapping([wrap, wrap])).sample(&TexCoords::new(Vec2::new(u, 0.5))).x
        };
        // Texel centres: exact values.
        assert_eq!(at(0.125), 0.0);
        assert_eq!(at(0.875), 1.0);
        // One period on, the same; repeat at u = 1.125 is texel 0 again.
        assert_eq!(look(Wrap::Repeat, 1.125), 0.0);
        assert_eq!(look(Wrap::Repeat, -0.125), 1.0);
        // Mirrored: u = 1.125 is texel 3 (the mirror image), u = -0.125 texel 0.
        assert_eq!(look(Wrap::MirroredRepeat, 1.125), 1.0);
        assert_eq!(look(Wrap::MirroredRepeat, -0.125), 0.0);
        assert_eq!(look(Wrap::MirroredRepeat, 2.125), 0.0);
        // Clamped: the edge texels beyond.
        assert_eq!(look(Wrap::ClampToEdge, 3.0), 1.0);
        assert_eq!(look(Wrap::ClampToEdge, -3.0), 0.0);
        // Between centres: linear.
        assert!((at(0.25) - 85.0 / 255.0 / 2.0).abs() < 1e-6);
    }

    #[test]
    fn a_nearest_sampler_reads_whole_texels_when_magnified_and_the_pyramid_when_not() {
        let map = TextureMap::new(ramp(), Sampler { nearest: true, ..Sampler::wrapping([Wrap::Repeat; 2]) });
        let look = |u: f32, width: f32| map.sample(&TexCoords { uv: [Vec2::new(u, 0.5); 2], width }).x;
        // Between texel centres: one texel or the next, never a blend.
        assert_eq!(look(0.249, 0.0), 0.0);
        assert_eq!(look(0.251, 0.0), 85.0 / 255.0);
        assert_eq!(look(0.99, 0.0), 1.0);
        assert_eq!(look(1.01, 0.0), 0.0); // wrapped
        // Minified: the pyramid's mean, as a bilinear sampler gives.
        let bilinear = TextureMap::new(ramp(), Sampler::wrapping([Wrap::Repeat; 2]));
        let wide = TexCoords { uv: [Vec2::new(0.3, 0.5); 2], width: 2.0 };
        assert_eq!(map.sample(&wide), bilinear.sample(&wide));
        // Part of what a render is keyed by.
        let (mut a, mut b) = (Fingerprint::default(), Fingerprint::default());
        map.fingerprint(&mut a);
        bilinear.fingerprint(&mut b);
        assert_ne!(a.finish(), b.finish());
    }

    #[test]
    fn the_pyramid_averages_in_linear_space_and_wide_footprints_read_it() {
        // A 2×2 sRGB checker of black and white: its 1×1 level is linear 0.5, which sRGB
        // encodes as 188 (0.5 → 0.7354 → 187.5).
        let texels = vec![[0, 0, 0, 255], [255, 255, 255, 255], [255, 255, 255, 255], [0, 0, 0, 255]];
        let img = Arc::new(MipImage::new(2, 2, texels, Encoding::Srgb));
        assert_eq!(img.levels.len(), 2);
        assert_eq!(img.levels[1].texels[0][0], 188);
        let map = TextureMap::new(img.clone(), Sampler::default());
        let wide = TexCoords { uv: [Vec2::new(0.25, 0.25); 2], width: 4.0 };
        let v = map.sample(&wide).x;
        assert!((v - srgb_to_linear(188.0 / 255.0)).abs() < 1e-6, "{v}");
        // A point footprint at a texel centre reads level 0 exactly.
        assert_eq!(map.sample(&TexCoords::new(Vec2::new(0.25, 0.25))).x, 0.0);
        assert!((img.mean().x - 0.5).abs() < 1e-6);
        assert_eq!(img.max().x, 1.0);
    }

    #[test]
    fn transforms_and_coordinate_sets_move_the_lookup() {
        let mut map = TextureMap::new(ramp(), Sampler::default());
        map.set = 1;
        let at = TexCoords { uv: [Vec2::new(0.125, 0.5), Vec2::new(0.875, 0.5)], width: 0.0 };
        assert_eq!(map.sample(&at).x, 1.0);
        // Offset by a quarter: texel 3's centre moves to u = 0.625.
        map.set = 0;
        map.transform = Some(UvTransform::offset_rotation_scale(Vec2::new(0.25, 0.0), 0.0, Vec2::ONE));
        let at = TexCoords::new(Vec2::new(0.625, 0.5));
        assert_eq!(map.sample(&at).x, 1.0);
        // Scale 2: u = 0.4375 lands on 0.875.
        map.transform = Some(UvTransform::offset_rotation_scale(Vec2::ZERO, 0.0, Vec2::splat(2.0)));
        assert_eq!(map.sample(&TexCoords::new(Vec2::new(0.4375, 0.25))).x, 1.0);
        // A quarter turn takes (u, v) to (v, -u) as the extension's matrix says.
        let t = UvTransform::offset_rotation_scale(Vec2::ZERO, std::f32::consts::FRAC_PI_2, Vec2::ONE);
        let p = t.apply(Vec2::new(0.3, 0.1));
        assert!((p - Vec2::new(0.1, -0.3)).length() < 1e-6, "{p}");
        assert_eq!(UvTransform::FLIP_V.apply(Vec2::new(0.3, 0.25)), Vec2::new(0.3, 0.75));
    }
}

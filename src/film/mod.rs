//! The film: per-pixel radiance, and its output as PNG (8-bit sRGB) or OpenEXR (linear float),
//! written atomically (temporary file in the same folder, then rename); with a denoised image
//! or auxiliary images, an EXR holds them all as layers (`layers.rs`).

mod accum;
mod checkpoint;
mod denoise;
mod filter;
mod layers;
mod look;
pub mod shard;

pub use accum::{Accumulator, AdaptivePixel, AuxSums, LightSums, PixelState, REL_MSE_EPSILON, RELATIVE_ERROR_FLOOR};
pub use checkpoint::{Checkpoint, CheckpointError, CheckpointKey, checkpoint_path};
pub use denoise::{AuxMode, denoise};
pub use filter::{GAUSSIAN_RADIUS, GAUSSIAN_SIGMA, PixelFilter};
pub use layers::{
    ALBEDO_LAYER, MAIN_LAYER, NOISY_LAYER, NORMAL_LAYER, RenderImages, SAMPLE_COUNT_CHANNEL, exr_channel_names,
    read_exr_channel,
};
pub use look::{Look, MAX_EXPOSURE, Tonemap, check_exposure};

use glam::Vec3;
use std::path::{Path, PathBuf};

/// An image of linear RGB radiance values, row-major, top row first.
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<Vec3>,
}

/// Why an image could not be written.
#[derive(Debug, thiserror::Error)]
pub enum FilmError {
    #[error("{path}: unsupported output format (use .png or .exr)")]
    UnsupportedFormat { path: PathBuf },
    #[error("{path}: cannot write: {reason}")]
    Write { path: PathBuf, reason: String },
    #[error("{path}: cannot read: {reason}")]
    Read { path: PathBuf, reason: String },
}

/// Output formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormat {
    Png,
    Exr,
}

impl ImageFormat {
    /// The format for a path's extension.
    pub fn from_path(path: &Path) -> Result<Self, FilmError> {
        match path.extension().and_then(|e| e.to_str()).map(|e| e.to_ascii_lowercase()).as_deref() {
            Some("png") => Ok(ImageFormat::Png),
            Some("exr") => Ok(ImageFormat::Exr),
            _ => Err(FilmError::UnsupportedFormat { path: path.to_path_buf() }),
        }
    }
}

/// Linear → sRGB transfer function.
#[inline]
pub fn linear_to_srgb(x: f32) -> f32 {
    if x <= 0.003_130_8 { 12.92 * x } else { 1.055 * x.powf(1.0 / 2.4) - 0.055 }
}

/// sRGB → linear transfer function.
#[inline]
pub fn srgb_to_linear(x: f32) -> f32 {
    if x <= 0.040_45 { x / 12.92 } else { ((x + 0.055) / 1.055).powf(2.4) }
}

impl Film {
    pub fn new(width: u32, height: u32) -> Film {
        Film { width, height, pixels: vec![Vec3::ZERO; width as usize * height as usize] }
    }

    #[inline]
    pub fn get(&self, x: u32, y: u32) -> Vec3 {
        self.pixels[(y * self.width + x) as usize]
    }

    /// Mean of all pixels.
    pub fn mean(&self) -> Vec3 {
        self.pixels.iter().fold(Vec3::ZERO, |a, &p| a + p) / self.pixels.len().max(1) as f32
    }

    /// 8-bit sRGB with the default look (values clamped to [0, 1], no exposure).
    pub fn to_rgb8(&self) -> Vec<u8> {
        self.to_rgb8_with(&Look::default())
    }

    /// 8-bit sRGB with `look` (exposure and tone curve, then the sRGB encoding).
    pub fn to_rgb8_with(&self, look: &Look) -> Vec<u8> {
        self.pixels
            .iter()
            .flat_map(|p| look.display_linear(p.to_array()))
            .map(|c| (linear_to_srgb(c) * 255.0 + 0.5) as u8)
            .collect()
    }

    /// Writes the image with the default look ([`Film::save_with`]).
    pub fn save(&self, path: &Path) -> Result<(), FilmError> {
        self.save_with(path, &Look::default())
    }

    /// Writes the image, format chosen by extension, atomically: nothing appears at `path`
    /// unless the whole file was written. PNG is 8-bit sRGB with `look`; OpenEXR is the
    /// linear radiance itself (the look does not apply).
    pub fn save_with(&self, path: &Path, look: &Look) -> Result<(), FilmError> {
        let format = ImageFormat::from_path(path)?;
        crate::atomic_write::write_atomically(path, |file| {
            let mut out = std::io::BufWriter::new(file);
            match format {
                ImageFormat::Png => {
                    use image::ImageEncoder;
                    image::codecs::png::PngEncoder::new(&mut out)
                        .write_image(&self.to_rgb8_with(look), self.width, self.height, image::ExtendedColorType::Rgb8)
                        .map_err(|e| e.to_string())?
                }
                ImageFormat::Exr => {
                    use exr::prelude::*;
                    let w = self.width as usize;
                    let channels = SpecificChannels::rgb(|Vec2(x, y)| {
                        let p: Vec3 = self.pixels[y * w + x];
                        (p.x, p.y, p.z)
                    });
                    // Compressed on this thread: in parallel, blocks are written in the order
                    // their compression finishes, so the same image would give different bytes.
                    Image::from_channels((w, self.height as usize), channels)
                        .write()
                        .non_parallel()
                        .to_buffered(&mut out)
                        .map_err(|e| e.to_string())?
                }
            }
            out.into_inner().map(|_| ()).map_err(|e| e.error().to_string())
        })
        .map_err(|e| FilmError::Write { path: e.path, reason: e.reason })
    }

    /// Reads a linear OpenEXR image (as written by [`Film::save`]).
    pub fn load_exr(path: &Path) -> Result<Film, FilmError> {
        use exr::prelude::*;
        let image = read_first_rgba_layer_from_file(
            path,
            |res, _| Film::new(res.width() as u32, res.height() as u32),
            |film: &mut Film, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
                let w = film.width as usize;
                film.pixels[pos.y() * w + pos.x()] = Vec3::new(r, g, b);
            },
        )
        .map_err(|e| FilmError::Read { path: path.to_path_buf(), reason: e.to_string() })?;
        Ok(image.layer_data.channel_data.pixels)
    }
}

//! What a render writes when it has more than its image: the denoised image and the auxiliary
//! images (albedo, normal) with the per-pixel sample count, as layers of one OpenEXR file.
//!
//! The EXR is a single part whose channels follow the usual layer naming (a layer is a channel
//! name prefix before the last dot, as OpenEXR's own tools, Blender, Nuke and tev read them):
//!
//! | channels | what |
//! | --- | --- |
//! | `R`, `G`, `B` (the default layer) | the image: the denoised one when denoised, else the render's estimate |
//! | `noisy.R`, `noisy.G`, `noisy.B` | the render's (noisy) estimate, when denoised |
//! | `albedo.R`, `albedo.G`, `albedo.B` | mean albedo of the first non-specular surface |
//! | `normal.X`, `normal.Y`, `normal.Z` | mean world-space shading normal there, in [-1, 1] |
//! | `sample_count.Y` | samples taken by the pixel (32-bit float: exact up to 2^24) |
//!
//! All 32-bit float, lossless (the `exr` crate's default compression), written on one thread so
//! the same images give the same bytes. A PNG gets the denoised image when there is one.

use super::{Film, FilmError, ImageFormat, Look};
use std::path::Path;

/// The images of a render to write (see the module documentation).
#[derive(Clone, Copy, Debug)]
pub struct RenderImages<'a> {
    /// The render's estimate (noisy).
    pub image: &'a Film,
    pub denoised: Option<&'a Film>,
    pub albedo: Option<&'a Film>,
    pub normal: Option<&'a Film>,
    /// Samples per pixel, row-major (written with the auxiliary images).
    pub sample_count: Option<&'a [u32]>,
}

/// The channel names of a render's EXR (the writer sorts them, as the format requires): the
/// default layer (the main image: denoised when denoised), the noisy estimate when denoised,
/// the auxiliary images and the sample count.
pub const MAIN_LAYER: [&str; 3] = ["R", "G", "B"];
pub const NOISY_LAYER: [&str; 3] = ["noisy.R", "noisy.G", "noisy.B"];
pub const ALBEDO_LAYER: [&str; 3] = ["albedo.R", "albedo.G", "albedo.B"];
pub const NORMAL_LAYER: [&str; 3] = ["normal.X", "normal.Y", "normal.Z"];
pub const SAMPLE_COUNT_CHANNEL: &str = "sample_count.Y";

impl<'a> RenderImages<'a> {
    /// Only the render's estimate.
    pub fn plain(image: &'a Film) -> RenderImages<'a> {
        RenderImages { image, denoised: None, albedo: None, normal: None, sample_count: None }
    }

    /// The image a viewer shows first: the denoised one if there is one.
    pub fn main(&self) -> &'a Film {
        self.denoised.unwrap_or(self.image)
    }

    /// Writes the images, atomically: a PNG gets [`RenderImages::main`]; an EXR gets every
    /// image there is as layers, or, with only the estimate, exactly what [`Film::save`]
    /// writes.
    pub fn save(&self, path: &Path) -> Result<(), FilmError> {
        self.save_with(path, &Look::default())
    }

    /// [`RenderImages::save`] with a look (exposure, tone curve) for a PNG; EXR layers are
    /// linear radiance whatever the look.
    pub fn save_with(&self, path: &Path, look: &Look) -> Result<(), FilmError> {
        let format = ImageFormat::from_path(path)?;
        let only_image = self.denoised.is_none() && self.albedo.is_none() && self.normal.is_none();
        if format == ImageFormat::Png || (only_image && self.sample_count.is_none()) {
            return self.main().save_with(path, look);
        }
        let (w, h) = (self.image.width as usize, self.image.height as usize);
        for f in [self.denoised, self.albedo, self.normal].into_iter().flatten() {
            assert_eq!((f.width, f.height), (self.image.width, self.image.height), "layers of one size");
        }
        use exr::prelude::*;
        let mut channels: Vec<AnyChannel<FlatSamples>> = Vec::new();
        let mut add_rgb = |names: [&str; 3], film: &Film| {
            for (c, name) in names.into_iter().enumerate() {
                let v: Vec<f32> = film.pixels.iter().map(|p| p[c]).collect();
                channels.push(AnyChannel::new(name, FlatSamples::F32(v)));
            }
        };
        add_rgb(MAIN_LAYER, self.main());
        if self.denoised.is_some() {
            add_rgb(NOISY_LAYER, self.image);
        }
        if let Some(a) = self.albedo {
            add_rgb(ALBEDO_LAYER, a);
        }
        if let Some(n) = self.normal {
            add_rgb(NORMAL_LAYER, n);
        }
        if let Some(counts) = self.sample_count {
            assert_eq!(counts.len(), w * h, "a count per pixel");
            let v: Vec<f32> = counts.iter().map(|&c| c as f32).collect();
            channels.push(AnyChannel::new(SAMPLE_COUNT_CHANNEL, FlatSamples::F32(v)));
        }
        let image = Image::from_channels((w, h), AnyChannels::sort(SmallVec::from_vec(channels)));
        crate::atomic_write::write_atomically(path, |file| {
            let mut out = std::io::BufWriter::new(file);
            // Compressed on this thread: the same images give the same bytes.
            image.write().non_parallel().to_buffered(&mut out).map_err(|e| e.to_string())?;
            out.into_inner().map(|_| ()).map_err(|e| e.error().to_string())
        })
        .map_err(|e| FilmError::Write { path: e.path, reason: e.reason })
    }
}

/// Reads the channel `name` of an EXR written by [`RenderImages::save`] (or any single-part
/// EXR with 32-bit float channels), as (width, height, values row-major).
pub fn read_exr_channel(path: &Path, name: &str) -> Result<(u32, u32, Vec<f32>), FilmError> {
    use exr::prelude::*;
    let read_err = |reason: String| FilmError::Read { path: path.to_path_buf(), reason };
    let image = read_all_flat_layers_from_file(path).map_err(|e| read_err(e.to_string()))?;
    let layer = image.layer_data.first().ok_or_else(|| read_err("no layer".into()))?;
    let size = layer.size;
    let channel = layer
        .channel_data
        .list
        .iter()
        .find(|c| c.name == *name)
        .ok_or_else(|| read_err(format!("no channel {name:?}")))?;
    let values: Vec<f32> = channel.sample_data.values_as_f32().collect();
    Ok((size.width() as u32, size.height() as u32, values))
}

/// The channel names of the first part of an EXR file, sorted.
pub fn exr_channel_names(path: &Path) -> Result<Vec<String>, FilmError> {
    use exr::prelude::*;
    let meta = MetaData::read_from_file(path, false)
        .map_err(|e| FilmError::Read { path: path.to_path_buf(), reason: e.to_string() })?;
    let header =
        meta.headers.first().ok_or_else(|| FilmError::Read { path: path.to_path_buf(), reason: "no header".into() })?;
    Ok(header.channels.list.iter().map(|c| c.name.to_string()).collect())
}

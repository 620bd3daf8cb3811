//! Denoising a render's image with Open Image Denoise ([`crate::oidn`]), given its auxiliary
//! images or not.

use super::{Accumulator, Film};
use crate::oidn::{Aux, DenoiseError, Denoiser};

/// How the denoiser is given the auxiliary images: not at all (colour only), or as
/// [`Aux::Noisy`], [`Aux::Prefilter`] or [`Aux::Clean`]. `--denoise-aux` on the command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AuxMode {
    /// Colour only: the albedo and normal images are not given to OIDN.
    ColorOnly,
    /// Albedo and normal images, as OIDN is told they are.
    With(Aux),
}

impl AuxMode {
    /// The default: measured on the sample scenes (docs/denoiser.md, "Which auxiliary mode").
    pub const DEFAULT: AuxMode = AuxMode::With(Aux::Prefilter);
    pub const ALL: [AuxMode; 4] =
        [AuxMode::ColorOnly, AuxMode::With(Aux::Noisy), AuxMode::With(Aux::Prefilter), AuxMode::With(Aux::Clean)];

    /// `color`, `noisy`, `prefilter` or `clean`.
    pub fn name(self) -> &'static str {
        match self {
            AuxMode::ColorOnly => "color",
            AuxMode::With(Aux::Noisy) => "noisy",
            AuxMode::With(Aux::Prefilter) => "prefilter",
            AuxMode::With(Aux::Clean) => "clean",
        }
    }

    /// What it gives OIDN, for the summary line: `albedo + normal, prefiltered`.
    pub fn describe(self) -> &'static str {
        match self {
            AuxMode::ColorOnly => "colour only",
            AuxMode::With(Aux::Noisy) => "albedo + normal, used as noisy",
            AuxMode::With(Aux::Prefilter) => "albedo + normal, prefiltered",
            AuxMode::With(Aux::Clean) => "albedo + normal, used as clean",
        }
    }
}

crate::choice::named_choice!(AuxMode, "auxiliary mode");

/// The denoised image of `accum` (its mean, linear HDR), with its auxiliary images as `mode`
/// says. Panics if `mode` uses auxiliary images and `accum` has none (the render must take
/// them: [`crate::integrator::RenderSettings::aux`]).
pub fn denoise(denoiser: &Denoiser, accum: &Accumulator, mode: AuxMode) -> Result<Film, DenoiseError> {
    let image = accum.film();
    let (w, h) = (image.width, image.height);
    let pixels = match mode {
        AuxMode::ColorOnly => denoiser.denoise(w, h, &image.pixels, None, None, Aux::Noisy)?,
        AuxMode::With(aux) => {
            let albedo = accum.albedo().expect("the render took the auxiliary images");
            let normal = accum.normal().expect("the render took the auxiliary images");
            denoiser.denoise(w, h, &image.pixels, Some(&albedo.pixels), Some(&normal.pixels), aux)?
        }
    };
    Ok(Film { width: w, height: h, pixels })
}

//! Intel Open Image Denoise (OIDN 2.x, CPU device): the only module besides [`crate::embree`]
//! with `unsafe` code, under the same rules: every `unsafe` is here, handles are RAII, each
//! unsafe block says why it is sound, and OIDN errors become [`DenoiseError`] values.
//!
//! - [`Denoiser`]: loads the library at run time and creates a CPU device;
//!   [`Denoiser::denoise`] runs OIDN's `RT` filter on linear HDR colour, with optional albedo
//!   and normal images, noisy ([`Aux::Noisy`]), noisy and prefiltered as OIDN recommends for
//!   final frames ([`Aux::Prefilter`]) or already clean ([`Aux::Clean`]).
//!
//! The library is *not* linked at build time: `ffi.rs` opens it with `dlopen` (the
//! `libloading` crate) and resolves the functions it declares, so a binary without it starts
//! and only denoising fails, with [`DenoiseError::LibraryNotFound`] naming where it looked and
//! how to install it. Where it looks (`locate.rs`): `$EMBER_OIDN_DIR`, else the folder that
//! `scripts/fetch-oidn.sh` fills (`~/.cache/ember/oidn-2.5.1/lib`, recorded by `build.rs`),
//! else the standard library path. OIDN's one callback into Rust is a filter's progress monitor,
//! which reads a flag and cannot unwind ([`Denoiser::cancel_when`]).
//! See `docs/denoiser.md`.

mod denoiser;
mod device;
mod error;
mod ffi;
mod locate;

pub use denoiser::{Aux, Denoiser, DenoiserOptions};
pub use error::{Attempt, DenoiseError, ErrorCode};
pub use locate::{DIR_VARIABLE, default_dir};

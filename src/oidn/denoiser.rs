use super::device::{Device, Filter};
use super::error::DenoiseError;
use super::{ffi, locate};
use glam::Vec3;
use std::path::PathBuf;
use std::sync::atomic::AtomicBool;

/// How to set up a [`Denoiser`]. `Default` is what [`Denoiser::new`] uses.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct DenoiserOptions {
    /// Load the library from this folder only (holding `libOpenImageDenoise.so.2`), instead of
    /// the search order of [`Denoiser::new`].
    pub library_dir: Option<PathBuf>,
    /// OIDN's `numThreads` device parameter; `None` or 0: OIDN chooses (all cores).
    pub threads: Option<u32>,
    /// OIDN's `setAffinity` device parameter (pin its worker threads); `None`: OIDN's default,
    /// which is on.
    pub set_affinity: Option<bool>,
}

/// What the auxiliary (albedo, normal) images passed to [`Denoiser::denoise`] are like, and so
/// how OIDN uses them. Ignored when there are none.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Aux {
    /// Noisy, used as given (`cleanAux = false`): noise in them can stay in the output. OIDN's
    /// choice for previews; about the cost of colour alone.
    Noisy,
    /// Noisy, denoised first (each in place, on a copy, by its own `RT` filter), then used
    /// with `cleanAux = true`: OIDN's recommendation for final frames. The most expensive:
    /// about 6x the CPU time of colour alone (docs/denoiser.md).
    Prefilter,
    /// Already noise-free (e.g. averaged over many samples, with no depth of field or glossy
    /// first hits), used with `cleanAux = true`: noise in them ends up in the output. OIDN
    /// costs more with clean aux images: about 2–2.3x the CPU time of colour alone.
    Clean,
}

/// Intel Open Image Denoise on the CPU: a loaded library and a committed device.
///
/// Loading happens here, at run time: a binary without the library runs, and only creating a
/// `Denoiser` fails (with [`DenoiseError::LibraryNotFound`], naming where it looked and the
/// command that installs the library). `Send + Sync`: OIDN serialises calls on one device.
pub struct Denoiser {
    device: Device,
    version: (i32, i32, i32),
    threads: i32,
    /// When set, a running denoise stops ([`Denoiser::cancel_when`]).
    stop: Option<&'static AtomicBool>,
    /// OIDN's `maxMemoryMB` for every filter ([`Denoiser::scratch_memory`]).
    max_memory_mb: Option<i32>,
}

impl Denoiser {
    /// Loads the library (from `$EMBER_OIDN_DIR` if set, else the folder `scripts/fetch-oidn.sh`
    /// fills, recorded at build time, else the standard library path) and creates a CPU device.
    pub fn new() -> Result<Denoiser, DenoiseError> {
        Denoiser::with_options(&DenoiserOptions::default())
    }

    /// As [`Denoiser::new`], with a library folder, thread count or affinity setting of choice.
    pub fn with_options(options: &DenoiserOptions) -> Result<Denoiser, DenoiseError> {
        let api = locate::load(options.library_dir.as_deref())?;
        let device = Device::new_cpu(api, options.threads, options.set_affinity)?;
        let version = (device.int(c"versionMajor")?, device.int(c"versionMinor")?, device.int(c"versionPatch")?);
        if version.0 != 2 {
            return Err(DenoiseError::UnsupportedVersion {
                library: PathBuf::from(device.library()),
                version: format!("{}.{}.{}", version.0, version.1, version.2),
            });
        }
        let threads = device.int(c"numThreads")?;
        Ok(Denoiser { device, version, threads, stop: None, max_memory_mb: None })
    }

    /// The same denoiser, whose [`Denoiser::denoise`] stops early with
    /// [`DenoiseError::Cancelled`] once `flag` is set (e.g. by a signal), instead of running
    /// its filters to the end.
    pub fn cancel_when(self, flag: &'static AtomicBool) -> Denoiser {
        Denoiser { stop: Some(flag), ..self }
    }

    /// The same denoiser, telling OIDN to use about `bytes` of scratch memory (its
    /// `maxMemoryMB`, at least 1 MB: it tiles the image to stay near it, and may go somewhat
    /// over) instead of what it would choose.
    pub fn scratch_memory(self, bytes: u64) -> Denoiser {
        let mb = (bytes / 1_000_000).clamp(1, i32::MAX as u64) as i32;
        Denoiser { max_memory_mb: Some(mb), ..self }
    }

    /// Sets what every filter run shares: cancellation and scratch memory.
    fn prepare(&self, filter: &mut Filter<'_>) -> Result<(), DenoiseError> {
        if let Some(flag) = self.stop {
            filter.cancel_when(flag)?;
        }
        if let Some(mb) = self.max_memory_mb {
            filter.set_int(c"maxMemoryMB", mb)?;
        }
        Ok(())
    }

    /// The running library's version, e.g. `"2.5.1"`.
    pub fn version(&self) -> String {
        format!("{}.{}.{}", self.version.0, self.version.1, self.version.2)
    }

    /// What the library was loaded as: its full path, or `libOpenImageDenoise.so.2` when it
    /// came from the standard library path.
    pub fn library(&self) -> &'static str {
        self.device.library()
    }

    /// The device's `numThreads` as OIDN reports it after committing (0: chosen by OIDN).
    pub fn threads(&self) -> i32 {
        self.threads
    }

    /// Denoises a `w` x `h` image with OIDN's `RT` filter in high quality.
    ///
    /// `color`: linear HDR RGB (`hdr = true`), values ≥ 0; `albedo` in [0,1]; `normal` in
    /// [-1,1] (world or view space); all `w * h` pixels, row-major, finite (a NaN or infinite
    /// value is refused with [`DenoiseError::InvalidInput`]: one infinite colour value would
    /// change every pixel of OIDN's output). A normal image is only
    /// accepted together with an albedo image (the combinations OIDN's models are trained for:
    /// colour, colour + albedo, colour + albedo + normal).
    ///
    /// `aux` says whether the auxiliary images are noisy or clean, and whether to prefilter
    /// them ([`Aux`]).
    pub fn denoise(
        &self,
        w: u32,
        h: u32,
        color: &[Vec3],
        albedo: Option<&[Vec3]>,
        normal: Option<&[Vec3]>,
        aux: Aux,
    ) -> Result<Vec<Vec3>, DenoiseError> {
        let (width, height) = (w as usize, h as usize);
        let pixels = width
            .checked_mul(height)
            .filter(|&n| n > 0 && n.checked_mul(size_of::<Vec3>()).is_some())
            .ok_or_else(|| DenoiseError::InvalidInput(format!("image size {w}x{h}")))?;
        for (name, len) in
            [("colour", Some(color.len())), ("albedo", albedo.map(<[_]>::len)), ("normal", normal.map(<[_]>::len))]
        {
            if let Some(len) = len.filter(|&l| l != pixels) {
                return Err(DenoiseError::InvalidInput(format!(
                    "the {name} image has {len} pixels, expected {w}x{h} = {pixels}"
                )));
            }
        }
        for (name, image) in [("colour", Some(color)), ("albedo", albedo), ("normal", normal)] {
            if let Some(image) = image {
                check_finite(name, image, width)?;
            }
        }
        if normal.is_some() && albedo.is_none() {
            return Err(DenoiseError::InvalidInput(String::from(
                "a normal image needs an albedo image too (OIDN's filters take colour, colour + albedo, or colour + albedo + normal)",
            )));
        }

        // Prefiltered copies (declared before the filters that borrow them, so they outlive
        // them); without prefiltering the caller's images are read directly.
        let mut albedo_clean: Option<Vec<Vec3>> = None;
        let mut normal_clean: Option<Vec<Vec3>> = None;
        if aux == Aux::Prefilter {
            if let Some(a) = albedo {
                let mut buf = a.to_vec();
                self.prefilter(width, height, c"albedo", &mut buf)?;
                albedo_clean = Some(buf);
            }
            if let Some(n) = normal {
                let mut buf = n.to_vec();
                self.prefilter(width, height, c"normal", &mut buf)?;
                normal_clean = Some(buf);
            }
        }
        let albedo = albedo_clean.as_deref().or(albedo);
        let normal = normal_clean.as_deref().or(normal);
        let clean_aux = aux != Aux::Noisy && albedo.is_some();

        let mut output = vec![Vec3::ZERO; pixels];
        {
            let mut filter = Filter::new(&self.device, c"RT", width, height)?;
            filter.input(c"color", color)?;
            if let Some(a) = albedo {
                filter.input(c"albedo", a)?;
            }
            if let Some(n) = normal {
                filter.input(c"normal", n)?;
            }
            filter.output(&mut output)?;
            filter.set_bool(c"hdr", true)?;
            filter.set_bool(c"cleanAux", clean_aux)?;
            filter.set_int(c"quality", ffi::QUALITY_HIGH)?;
            self.prepare(&mut filter)?;
            filter.run("colour")?;
        }
        Ok(output)
    }

    /// Denoises an auxiliary image (`"albedo"` or `"normal"`) in place with its own RT filter.
    fn prefilter(
        &self,
        width: usize,
        height: usize,
        name: &std::ffi::CStr,
        image: &mut [Vec3],
    ) -> Result<(), DenoiseError> {
        let mut filter = Filter::new(&self.device, c"RT", width, height)?;
        filter.in_place(name, image)?;
        filter.set_int(c"quality", ffi::QUALITY_HIGH)?;
        self.prepare(&mut filter)?;
        filter.run(&format!("{} prefilter", name.to_string_lossy()))
    }
}

/// Refuses non-finite values: OIDN 2.5.1 reads NaN as 0, but a single infinite colour value
/// changes every pixel of the output (its HDR exposure is computed from the whole image).
fn check_finite(name: &str, image: &[Vec3], width: usize) -> Result<(), DenoiseError> {
    let mut bad = image.iter().enumerate().filter(|(_, p)| !p.is_finite());
    let Some((first, value)) = bad.next() else { return Ok(()) };
    let count = 1 + bad.count();
    Err(DenoiseError::InvalidInput(format!(
        "the {name} image has {count} non-finite pixel{} (the first at ({}, {}): {value})",
        if count == 1 { "" } else { "s" },
        first % width,
        first / width
    )))
}

impl std::fmt::Debug for Denoiser {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Denoiser(Open Image Denoise {}, CPU, {})", self.version(), self.library())
    }
}

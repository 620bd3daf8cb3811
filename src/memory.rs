//! Memory limits: an image, mesh or texture that would not fit in memory is refused before it
//! is allocated, with the estimate in the message.
//!
//! The limit is 75% of the memory available when the process starts (`MemAvailable` in
//! `/proc/meminfo`; 4 GB where that cannot be read), or what the environment variable
//! `EMBER_MEMORY_LIMIT` says: a size such as `8G`, `512M`, `1.5GiB` or `off`.
//!
//! The estimates are measured peaks of this renderer (see the functions), not exact counts.
//! The number of samples per pixel does not change memory: each pixel keeps a running sum.
//!
//! Loading counts everything together ([`LoadBudget`]): the scene file, each mesh and MTL
//! file, each texture (decoded), the film and the accelerator's share of each mesh. Before a
//! step allocates, what the load keeps so far plus the step's peak must fit; so forty large
//! meshes are refused at the one that would not fit, not after all were read.

use std::cell::Cell;
use std::sync::OnceLock;

/// The environment variable that overrides the limit.
pub const ENV: &str = "EMBER_MEMORY_LIMIT";

/// Share of the available memory the default limit allows.
pub const AVAILABLE_SHARE: f64 = 0.75;

/// Limit used when the available memory cannot be read.
pub const FALLBACK_BYTES: u64 = 4_000_000_000;

/// How many bytes may be allocated, and where that number came from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MemoryLimit {
    /// `None`: no limit.
    pub bytes: Option<u64>,
    pub source: LimitSource,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LimitSource {
    /// `EMBER_MEMORY_LIMIT`.
    Env,
    /// A share of `MemAvailable` (bytes).
    Available(u64),
    /// `/proc/meminfo` could not be read.
    Fallback,
    /// Given by the caller.
    Explicit,
}

/// A size refused because it would exceed the limit.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{what} needs ~{} {purpose}, more than the {} limit ({})", format_bytes(*.needed), format_bytes(*.limit), .source_text)]
pub struct LimitError {
    /// What was asked for, e.g. `image 16384x16384`.
    pub what: String,
    /// What the memory is for, e.g. `of film memory`.
    pub purpose: String,
    pub needed: u64,
    pub limit: u64,
    source_text: String,
}

impl MemoryLimit {
    /// A limit of `bytes`.
    pub fn bytes(bytes: u64) -> MemoryLimit {
        MemoryLimit { bytes: Some(bytes), source: LimitSource::Explicit }
    }

    /// No limit.
    pub fn unlimited() -> MemoryLimit {
        MemoryLimit { bytes: None, source: LimitSource::Explicit }
    }

    /// The limit from `EMBER_MEMORY_LIMIT`, else from the available memory. An unreadable
    /// value of the variable is an error.
    pub fn from_env() -> Result<MemoryLimit, String> {
        match std::env::var(ENV) {
            Ok(v) => {
                let bytes = parse_size(&v).map_err(|e| format!("{ENV}={v:?}: {e}"))?;
                Ok(MemoryLimit { bytes, source: LimitSource::Env })
            }
            Err(std::env::VarError::NotUnicode(v)) => Err(format!("{ENV}={v:?}: not a size")),
            Err(std::env::VarError::NotPresent) => Ok(Self::from_available(mem_available())),
        }
    }

    /// 75% of `available` bytes, or the fallback when unknown.
    pub fn from_available(available: Option<u64>) -> MemoryLimit {
        match available {
            Some(a) => {
                MemoryLimit { bytes: Some((a as f64 * AVAILABLE_SHARE) as u64), source: LimitSource::Available(a) }
            }
            None => MemoryLimit { bytes: Some(FALLBACK_BYTES), source: LimitSource::Fallback },
        }
    }

    /// The process-wide limit, read once ([`MemoryLimit::from_env`]; an unreadable
    /// `EMBER_MEMORY_LIMIT` is ignored here — the command line reports it before loading).
    pub fn current() -> MemoryLimit {
        static LIMIT: OnceLock<MemoryLimit> = OnceLock::new();
        *LIMIT.get_or_init(|| Self::from_env().unwrap_or_else(|_| Self::from_available(mem_available())))
    }

    /// Refuses `needed` bytes for `what` (`purpose` says what the memory is for) when they
    /// exceed the limit.
    pub fn check(&self, what: impl Into<String>, purpose: &str, needed: u64) -> Result<(), LimitError> {
        match self.bytes {
            Some(limit) if needed > limit => Err(LimitError {
                what: what.into(),
                purpose: purpose.to_string(),
                needed,
                limit,
                source_text: self.source_text(),
            }),
            _ => Ok(()),
        }
    }

    fn source_text(&self) -> String {
        match self.source {
            LimitSource::Env => format!("set by {ENV}"),
            LimitSource::Available(a) => {
                format!("{:.0}% of the {} available; set {ENV} to change it", AVAILABLE_SHARE * 100.0, format_bytes(a))
            }
            LimitSource::Fallback => format!("available memory unknown; set {ENV} to change it"),
            LimitSource::Explicit => "given".to_string(),
        }
    }
}

/// The memory a load may use (see the module documentation). Loaders ask it before each
/// step that allocates ([`LoadBudget::admit`]) and tell it what they keep
/// ([`LoadBudget::keep`]).
#[derive(Debug)]
pub struct LoadBudget {
    limit: MemoryLimit,
    kept: Cell<u64>,
    /// The accelerator's bytes per triangle and per sphere or cylinder (0: none counted).
    accel_per_triangle: u64,
    accel_per_shape: u64,
    /// Whether a film is counted, and the image size given on the command line, which wins
    /// over the scene file's.
    film: Option<(Option<u32>, Option<u32>)>,
    /// Whether a model may name files outside its folder
    /// ([`crate::scene::input::named_file`]): part of the load's terms, as its memory is.
    external_files: bool,
}

impl LoadBudget {
    /// A budget of `limit` with nothing kept yet, counting no film and no accelerator.
    pub fn new(limit: MemoryLimit) -> LoadBudget {
        LoadBudget {
            limit,
            kept: Cell::new(0),
            accel_per_triangle: 0,
            accel_per_shape: 0,
            film: None,
            external_files: false,
        }
    }

    /// The same budget, letting models name files outside their folder if `allow`
    /// (`--allow-external-files`).
    pub fn with_external_files(self, allow: bool) -> LoadBudget {
        LoadBudget { external_files: allow, ..self }
    }

    /// Whether models may name files outside their folder.
    pub fn external_files(&self) -> bool {
        self.external_files
    }

    /// No limit.
    pub fn unlimited() -> LoadBudget {
        LoadBudget::new(MemoryLimit::unlimited())
    }

    /// Counts an Embree BVH over everything loaded ([`embree_bytes`]) and the film of an
    /// image `width` x `height` (each `None`: the scene file's, else the default), which
    /// [`LoadBudget::keep_film`] adds once the scene's own size is known.
    pub fn for_render(limit: MemoryLimit, embree: bool, width: Option<u32>, height: Option<u32>) -> LoadBudget {
        LoadBudget { film: Some((width, height)), ..LoadBudget::for_accel(limit, embree) }
    }

    /// Counts an Embree BVH over everything loaded (with `embree`), and no film.
    pub fn for_accel(limit: MemoryLimit, embree: bool) -> LoadBudget {
        let (accel_per_triangle, accel_per_shape) =
            if embree { (EMBREE_BYTES_PER_TRIANGLE, EMBREE_BYTES_PER_SHAPE) } else { (0, 0) };
        LoadBudget { accel_per_triangle, accel_per_shape, ..LoadBudget::new(limit) }
    }

    /// The limit it checks against.
    pub fn limit(&self) -> &MemoryLimit {
        &self.limit
    }

    /// Bytes kept so far.
    pub fn kept(&self) -> u64 {
        self.kept.get()
    }

    /// Bytes a step may still take beside what is kept (`None`: no limit).
    pub fn available(&self) -> Option<u64> {
        self.limit.bytes.map(|l| l.saturating_sub(self.kept.get()))
    }

    /// Refuses a step that needs `peak` bytes at its height, for `what`, if they do not fit
    /// beside what is kept.
    pub fn admit(&self, what: impl Into<String>, peak: u64) -> Result<(), LimitError> {
        let kept = self.kept.get();
        let purpose = if kept == 0 {
            "to load".to_string()
        } else {
            format!("to load, with the {} already loaded", format_bytes(kept))
        };
        self.limit.check(what, &purpose, kept.saturating_add(peak))
    }

    /// Records `bytes` more kept.
    pub fn keep(&self, bytes: u64) {
        self.kept.set(self.kept.get().saturating_add(bytes));
    }

    /// Keeps `triangles` triangles and `shapes` spheres and cylinders: their share of the
    /// accelerator (their own data is kept by the loader that reads them).
    pub fn keep_primitives(&self, triangles: u64, shapes: u64) {
        self.keep(
            triangles
                .saturating_mul(self.accel_per_triangle)
                .saturating_add(shapes.saturating_mul(self.accel_per_shape)),
        );
    }

    /// Keeps the film of the image the render will have, if a film is counted: the command
    /// line's size, else the scene file's (`width`, `height`), else `default`; refused if it
    /// does not fit.
    pub fn keep_film(&self, width: Option<u32>, height: Option<u32>, default: (u32, u32)) -> Result<(), LimitError> {
        let Some((cli_w, cli_h)) = self.film else { return Ok(()) };
        let w = cli_w.or(width).unwrap_or(default.0);
        let h = cli_h.or(height).unwrap_or(default.1);
        let bytes = film_bytes(w, h);
        let kept = self.kept.get();
        let purpose = if kept == 0 {
            "of film memory".to_string()
        } else {
            format!("of film memory, with the {} already loaded", format_bytes(kept))
        };
        self.limit.check(format!("image {w}x{h}"), &purpose, kept.saturating_add(bytes))?;
        self.keep(bytes);
        Ok(())
    }
}

/// `MemAvailable` from `/proc/meminfo`, in bytes.
pub fn mem_available() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    parse_meminfo(&text)
}

fn parse_meminfo(text: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let mut parts = line.split_whitespace().skip(1);
    let value: u64 = parts.next()?.parse().ok()?;
    match parts.next() {
        Some("kB") => value.checked_mul(1024),
        None => Some(value),
        _ => None,
    }
}

/// Parses a size: a number with an optional unit (`K`, `M`, `G`, `T` = powers of 1000,
/// with or without `B`; `KiB`, `MiB`, `GiB`, `TiB` = powers of 1024), or `off` (no limit).
pub fn parse_size(s: &str) -> Result<Option<u64>, String> {
    let s = s.trim();
    if s.eq_ignore_ascii_case("off") || s.eq_ignore_ascii_case("none") {
        return Ok(None);
    }
    let split = s.find(|c: char| !(c.is_ascii_digit() || c == '.')).unwrap_or(s.len());
    let (number, unit) = s.split_at(split);
    let number: f64 = number.parse().map_err(|_| "not a size (use e.g. 8G, 512M, 1.5GiB or off)".to_string())?;
    let scale: f64 = match unit.trim().to_ascii_lowercase().as_str() {
        "" | "b" => 1.0,
        "k" | "kb" => 1e3,
        "m" | "mb" => 1e6,
        "g" | "gb" => 1e9,
        "t" | "tb" => 1e12,
        "kib" => 1024.0,
        "mib" => 1024.0 * 1024.0,
        "gib" => 1024.0 * 1024.0 * 1024.0,
        "tib" => 1024.0 * 1024.0 * 1024.0 * 1024.0,
        u => return Err(format!("unknown unit {u:?} (use K, M, G, T, KiB, MiB, GiB, TiB or off)")),
    };
    let bytes = number * scale;
    if !bytes.is_finite() || bytes >= u64::MAX as f64 {
        return Err("too large".to_string());
    }
    Ok(Some(bytes as u64))
}

/// `1234567` → `1.2 MB` (powers of 1000).
pub fn format_bytes(b: u64) -> String {
    const UNITS: [&str; 5] = ["bytes", "kB", "MB", "GB", "TB"];
    let mut v = b as f64;
    let mut u = 0;
    while v >= 1000.0 && u + 1 < UNITS.len() {
        v /= 1000.0;
        u += 1;
    }
    if u == 0 { format!("{b} bytes") } else { format!("{v:.1} {}", UNITS[u]) }
}

/// Bytes per pixel while rendering and writing the image: the accumulator (f64 sums, second
/// moment and count: 40 bytes), the film (12) and the 8-bit output (3) — measured 54.9 bytes
/// per pixel peak for 4096x4096 to PNG, 52.0 to EXR.
pub const FILM_BYTES_PER_PIXEL: u64 = 56;

/// Bytes per pixel more while a checkpoint is written (periodically, or when the render is
/// interrupted — which can always happen): a copy of the accumulator (40) and the file's bytes
/// (36) — measured 115 bytes per pixel peak in all for 1024x1024 with `--checkpoint-every 1s`.
pub const CHECKPOINT_BYTES_PER_PIXEL: u64 = 60;

/// Memory to render a `width` x `height` image, including writing a checkpoint.
pub fn film_bytes(width: u32, height: u32) -> u64 {
    (width as u64 * height as u64).saturating_mul(FILM_BYTES_PER_PIXEL + CHECKPOINT_BYTES_PER_PIXEL)
}

/// Bytes per pixel more when a render keeps the auxiliary images (`--aux`, `--denoise`): their
/// sums (48) and their copy in a checkpoint (48), the albedo, normal and sample-count images
/// (28) and the EXR layers' buffers while written — measured 169 bytes per pixel peak in all for
/// 2000x2000 to EXR with `--aux`, 60 without.
pub const AUX_BYTES_PER_PIXEL: u64 = 160;

/// Bytes per pixel more in an adaptive render: its plan (first-round rays, target and sums of
/// squares: 32) and its copy in a checkpoint (32).
pub const ADAPTIVE_BYTES_PER_PIXEL: u64 = 64;

/// Bytes per pixel more while denoising, besides the denoiser's scratch memory
/// ([`denoiser_scratch_bytes`]): the colour, albedo and normal images (36), their prefiltered
/// copies (24) and the output (12).
pub const DENOISE_BYTES_PER_PIXEL: u64 = 72;

/// Bytes per pixel more in a render that traces caustic light paths: their sums while traced
/// (24), kept (24) and in a checkpoint (24); in a merge, the sums and a shard's being read.
pub const LIGHT_PATHS_BYTES_PER_PIXEL: u64 = 72;

/// Memory a `width` x `height` render's caustic light paths take beside its film.
pub fn light_paths_bytes(width: u32, height: u32) -> u64 {
    (width as u64 * height as u64).saturating_mul(LIGHT_PATHS_BYTES_PER_PIXEL)
}

/// The scratch memory Open Image Denoise is told it may use (its `maxMemoryMB`; it tiles the
/// image to stay near it): what the limit leaves (`available`), at most 3 GB (about what it
/// takes untold: 2.8 GB for 2000x2000), at least 200 MB. `None`: not even that fits.
pub fn denoiser_scratch_bytes(available: Option<u64>) -> Option<u64> {
    const MOST: u64 = 3_000_000_000;
    const LEAST: u64 = 200_000_000;
    let scratch = available.map_or(MOST, |a| a.min(MOST));
    (scratch >= LEAST).then_some(scratch)
}

/// Memory a `width` x `height` render takes beside its film ([`film_bytes`]): the auxiliary
/// images if `aux`, an adaptive plan if `adaptive`, the denoiser's images if `denoise` (its
/// scratch memory apart).
pub fn render_extra_bytes(width: u32, height: u32, aux: bool, adaptive: bool, denoise: bool) -> u64 {
    let per_pixel = aux as u64 * AUX_BYTES_PER_PIXEL
        + adaptive as u64 * ADAPTIVE_BYTES_PER_PIXEL
        + denoise as u64 * DENOISE_BYTES_PER_PIXEL;
    (width as u64 * height as u64).saturating_mul(per_pixel)
}

/// Bytes per pixel while a texture is decoded: the decoded image (up to 8 bytes per pixel
/// for 16-bit RGBA), its 8-bit RGB copy (3) and the linear RGB f32 texture (12).
pub const TEXTURE_BYTES_PER_PIXEL: u64 = 23;

/// Memory to load a `width` x `height` texture.
pub fn texture_bytes(width: u32, height: u32) -> u64 {
    (width as u64 * height as u64).saturating_mul(TEXTURE_BYTES_PER_PIXEL)
}

/// Bytes per pixel while an HDR image (OpenEXR, Radiance) is decoded: the decoded image (up to
/// 16 bytes per pixel for f32 RGBA) and the linear RGB f32 image kept (12).
pub const HDR_IMAGE_BYTES_PER_PIXEL: u64 = 28;

/// Memory to load a `width` x `height` HDR image.
pub fn hdr_image_bytes(width: u32, height: u32) -> u64 {
    (width as u64 * height as u64).saturating_mul(HDR_IMAGE_BYTES_PER_PIXEL)
}

/// Bytes per pixel of an environment image's sampling distribution while it is built: the
/// luminance (4, freed after) and the per-pixel density and cumulative sums kept (8).
pub const ENVIRONMENT_SAMPLING_BYTES_PER_PIXEL: u64 = 12;

/// Memory to build the sampling distribution of a `width` x `height` environment image.
pub fn environment_sampling_bytes(width: u32, height: u32) -> u64 {
    (width as u64 * height as u64).saturating_mul(ENVIRONMENT_SAMPLING_BYTES_PER_PIXEL)
}

/// Memory Embree needs for `triangles` triangles and `shapes` user primitives (spheres,
/// cylinders): its copies of the vertex and index buffers and the BVH being built (measured,
/// medium build quality: 114 bytes per triangle for a 1,000,000-triangle height field, 113
/// per sphere for 1,000,000 spheres).
pub fn embree_bytes(triangles: u64, shapes: u64) -> u64 {
    triangles.saturating_mul(EMBREE_BYTES_PER_TRIANGLE).saturating_add(shapes.saturating_mul(EMBREE_BYTES_PER_SHAPE))
}

const EMBREE_BYTES_PER_TRIANGLE: u64 = 125;
const EMBREE_BYTES_PER_SHAPE: u64 = 125;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse() {
        assert_eq!(parse_size("512M"), Ok(Some(512_000_000)));
        assert_eq!(parse_size("2G"), Ok(Some(2_000_000_000)));
        assert_eq!(parse_size("1.5GiB"), Ok(Some(1_610_612_736)));
        assert_eq!(parse_size("100"), Ok(Some(100)));
        assert_eq!(parse_size(" 8 gb "), Ok(Some(8_000_000_000)));
        assert_eq!(parse_size("off"), Ok(None));
        assert!(parse_size("lots").is_err());
        assert!(parse_size("5X").is_err());
        assert!(parse_size("").is_err());
        assert!(parse_size("1e30T").is_err());
    }

    #[test]
    fn meminfo_parses() {
        let text = "MemTotal:       24683656 kB\nMemFree:        1000 kB\nMemAvailable:   24077712 kB\n";
        assert_eq!(parse_meminfo(text), Some(24_077_712 * 1024));
        assert_eq!(parse_meminfo("MemTotal: 5 kB\n"), None);
        let limit = MemoryLimit::from_available(Some(4_000_000_000));
        assert_eq!(limit.bytes, Some(3_000_000_000));
        assert_eq!(MemoryLimit::from_available(None).bytes, Some(FALLBACK_BYTES));
    }

    #[test]
    fn check_refuses_with_the_estimate() {
        let limit = MemoryLimit::from_available(Some(2_000_000_000));
        let e = limit.check("image 16384x16384", "of film memory", film_bytes(16384, 16384)).unwrap_err();
        assert_eq!(
            e.to_string(),
            "image 16384x16384 needs ~31.1 GB of film memory, more than the 1.5 GB limit \
             (75% of the 2.0 GB available; set EMBER_MEMORY_LIMIT to change it)"
        );
        assert!(limit.check("image 640x480", "of film memory", film_bytes(640, 480)).is_ok());
        assert!(MemoryLimit::unlimited().check("x", "", u64::MAX).is_ok());
        assert!(MemoryLimit::bytes(100).check("x", "", 100).is_ok());
        assert!(MemoryLimit::bytes(100).check("x", "", 101).is_err());
    }

    #[test]
    fn bytes_format() {
        assert_eq!(format_bytes(999), "999 bytes");
        assert_eq!(format_bytes(1_500), "1.5 kB");
        assert_eq!(format_bytes(3_221_225_472), "3.2 GB");
    }
}

//! Checkpoints: the accumulated samples of an unfinished render, saved so that it can be
//! resumed and end in the same image, bit for bit, as an uninterrupted render.
//!
//! A checkpoint records what it belongs to — a scene fingerprint and a description of the
//! image-affecting settings as `key=value` words — and is only ever read for a given render
//! ([`CheckpointKey`]): a file that is not a regular file of exactly the size that render's
//! checkpoint has is refused before anything is read from it, and one whose scene, settings or
//! image size differ, or whose pixels could not have come from that render (a sum that is not
//! finite, more samples than the render takes), is refused naming what is wrong. The file is
//! binary (little-endian), ends with a checksum, and is written atomically, so a crash while
//! writing leaves the previous checkpoint intact.
//!
//! Layout: `EMBERCK\x01`, scene (u64), settings length (u32) and text, non-finite samples
//! (u64), elapsed nanoseconds (u64), width and height (u32), then per pixel its count (u32)
//! and sums r, g, b and of squared luminance (f64) — followed, in a render that takes the
//! auxiliary images (its settings then hold `aux=albedo+normal`), by the sums of its albedo
//! r, g, b and normal x, y, z (f64), then, in an adaptive render (its settings then hold
//! `adaptive=relmse-5x5`), the rays of its first round and its planned sample count (u32, 0 before
//! the plan) and its first round's sums of squares r, g, b (f64) — then, in a render that traces
//! caustic light paths (its settings then hold `caustics=light-paths`), what they add to each
//! pixel (r, g, b as i64, [`LightSums`]), and the FNV-1a hash of all that (u64).

use super::accum::{Accumulator, AdaptivePixel, AuxSums, LUMINANCE, LightSums, PixelState};
use crate::hash::Fnv1a;
use glam::DVec3;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::time::Duration;

const MAGIC: &[u8; 8] = b"EMBERCK\x01";
/// Bytes of a pixel: count (u32) and four f64 sums.
pub(super) const PIXEL_BYTES: u64 = 36;
/// Bytes of a pixel's auxiliary sums, when the render takes them: six f64 (albedo, normal).
pub(super) const AUX_BYTES: u64 = 48;
/// Bytes of a pixel's part in an adaptive render's plan: first-round rays and target (u32),
/// first-round sums of squares (three f64).
pub(super) const ADAPTIVE_BYTES: u64 = 32;
/// Bytes of a pixel's light-path sums ([`LightSums`]): three i64.
pub(super) const LIGHT_BYTES: u64 = 24;
/// Magic, scene and settings length: what comes before the settings text.
const PREFIX_BYTES: u64 = 8 + 8 + 4;
/// Non-finite count, elapsed time, width and height: between the settings and the pixels.
const FIELDS_BYTES: u64 = 8 + 8 + 4 + 4;
const CHECKSUM_BYTES: u64 = 8;
/// The most of a checkpoint of the wrong size that is read, to say what it belongs to.
const DIAGNOSIS_BYTES: u64 = 64 * 1024;

/// An unfinished render.
#[derive(Clone, Debug, PartialEq)]
pub struct Checkpoint {
    /// [`crate::scene::Scene::fingerprint`] of the scene rendered.
    pub scene: u64,
    /// The settings that affect the image, as space-separated `key=value` words.
    pub settings: String,
    /// Non-finite samples dropped so far.
    pub nonfinite: u64,
    /// Render time spent so far.
    pub elapsed: Duration,
    pub accum: Accumulator,
}

/// The render a checkpoint must belong to (`crate::integrator::RenderPlan::checkpoint_key`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CheckpointKey {
    /// [`crate::scene::Scene::fingerprint`] of the scene.
    pub scene: u64,
    /// Everything else that changes the image, as space-separated `key=value` words.
    pub settings: String,
    pub width: u32,
    pub height: u32,
    /// The most samples any pixel takes.
    pub spp: u32,
    /// Whether the render takes the auxiliary images (and its checkpoint holds their sums).
    pub aux: bool,
    /// Whether the render is adaptive (and its checkpoint holds each pixel's plan).
    pub adaptive: bool,
    /// Whether the render traces light paths (and its checkpoint holds their sums).
    pub light: bool,
}

impl CheckpointKey {
    /// The size in bytes of a checkpoint of this render.
    pub fn file_size(&self) -> u64 {
        PREFIX_BYTES
            + self.settings.len() as u64
            + FIELDS_BYTES
            + self.width as u64 * self.height as u64 * (self.pixel_bytes() + if self.light { LIGHT_BYTES } else { 0 })
            + CHECKSUM_BYTES
    }

    /// The bytes of one pixel's record.
    fn pixel_bytes(&self) -> u64 {
        PIXEL_BYTES + if self.aux { AUX_BYTES } else { 0 } + if self.adaptive { ADAPTIVE_BYTES } else { 0 }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum CheckpointError {
    #[error("{}: no checkpoint to resume from (it is written when a render is interrupted)", .0.display())]
    Missing(PathBuf),
    #[error("{}: cannot read checkpoint: {}", .0.display(), .1)]
    Read(PathBuf, String),
    #[error("{}: not a valid ember checkpoint ({})", .0.display(), .1)]
    Corrupt(PathBuf, String),
    #[error("{}: checkpoint is for a different scene (the scene or a file it uses changed since)", .0.display())]
    OtherScene(PathBuf),
    #[error("{}: checkpoint was made with different settings: {}", .0.display(), .1)]
    OtherSettings(PathBuf, String),
    #[error(transparent)]
    Write(#[from] crate::atomic_write::WriteError),
}

/// Where the checkpoint of a render writing `output` lives: next to it.
pub fn checkpoint_path(output: &Path) -> PathBuf {
    let mut name = output.file_name().map(|n| n.to_os_string()).unwrap_or_default();
    name.push(".checkpoint");
    output.with_file_name(name)
}

/// A writer that hashes what goes through it.
pub(super) struct Hashing<W> {
    pub(super) inner: W,
    pub(super) hash: Fnv1a,
}

impl<W: Write> Write for Hashing<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.hash.write(&buf[..n]);
        Ok(n)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

impl Checkpoint {
    /// The [`CheckpointKey`] this checkpoint answers to.
    pub fn key(&self, spp: u32) -> CheckpointKey {
        CheckpointKey {
            scene: self.scene,
            settings: self.settings.clone(),
            width: self.accum.width,
            height: self.accum.height,
            spp,
            aux: self.accum.aux.is_some(),
            adaptive: self.accum.adaptive.is_some(),
            light: self.accum.light.is_some(),
        }
    }

    /// The checkpoint's bytes, to `out` (buffered by the caller).
    pub fn write_to(&self, out: impl Write) -> std::io::Result<()> {
        let mut w = Hashing { inner: out, hash: Fnv1a::default() };
        w.write_all(MAGIC)?;
        w.write_all(&self.scene.to_le_bytes())?;
        w.write_all(&(self.settings.len() as u32).to_le_bytes())?;
        w.write_all(self.settings.as_bytes())?;
        w.write_all(&self.nonfinite.to_le_bytes())?;
        w.write_all(&(self.elapsed.as_nanos().min(u64::MAX as u128) as u64).to_le_bytes())?;
        w.write_all(&self.accum.width.to_le_bytes())?;
        w.write_all(&self.accum.height.to_le_bytes())?;
        for (i, p) in self.accum.pixels.iter().enumerate() {
            w.write_all(&encode_pixel(p))?;
            if let Some(aux) = &self.accum.aux {
                w.write_all(&encode_aux(&aux[i]))?;
            }
            if let Some(plan) = &self.accum.adaptive {
                w.write_all(&encode_plan(&plan[i]))?;
            }
        }
        if let Some(light) = &self.accum.light {
            write_light(&mut w, light)?;
        }
        let sum = w.hash.finish();
        w.inner.write_all(&sum.to_le_bytes())?;
        w.flush()
    }

    /// The checkpoint's bytes.
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut b = Vec::new();
        self.write_to(&mut b).expect("writing to memory does not fail");
        b
    }

    /// Writes the checkpoint to `path` atomically.
    pub fn save(&self, path: &Path) -> Result<(), CheckpointError> {
        crate::atomic_write::write_atomically(path, |file| {
            let mut out = std::io::BufWriter::new(file);
            self.write_to(&mut out).map_err(|e| e.to_string())?;
            out.into_inner().map(|_| ()).map_err(|e| e.error().to_string())
        })?;
        Ok(())
    }

    /// Reads the checkpoint at `path` for the render `key`, and checks it belongs to it and
    /// could have come from it ([`Checkpoint::check_matches`]). Only a regular file of exactly
    /// [`CheckpointKey::file_size`] bytes is read (a FIFO, a device or a file of another size
    /// is refused before reading it, save a little of the latter to say what it is for).
    pub fn load(path: &Path, key: &CheckpointKey) -> Result<Checkpoint, CheckpointError> {
        use std::os::unix::fs::OpenOptionsExt;
        let read_err = |e: std::io::Error| CheckpointError::Read(path.to_path_buf(), e.to_string());
        // Non-blocking: opening a FIFO must not wait for a writer (regular files ignore it).
        let file =
            std::fs::OpenOptions::new().read(true).custom_flags(libc::O_NONBLOCK | libc::O_NOCTTY).open(path).map_err(
                |e| match e.kind() {
                    std::io::ErrorKind::NotFound => CheckpointError::Missing(path.to_path_buf()),
                    _ => read_err(e),
                },
            )?;
        let meta = file.metadata().map_err(read_err)?;
        if meta.is_dir() {
            return Err(CheckpointError::Read(path.to_path_buf(), "is a directory".into()));
        }
        if !meta.is_file() {
            return Err(CheckpointError::Read(
                path.to_path_buf(),
                "is not a regular file (a FIFO, socket or device?)".into(),
            ));
        }
        let len = meta.len();
        let mut reader = std::io::BufReader::with_capacity(1 << 16, file);
        if len != key.file_size() {
            let mut head = Vec::new();
            (&mut reader).take(len.min(DIAGNOSIS_BYTES)).read_to_end(&mut head).map_err(read_err)?;
            return Err(wrong_size(path, &head, len, key));
        }
        Self::read_checked(&mut reader, path, key)
    }

    /// [`Checkpoint::load`] from the bytes of a file (`path` names it in messages).
    pub fn from_bytes(bytes: &[u8], path: &Path, key: &CheckpointKey) -> Result<Checkpoint, CheckpointError> {
        let len = bytes.len() as u64;
        if len != key.file_size() {
            let head = &bytes[..len.min(DIAGNOSIS_BYTES) as usize];
            return Err(wrong_size(path, head, len, key));
        }
        Self::read_checked(&mut &bytes[..], path, key)
    }

    /// Parses exactly `key.file_size()` bytes from `r`, then checks the checkpoint.
    fn read_checked(r: &mut dyn Read, path: &Path, key: &CheckpointKey) -> Result<Checkpoint, CheckpointError> {
        let corrupt = |why: String| CheckpointError::Corrupt(path.to_path_buf(), why);
        let io = |e: std::io::Error| match e.kind() {
            std::io::ErrorKind::UnexpectedEof => corrupt("truncated while reading".into()),
            _ => CheckpointError::Read(path.to_path_buf(), e.to_string()),
        };
        let mut hash = Fnv1a::default();
        let mut take = |n: usize| -> Result<Vec<u8>, CheckpointError> {
            let mut b = vec![0u8; n];
            r.read_exact(&mut b).map_err(io)?;
            hash.write(&b);
            Ok(b)
        };
        // The file has the expected size, so the settings length is at most that.
        let prefix = take(PREFIX_BYTES as usize)?;
        let settings_len = u32::from_le_bytes(prefix[16..20].try_into().unwrap()) as u64;
        let rest = key.file_size() - PREFIX_BYTES - FIELDS_BYTES - CHECKSUM_BYTES;
        if settings_len > rest {
            return Err(corrupt(format!("settings of {settings_len} bytes in a file that has {rest} left")));
        }
        let mut header_bytes = prefix;
        header_bytes.extend(take(settings_len as usize)?);
        header_bytes.extend(take(FIELDS_BYTES as usize)?);
        let header = Header::parse(&header_bytes).map_err(|why| corrupt(why.into()))?;
        if (header.width, header.height) != (key.width, key.height) || header.settings.len() != key.settings.len() {
            // Same size, other layout: say what the header claims.
            return Err(header.mismatch(path, key).unwrap_or_else(|| corrupt("damaged header".into())));
        }
        let mut accum = Accumulator::empty(header.width, header.height, key.aux, key.adaptive);
        let plan_at = (PIXEL_BYTES + if key.aux { AUX_BYTES } else { 0 }) as usize;
        let record = key.pixel_bytes() as usize;
        let mut chunk = vec![0u8; 4096 * record];
        for (c, pixels) in accum.pixels.chunks_mut(4096).enumerate() {
            let bytes = &mut chunk[..pixels.len() * record];
            r.read_exact(bytes).map_err(io)?;
            hash.write(bytes);
            for (j, (p, b)) in pixels.iter_mut().zip(bytes.chunks_exact(record)).enumerate() {
                *p = decode_pixel(b);
                if let Some(aux) = &mut accum.aux {
                    aux[c * 4096 + j] = decode_aux(&b[PIXEL_BYTES as usize..]);
                }
                if let Some(plan) = &mut accum.adaptive {
                    plan[c * 4096 + j] = decode_plan(&b[plan_at..]);
                }
            }
        }
        if key.light {
            let mut light = LightSums::new(accum.pixels.len());
            read_light(r, &mut hash, &mut light).map_err(io)?;
            if let Some(why) = light.0.iter().enumerate().find_map(|(i, s)| light_problem(i, s, header.width)) {
                return Err(corrupt(why));
            }
            accum.light = Some(light);
        }
        let mut tail = [0u8; CHECKSUM_BYTES as usize];
        r.read_exact(&mut tail).map_err(io)?;
        if hash.finish() != u64::from_le_bytes(tail) {
            return Err(corrupt("checksum mismatch: truncated or damaged".into()));
        }
        let c = Checkpoint {
            scene: header.scene,
            settings: header.settings,
            nonfinite: header.nonfinite,
            elapsed: header.elapsed,
            accum,
        };
        c.check_matches(path, key)?;
        Ok(c)
    }

    /// Checks that this checkpoint belongs to the render `key` (scene, settings, image size;
    /// the error names every setting that differs) and that its contents could have come from
    /// it: every sum finite, the sums of squares not negative, no pixel with more than
    /// `key.spp` samples, none without samples but with sums, no more non-finite samples than
    /// samples; and, with auxiliary sums, that there are as many as pixels, each albedo sum
    /// within [0, count] and each normal sum within [−count, count].
    pub fn check_matches(&self, path: &Path, key: &CheckpointKey) -> Result<(), CheckpointError> {
        if self.scene != key.scene {
            return Err(CheckpointError::OtherScene(path.to_path_buf()));
        }
        if self.settings != key.settings {
            return Err(CheckpointError::OtherSettings(
                path.to_path_buf(),
                settings_diff(&self.settings, &key.settings),
            ));
        }
        let corrupt = |why: String| CheckpointError::Corrupt(path.to_path_buf(), why);
        let a = &self.accum;
        if (a.width, a.height) != (key.width, key.height) {
            return Err(corrupt(format!(
                "its image is {}x{} but its settings say {}x{}",
                a.width, a.height, key.width, key.height
            )));
        }
        if a.pixels.len() as u64 != a.width as u64 * a.height as u64 {
            return Err(corrupt(format!("{} pixels for a {}x{} image", a.pixels.len(), a.width, a.height)));
        }
        match (&a.aux, key.aux) {
            (Some(aux), true) if aux.len() == a.pixels.len() => {}
            (Some(aux), true) => {
                return Err(corrupt(format!("{} auxiliary sums for {} pixels", aux.len(), a.pixels.len())));
            }
            (None, false) => {}
            (had, _) => {
                let (was, now) = if had.is_some() { ("with", "without") } else { ("without", "with") };
                return Err(corrupt(format!(
                    "it was saved {was} the auxiliary images (albedo, normal), this render takes them {now}"
                )));
            }
        }
        match (&a.adaptive, key.adaptive) {
            (Some(plan), true) if plan.len() == a.pixels.len() => {}
            (None, false) => {}
            _ => return Err(corrupt("its adaptive plan does not match this render's".into())),
        }
        let mut samples = 0u64;
        for (i, p) in a.pixels.iter().enumerate() {
            let problem = pixel_problem(p, key.spp);
            let problem = problem.or_else(|| {
                let plan = a.adaptive.as_ref()?[i];
                let t = plan.target;
                sum_sq_problem(&plan).or_else(|| {
                    (t > key.spp || (t > 0 && p.count > t))
                        .then(|| format!("{} samples planned (of at most {}), {} taken", t, key.spp, p.count))
                })
            });
            let problem = problem.or_else(|| a.aux.as_ref().and_then(|aux| check_aux(&aux[i], p.count).err()));
            if let Some(why) = problem {
                let (x, y) = (i % a.width as usize, i / a.width as usize);
                return Err(corrupt(format!("pixel ({x}, {y}): {why}")));
            }
            samples += p.count as u64;
        }
        if self.nonfinite > samples {
            return Err(corrupt(format!("{} non-finite samples of {samples} samples in all", self.nonfinite)));
        }
        Ok(())
    }
}

/// Writes `light`'s sums, pixel by pixel.
fn write_light(w: &mut impl Write, light: &LightSums) -> std::io::Result<()> {
    let mut buf = Vec::with_capacity(4096 * LIGHT_BYTES as usize);
    for chunk in light.0.chunks(4096) {
        buf.clear();
        for s in chunk {
            buf.extend_from_slice(&encode_light(s));
        }
        w.write_all(&buf)?;
    }
    Ok(())
}

/// Reads the sums [`write_light`] wrote into `light` (sized for them), hashing the bytes.
fn read_light(r: &mut dyn Read, hash: &mut Fnv1a, light: &mut LightSums) -> std::io::Result<()> {
    let mut buf = vec![0u8; 4096 * LIGHT_BYTES as usize];
    for chunk in light.0.chunks_mut(4096) {
        let bytes = &mut buf[..chunk.len() * LIGHT_BYTES as usize];
        r.read_exact(bytes)?;
        hash.write(bytes);
        for (s, b) in chunk.iter_mut().zip(bytes.chunks_exact(LIGHT_BYTES as usize)) {
            *s = decode_light(b);
        }
    }
    Ok(())
}

/// One pixel's light-path sums as stored ([`LIGHT_BYTES`], little-endian).
pub(super) fn encode_light(s: &[i64; 3]) -> [u8; LIGHT_BYTES as usize] {
    let mut b = [0u8; LIGHT_BYTES as usize];
    for (c, v) in s.iter().enumerate() {
        b[8 * c..8 * c + 8].copy_from_slice(&v.to_le_bytes());
    }
    b
}

/// The sums [`encode_light`] stored in the first [`LIGHT_BYTES`] of `b`.
pub(super) fn decode_light(b: &[u8]) -> [i64; 3] {
    std::array::from_fn(|c| i64::from_le_bytes(b[8 * c..8 * c + 8].try_into().unwrap()))
}

/// Why the light-path sums `s` of pixel `i` of an image `width` pixels wide could not come
/// from a render, if they could not: light paths only add light.
pub(super) fn light_problem(i: usize, s: &[i64; 3], width: u32) -> Option<String> {
    let (x, y) = (i % width as usize, i / width as usize);
    s.iter().any(|&v| v < 0).then(|| format!("pixel ({x}, {y}): a negative light-path sum"))
}

/// Whether a pixel's auxiliary sums could come from `count` samples: finite, each albedo in
/// [0, 1] and each normal component in [−1, 1] (with room for rounding in the sums).
pub(super) fn check_aux(a: &AuxSums, count: u32) -> Result<(), String> {
    let n = count as f64 * (1.0 + 1e-9);
    if !(a.albedo.is_finite() && a.normal.is_finite()) {
        return Err(format!("its auxiliary sums are not finite (albedo {}, normal {})", a.albedo, a.normal));
    }
    if a.albedo.min_element() < 0.0 || a.albedo.max_element() > n {
        return Err(format!("the sum of its albedos {} is outside [0, {count}]", a.albedo));
    }
    if a.normal.abs().max_element() > n {
        return Err(format!("the sum of its normals {} is outside [-{count}, {count}]", a.normal));
    }
    Ok(())
}

/// A pixel's auxiliary sums as stored: albedo then normal, six f64, little-endian.
pub(super) fn encode_aux(a: &AuxSums) -> [u8; AUX_BYTES as usize] {
    let mut b = [0u8; AUX_BYTES as usize];
    for (chunk, x) in
        b.chunks_exact_mut(8).zip([a.albedo.x, a.albedo.y, a.albedo.z, a.normal.x, a.normal.y, a.normal.z])
    {
        chunk.copy_from_slice(&x.to_le_bytes());
    }
    b
}

/// [`encode_aux`] read back from the first [`AUX_BYTES`] of `b`.
pub(super) fn decode_aux(b: &[u8]) -> AuxSums {
    let f = |i: usize| f64::from_le_bytes(b[8 * i..8 * i + 8].try_into().unwrap());
    AuxSums { albedo: DVec3::new(f(0), f(1), f(2)), normal: DVec3::new(f(3), f(4), f(5)) }
}

/// A pixel's part in an adaptive render's plan as stored: first-round rays and target (u32),
/// first-round sums of squares r, g, b (f64), little-endian.
pub(super) fn encode_plan(a: &AdaptivePixel) -> [u8; ADAPTIVE_BYTES as usize] {
    let mut b = [0u8; ADAPTIVE_BYTES as usize];
    b[..4].copy_from_slice(&a.rays.to_le_bytes());
    b[4..8].copy_from_slice(&a.target.to_le_bytes());
    for (i, x) in a.sum_sq.to_array().into_iter().enumerate() {
        b[8 + 8 * i..16 + 8 * i].copy_from_slice(&x.to_le_bytes());
    }
    b
}

/// [`encode_plan`] read back from the first [`ADAPTIVE_BYTES`] of `b`.
pub(super) fn decode_plan(b: &[u8]) -> AdaptivePixel {
    let u = |k: usize| u32::from_le_bytes(b[4 * k..4 * k + 4].try_into().unwrap());
    let f = |k: usize| f64::from_le_bytes(b[8 + 8 * k..16 + 8 * k].try_into().unwrap());
    AdaptivePixel { rays: u(0), target: u(1), sum_sq: DVec3::new(f(0), f(1), f(2)) }
}

/// Why a stored plan's first-round sums of squares could not have come from a render, if they
/// could not: one is negative or not finite.
pub(super) fn sum_sq_problem(a: &AdaptivePixel) -> Option<String> {
    let s = a.sum_sq;
    (!(s.is_finite() && s.min_element() >= 0.0))
        .then(|| format!("first-round sums of squares {s} are not finite and non-negative"))
}

/// A pixel's state as stored: its count (u32) and sums r, g, b and of squared luminance (f64),
/// little-endian.
pub(super) fn encode_pixel(p: &PixelState) -> [u8; PIXEL_BYTES as usize] {
    let mut b = [0u8; PIXEL_BYTES as usize];
    b[..4].copy_from_slice(&p.count.to_le_bytes());
    for (i, x) in [p.sum.x, p.sum.y, p.sum.z, p.sum_lum_sq].into_iter().enumerate() {
        b[4 + 8 * i..12 + 8 * i].copy_from_slice(&x.to_le_bytes());
    }
    b
}

/// The pixel state of [`PIXEL_BYTES`] bytes written by [`encode_pixel`].
pub(super) fn decode_pixel(b: &[u8]) -> PixelState {
    let f = |i: usize| f64::from_le_bytes(b[4 + 8 * i..12 + 8 * i].try_into().unwrap());
    PixelState {
        count: u32::from_le_bytes(b[..4].try_into().unwrap()),
        sum: DVec3::new(f(0), f(1), f(2)),
        sum_lum_sq: f(3),
    }
}

/// Why a stored pixel could not have come from a render of `spp` samples per pixel, if it
/// could not: more samples, a sum that is not finite or negative, a negative or non-finite sum
/// of squares or one too small for the sum, sums without samples.
pub(super) fn pixel_problem(p: &PixelState, spp: u32) -> Option<String> {
    if p.count > spp {
        return Some(format!("{} samples, more than the {spp} a pixel of this render takes at most", p.count));
    }
    if !p.sum.is_finite() {
        return Some(format!("the sum of its samples is not finite ({})", p.sum));
    }
    if !(p.sum_lum_sq.is_finite() && p.sum_lum_sq >= 0.0) {
        return Some(format!(
            "the sum of its squared luminances is {} (must be finite and not negative)",
            p.sum_lum_sq
        ));
    }
    if p.count == 0 && (p.sum != DVec3::ZERO || p.sum_lum_sq != 0.0) {
        return Some("no samples, but sums that are not zero".into());
    }
    // Radiance is never negative (colours, emission and lights are not; a sample that is not
    // finite counts as 0).
    if p.sum.min_element() < 0.0 {
        return Some(format!("the sum of its samples {} is negative, which radiance never is", p.sum));
    }
    // The sum of n luminances squared is at most n times the sum of their squares (Cauchy–
    // Schwarz), with room for rounding.
    let lum = p.sum.dot(LUMINANCE);
    if lum * lum > p.count as f64 * p.sum_lum_sq * (1.0 + 1e-6) + 1e-300 {
        return Some(format!(
            "the sum of its luminances ({lum}) is too large for the sum of their squares ({}) over {} samples",
            p.sum_lum_sq, p.count
        ));
    }
    None
}

/// `spp=16 in the checkpoint, spp=32 now; …` for every word of `now` that `was` lacks, and
/// every key of `was` that `now` lacks.
pub(super) fn settings_diff(was: &str, now: &str) -> String {
    words_diff(was, "in the checkpoint", now, "now")
}

/// `spp=16 {a_name}, spp=32 {b_name}; …` for every word of `b` that `a` lacks, and every key
/// of `a` that `b` lacks.
pub(super) fn words_diff(a: &str, a_name: &str, b: &str, b_name: &str) -> String {
    let key_of = |w: &str| w.split('=').next().unwrap_or(w).to_string();
    let mine: Vec<&str> = a.split_whitespace().collect();
    let theirs: Vec<&str> = b.split_whitespace().collect();
    let mut diffs: Vec<String> = theirs
        .iter()
        .filter(|w| !mine.contains(w))
        .map(|w| {
            let key = key_of(w);
            let old = mine.iter().find(|m| key_of(m) == key).copied().unwrap_or("(absent)");
            format!("{old} {a_name}, {w} {b_name}")
        })
        .collect();
    for m in &mine {
        if !theirs.iter().any(|w| key_of(w) == key_of(m)) {
            diffs.push(format!("{m} {a_name}, (absent) {b_name}"));
        }
    }
    if diffs.is_empty() {
        diffs.push(format!("{a:?} {a_name}, {b:?} {b_name}"));
    }
    diffs.join("; ")
}

/// What comes before the pixels.
struct Header {
    scene: u64,
    settings: String,
    nonfinite: u64,
    elapsed: Duration,
    width: u32,
    height: u32,
}

impl Header {
    /// Parses the header at the start of `b` (which may go on with pixels).
    fn parse(b: &[u8]) -> Result<Header, &'static str> {
        if b.len() < MAGIC.len() || &b[..MAGIC.len()] != MAGIC {
            return Err("wrong header");
        }
        let mut at = MAGIC.len();
        let mut take = |n: usize| -> Result<&[u8], &'static str> {
            let s = b.get(at..at.checked_add(n).ok_or("truncated")?).ok_or("truncated")?;
            at += n;
            Ok(s)
        };
        let scene = u64::from_le_bytes(take(8)?.try_into().unwrap());
        let len = u32::from_le_bytes(take(4)?.try_into().unwrap()) as usize;
        let settings = take(len)?;
        // Printed in messages: a terminal's escape sequences are refused, not printed.
        if !super::shard::settings_are_text(settings) {
            return Err("settings are not text");
        }
        let settings = std::str::from_utf8(settings).map_err(|_| "settings are not text")?.to_string();
        let nonfinite = u64::from_le_bytes(take(8)?.try_into().unwrap());
        let elapsed = Duration::from_nanos(u64::from_le_bytes(take(8)?.try_into().unwrap()));
        let width = u32::from_le_bytes(take(4)?.try_into().unwrap());
        let height = u32::from_le_bytes(take(4)?.try_into().unwrap());
        Ok(Header { scene, settings, nonfinite, elapsed, width, height })
    }

    /// How this header differs from the render `key`, if it does.
    fn mismatch(&self, path: &Path, key: &CheckpointKey) -> Option<CheckpointError> {
        if self.scene != key.scene {
            return Some(CheckpointError::OtherScene(path.to_path_buf()));
        }
        if self.settings != key.settings {
            return Some(CheckpointError::OtherSettings(
                path.to_path_buf(),
                settings_diff(&self.settings, &key.settings),
            ));
        }
        if (self.width, self.height) != (key.width, key.height) {
            return Some(CheckpointError::Corrupt(
                path.to_path_buf(),
                format!(
                    "its image is {}x{} but its settings say {}x{}",
                    self.width, self.height, key.width, key.height
                ),
            ));
        }
        None
    }
}

/// The error for a checkpoint of `len` bytes, not the `key.file_size()` of the render: what
/// its header (the start of it is `head`) says, when that explains it.
fn wrong_size(path: &Path, head: &[u8], len: u64, key: &CheckpointKey) -> CheckpointError {
    let corrupt = |why: String| CheckpointError::Corrupt(path.to_path_buf(), why);
    match Header::parse(head) {
        Err("wrong header") => corrupt("wrong header".into()),
        Ok(h) => h.mismatch(path, key).unwrap_or_else(|| {
            corrupt(format!(
                "{len} bytes, where a checkpoint of this {}x{} render has {}: truncated or damaged",
                key.width,
                key.height,
                key.file_size()
            ))
        }),
        Err(_) => corrupt(format!("{len} bytes, where a checkpoint of this render has {}: truncated", key.file_size())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn sample() -> Checkpoint {
        let mut accum = Accumulator::new(3, 2);
        for (i, p) in accum.pixels.iter_mut().enumerate() {
            for s in 0..i {
                p.add(Vec3::new(0.1 * s as f32, 1.0 / (1 + i) as f32, 3.0));
            }
        }
        Checkpoint {
            scene: 42,
            settings: "spp=16 seed=1".into(),
            nonfinite: 2,
            elapsed: Duration::from_millis(1500),
            accum,
        }
    }

    fn key() -> CheckpointKey {
        sample().key(16)
    }

    /// `c`'s bytes with its checksum recomputed after `edit`, as a forger would.
    fn forged(c: &Checkpoint, edit: impl FnOnce(&mut Vec<u8>)) -> Vec<u8> {
        let mut b = c.to_bytes();
        b.truncate(b.len() - 8);
        edit(&mut b);
        let sum = crate::hash::fnv1a(&b);
        b.extend_from_slice(&sum.to_le_bytes());
        b
    }

    fn refused(bytes: &[u8]) -> String {
        Checkpoint::from_bytes(bytes, Path::new("x.checkpoint"), &key()).unwrap_err().to_string()
    }

    #[test]
    fn light_path_sums_round_trip_and_are_checked() {
        let mut c = sample();
        c.accum.light = Some(LightSums((0..6).map(|i| [i, 2 * i, 1 << 40]).collect()));
        let key = c.key(16);
        assert!(key.light && key.file_size() == sample().key(16).file_size() + 6 * LIGHT_BYTES);
        let bytes = c.to_bytes();
        assert_eq!(Checkpoint::from_bytes(&bytes, Path::new("x"), &key).unwrap(), c);
        // A render only adds light: a negative sum is refused, naming the pixel.
        let at = bytes.len() - 8 - 2 * LIGHT_BYTES as usize;
        let bad = forged(&c, |b| b[at..at + 8].copy_from_slice(&(-5i64).to_le_bytes()));
        let e = Checkpoint::from_bytes(&bad, Path::new("x"), &key).unwrap_err().to_string();
        assert!(e.ends_with("(pixel (1, 1): a negative light-path sum)"), "{e}");
    }

    #[test]
    fn round_trips_exactly_and_detects_damage() {
        let dir = std::env::temp_dir().join(format!("ember-ckpt-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("x.png.checkpoint");
        let c = sample();
        c.save(&path).unwrap();
        assert_eq!(std::fs::metadata(&path).unwrap().len(), key().file_size());
        assert_eq!(Checkpoint::load(&path, &key()).unwrap(), c);
        let mut bytes = std::fs::read(&path).unwrap();
        bytes[60] ^= 1;
        std::fs::write(&path, &bytes).unwrap();
        let e = Checkpoint::load(&path, &key()).unwrap_err();
        assert!(e.to_string().ends_with("(checksum mismatch: truncated or damaged)"), "{e}");
        std::fs::write(&path, &bytes[..bytes.len() - 3]).unwrap();
        let e = Checkpoint::load(&path, &key()).unwrap_err();
        assert!(e.to_string().contains("truncated or damaged"), "{e}");
        assert!(matches!(Checkpoint::load(&dir.join("none"), &key()), Err(CheckpointError::Missing(..))));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn refuses_other_scenes_and_names_changed_settings() {
        let c = sample();
        let p = Path::new("x.checkpoint");
        assert!(c.check_matches(p, &key()).is_ok());
        let other = CheckpointKey { scene: 43, ..key() };
        assert!(matches!(c.check_matches(p, &other), Err(CheckpointError::OtherScene(_))));
        let e = c.check_matches(p, &CheckpointKey { settings: "spp=32 seed=1".into(), ..key() }).unwrap_err();
        assert!(e.to_string().contains("spp=16 in the checkpoint, spp=32 now"), "{e}");
        // A longer settings text makes a longer file: the header still says what differs.
        let now = CheckpointKey { settings: "spp=16 seed=1 accel=naive".into(), ..key() };
        let e = Checkpoint::from_bytes(&c.to_bytes(), p, &now).unwrap_err().to_string();
        assert!(e.ends_with("different settings: (absent) in the checkpoint, accel=naive now"), "{e}");
    }

    #[test]
    fn refuses_headers_that_lie_about_the_image_size() {
        for (w, h) in [(1u32, 1u32), (1 << 31, 1 << 31), (65536, 1)] {
            let bytes = forged(&sample(), |b| {
                let at = 20 + 13 + 16;
                b[at..at + 4].copy_from_slice(&w.to_le_bytes());
                b[at + 4..at + 8].copy_from_slice(&h.to_le_bytes());
            });
            assert_eq!(
                refused(&bytes),
                format!("x.checkpoint: not a valid ember checkpoint (its image is {w}x{h} but its settings say 3x2)")
            );
        }
    }

    #[test]
    fn refuses_contents_no_render_makes() {
        let edit = |f: fn(&mut PixelState)| {
            let mut c = sample();
            f(&mut c.accum.pixels[4]);
            c.to_bytes()
        };
        let e = refused(&edit(|p| p.sum.y = f64::NAN));
        assert!(
            e.contains("(pixel (1, 1): the sum of its samples is not finite ([") && e.contains(", NaN, 12]"),
            "{e}"
        );
        let e = refused(&edit(|p| p.sum.x = f64::INFINITY));
        assert!(e.contains("pixel (1, 1): the sum of its samples is not finite"), "{e}");
        let e = refused(&edit(|p| p.count = u32::MAX));
        assert!(
            e.ends_with("(pixel (1, 1): 4294967295 samples, more than the 16 a pixel of this render takes at most)"),
            "{e}"
        );
        let e = refused(&edit(|p| p.count = 17));
        assert!(e.contains("17 samples, more than the 16 a pixel"), "{e}");
        let e = refused(&edit(|p| p.sum_lum_sq = -1.0));
        assert!(e.contains("the sum of its squared luminances is -1 (must be finite and not negative)"), "{e}");
        let e = refused(&edit(|p| p.sum_lum_sq = f64::NAN));
        assert!(e.contains("squared luminances is NaN"), "{e}");
        let e = refused(&edit(|p| p.count = 0));
        assert!(e.contains("no samples, but sums that are not zero"), "{e}");
        let mut c = sample();
        c.nonfinite = 1000;
        assert!(refused(&c.to_bytes()).contains("1000 non-finite samples of 15 samples in all"));
        // Bytes that are not a checkpoint, of the right size or not.
        assert!(refused(&[0u8; 10]).ends_with("(wrong header)"));
        assert!(refused(&vec![0u8; key().file_size() as usize]).ends_with("(wrong header)"));
        assert!(refused(b"EMBERCK\x01").contains("truncated"));
        let huge_len = forged(&sample(), |b| b[16..20].copy_from_slice(&u32::MAX.to_le_bytes()));
        assert!(
            refused(&huge_len).contains("settings of 4294967295 bytes in a file that has"),
            "{}",
            refused(&huge_len)
        );
        // The sample itself is fine.
        assert_eq!(Checkpoint::from_bytes(&sample().to_bytes(), Path::new("x"), &key()).unwrap(), sample());
    }

    /// [`sample`] as an adaptive render's, its plan made.
    fn sample_adaptive() -> Checkpoint {
        let mut c = sample();
        c.settings.push_str(" adaptive=relmse-5x5");
        let plan = c.accum.pixels.iter().enumerate().map(|(i, p)| AdaptivePixel {
            rays: 3 * p.count,
            target: 8 + i as u32,
            sum_sq: DVec3::new(0.25, 0.5, 9.0) * p.count as f64,
        });
        c.accum.adaptive = Some(plan.collect());
        c
    }

    #[test]
    fn adaptive_plans_round_trip_and_are_checked() {
        let c = sample_adaptive();
        let key = c.key(16);
        assert!(key.adaptive);
        let bytes = c.to_bytes();
        assert_eq!(key.file_size(), sample().key(16).file_size() + " adaptive=relmse-5x5".len() as u64 + 6 * 32);
        let p = Path::new("x.checkpoint");
        assert_eq!(Checkpoint::from_bytes(&bytes, p, &key).unwrap(), c);
        let refused_plan = |f: fn(&mut AdaptivePixel)| {
            let mut c = sample_adaptive();
            f(&mut c.accum.adaptive.as_mut().unwrap()[4]);
            Checkpoint::from_bytes(&c.to_bytes(), p, &key).unwrap_err().to_string()
        };
        let e = refused_plan(|a| a.sum_sq.y = -1.0);
        assert!(
            e.contains("pixel (1, 1): first-round sums of squares [1, -1, 36] are not finite and non-negative"),
            "{e}"
        );
        let e = refused_plan(|a| a.sum_sq.z = f64::NAN);
        assert!(e.contains("are not finite"), "{e}");
        let e = refused_plan(|a| a.target = 17);
        assert!(e.contains("pixel (1, 1): 17 samples planned (of at most 16), 4 taken"), "{e}");
    }

    /// [`sample`] with auxiliary sums (albedo 0.5, normal +Z per sample).
    fn sample_with_aux() -> Checkpoint {
        let mut c = sample();
        c.settings.push_str(" aux=albedo+normal");
        let aux = c.accum.pixels.iter().map(|p| {
            let mut a = AuxSums::default();
            for _ in 0..p.count {
                a.add(Vec3::splat(0.5), Vec3::Z);
            }
            a
        });
        c.accum.aux = Some(aux.collect());
        c
    }

    #[test]
    fn auxiliary_sums_round_trip_and_are_checked() {
        let c = sample_with_aux();
        let key = c.key(16);
        assert!(key.aux);
        let bytes = c.to_bytes();
        assert_eq!(bytes.len() as u64, key.file_size());
        assert_eq!(key.file_size(), sample().key(16).file_size() + " aux=albedo+normal".len() as u64 + 6 * 48);
        let p = Path::new("x.checkpoint");
        assert_eq!(Checkpoint::from_bytes(&bytes, p, &key).unwrap(), c);
        let refused_aux = |f: fn(&mut AuxSums)| {
            let mut c = sample_with_aux();
            f(&mut c.accum.aux.as_mut().unwrap()[4]);
            Checkpoint::from_bytes(&c.to_bytes(), p, &key).unwrap_err().to_string()
        };
        let e = refused_aux(|a| a.albedo.x = f64::NAN);
        assert!(e.contains("pixel (1, 1): its auxiliary sums are not finite"), "{e}");
        let e = refused_aux(|a| a.albedo.y = 5.0);
        assert!(e.contains("pixel (1, 1): the sum of its albedos [2, 5, 2] is outside [0, 4]"), "{e}");
        let e = refused_aux(|a| a.albedo.z = -0.5);
        assert!(e.contains("is outside [0, 4]"), "{e}");
        let e = refused_aux(|a| a.normal.x = -4.5);
        assert!(e.contains("the sum of its normals [-4.5, 0, 4] is outside [-4, 4]"), "{e}");
        // With and without aux: the settings say which, and so does the size.
        let e = Checkpoint::from_bytes(&bytes, p, &sample().key(16)).unwrap_err().to_string();
        assert!(e.ends_with("different settings: aux=albedo+normal in the checkpoint, (absent) now"), "{e}");
        let mut no_aux = sample_with_aux();
        no_aux.accum.aux = None;
        let e = no_aux.check_matches(p, &key).unwrap_err().to_string();
        assert!(e.contains("saved without the auxiliary images"), "{e}");
    }

    #[test]
    fn lives_next_to_the_output() {
        assert_eq!(checkpoint_path(Path::new("out/teapot.png")), PathBuf::from("out/teapot.png.checkpoint"));
    }
}

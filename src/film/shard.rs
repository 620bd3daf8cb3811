//! Shard files: the pixels one shard of an image rendered (`ember render --shard K/N`), exactly
//! as the render accumulated them, for `ember merge` to put back together into the image a
//! whole render gives, bit for bit.
//!
//! A shard file records what it belongs to — the scene's fingerprint, the settings that change
//! the image as `key=value` words, the image size and spp, and which shard of how many it is —
//! so that the merge can refuse files of another scene or other settings, a duplicate or a
//! missing shard. Its pixels are those [`Shard::pixels`] lists, in that order; the file is
//! binary (little-endian), ends with a checksum and is written atomically.
//!
//! A shard rendered with `--aux` or `--denoise` also holds each pixel's albedo and normal sums,
//! so that the merged image can be denoised (`ember merge --denoise`, or by default when the
//! shards were rendered with `--denoise`): the flags say which.
//!
//! A shard of an adaptive render is rendered in two stages (`--first-round`, then
//! `--plan-from`): the first writes a *first-round* file, which also holds each pixel's part of
//! the plan (the first round's rays and sums of squares), and which only the second stage reads:
//! the merge refuses it.
//!
//! Layout: `EMBERSH\x03`, scene (u64), settings length (u32) and text, shard index and count,
//! width, height and spp (u32 each), non-finite samples (u64), render nanoseconds (u64), flags
//! (u32: 1 = auxiliary sums, 2 = denoising asked for, 4 = a first round, 8 = with the plan's
//! data, 16 = with light paths' sums), the number of light-path entries (u64), then per pixel
//! of the shard its count (u32) and sums r, g, b and of squared luminance (f64), with auxiliary
//! sums those of the albedo and normal (six f64), with the plan's data the first round's rays
//! and target (u32, target 0) and sums of squares r, g, b (f64), then the light-path entries:
//! each pixel of the image the shard's light paths reached, in increasing order, as its index
//! (u32) and what they add to it (r, g, b as i64, [`super::LightSums`]: the merge adds the
//! shards'), and the FNV-1a hash of all that (u64). The light paths' splats land anywhere in
//! the image, but only where a caustic is: the entries keep a shard file of a caustic in a
//! corner small. A file is read only if it is a regular file of exactly the size its header
//! implies, and every pixel must be one the render could have produced.

use super::accum::{Accumulator, LightSums, PixelState};
use super::checkpoint::{
    ADAPTIVE_BYTES, AUX_BYTES, Hashing, LIGHT_BYTES, PIXEL_BYTES, check_aux, decode_aux, decode_light, decode_pixel,
    decode_plan, encode_aux, encode_light, encode_pixel, encode_plan, light_problem, pixel_problem, sum_sq_problem,
    words_diff,
};
use crate::hash::Fnv1a;
use crate::settings::Shard;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::time::Duration;

const MAGIC: &[u8; 8] = b"EMBERSH\x03";
/// The format's version: the magic's last byte. Earlier ones (1: no flags; 2: light-path sums
/// of every pixel) are named when refused.
const VERSION: u8 = 3;
/// Magic, scene and settings length: before the settings text.
const PREFIX_BYTES: u64 = 8 + 8 + 4;
/// Shard index and count, width, height, spp, non-finite samples, nanoseconds, flags, light-path
/// entries.
const FIELDS_BYTES: u64 = 5 * 4 + 8 + 8 + 4 + 8;
/// A light-path entry: the pixel's index (u32) and its sums.
const LIGHT_ENTRY_BYTES: u64 = 4 + LIGHT_BYTES;
const FLAG_AUX: u32 = 1;
const FLAG_DENOISE: u32 = 2;
const FLAG_FIRST_ROUND: u32 = 4;
const FLAG_PLAN: u32 = 8;
const FLAG_LIGHT: u32 = 16;
const CHECKSUM_BYTES: u64 = 8;
/// The longest settings text accepted.
const MAX_SETTINGS: u64 = 64 * 1024;

/// What a shard file says of itself.
#[derive(Clone, Debug, PartialEq)]
pub struct ShardHeader {
    /// [`crate::scene::Scene::fingerprint`] of the scene rendered.
    pub scene: u64,
    /// The settings that change the image (`crate::integrator::RenderPlan::image_key`).
    pub settings: String,
    pub shard: Shard,
    pub width: u32,
    pub height: u32,
    /// The most samples a pixel takes.
    pub spp: u32,
    /// Non-finite samples dropped in the shard's pixels.
    pub nonfinite: u64,
    /// Time the shard's render took (all its sessions).
    pub elapsed: Duration,
    /// The file holds each pixel's auxiliary sums (albedo, normal): the render took them.
    pub aux: bool,
    /// The render was asked to denoise (`--denoise` or the scene's `denoise = true`), which is
    /// the merge's to do; implies `aux`.
    pub denoise: bool,
    /// Stage 1 of a two-stage shard (`--first-round`): what the shard renders before it needs
    /// the others; for `--plan-from`, not for the merge.
    pub first_round: bool,
    /// The file holds each pixel's part in an adaptive render's plan (a first round only).
    pub plan: bool,
    /// The file holds what the shard's light paths add to the image (caustics).
    pub light: bool,
    /// How many pixels they add to (what a file read says; [`save`] counts them).
    pub light_pixels: u64,
}

impl ShardHeader {
    /// The number of pixels the shard holds.
    pub fn pixel_count(&self) -> u64 {
        self.shard.pixel_count(self.width, self.height)
    }

    /// The size in bytes of the shard file.
    pub fn file_size(&self) -> u64 {
        PREFIX_BYTES
            + self.settings.len() as u64
            + FIELDS_BYTES
            + self.pixel_count() * self.pixel_bytes()
            + self.light_pixels * LIGHT_ENTRY_BYTES
            + CHECKSUM_BYTES
    }

    /// Bytes of one pixel's record.
    fn pixel_bytes(&self) -> u64 {
        PIXEL_BYTES + if self.aux { AUX_BYTES } else { 0 } + if self.plan { ADAPTIVE_BYTES } else { 0 }
    }
}

#[derive(Debug, thiserror::Error)]
pub enum ShardError {
    #[error("{}: cannot read shard file: {}", .0.display(), .1)]
    Read(PathBuf, String),
    #[error("{}: not a valid ember shard file ({})", .0.display(), .1)]
    Corrupt(PathBuf, String),
    #[error(transparent)]
    Write(#[from] crate::atomic_write::WriteError),
}

/// Writes the pixels of `header.shard` from `accum` (the render's accumulator, of the whole
/// image) to `path`, atomically, with the light-path entries `accum` has (whatever
/// `header.light_pixels` says).
pub fn save(path: &Path, header: &ShardHeader, accum: &Accumulator) -> Result<(), ShardError> {
    assert_eq!((accum.width, accum.height), (header.width, header.height), "the accumulator is the image's");
    assert_eq!(accum.aux.is_some(), header.aux, "the header says whether the render took auxiliary sums");
    assert!(header.aux || !header.denoise, "denoising needs the auxiliary sums");
    assert_eq!(accum.adaptive.is_some() && header.first_round, header.plan, "a first round keeps the plan's data");
    assert!(accum.light.is_some() || !header.light, "the header says whether the render traced light paths");
    let light_pixels = match &accum.light {
        Some(light) if header.light => light.0.iter().filter(|s| **s != [0; 3]).count() as u64,
        _ => 0,
    };
    let header = ShardHeader { light_pixels, ..header.clone() };
    crate::atomic_write::write_atomically(path, |file| {
        let mut out = std::io::BufWriter::new(file);
        write(&mut out, &header, accum).map_err(|e| e.to_string())?;
        out.into_inner().map(|_| ()).map_err(|e| e.error().to_string())
    })?;
    Ok(())
}

fn write(out: impl Write, h: &ShardHeader, accum: &Accumulator) -> std::io::Result<()> {
    let mut w = Hashing { inner: out, hash: Fnv1a::default() };
    w.write_all(MAGIC)?;
    w.write_all(&h.scene.to_le_bytes())?;
    w.write_all(&(h.settings.len() as u32).to_le_bytes())?;
    w.write_all(h.settings.as_bytes())?;
    for x in [h.shard.index, h.shard.count, h.width, h.height, h.spp] {
        w.write_all(&x.to_le_bytes())?;
    }
    w.write_all(&h.nonfinite.to_le_bytes())?;
    w.write_all(&(h.elapsed.as_nanos().min(u64::MAX as u128) as u64).to_le_bytes())?;
    let flags = if h.aux { FLAG_AUX } else { 0 }
        | if h.denoise { FLAG_DENOISE } else { 0 }
        | if h.first_round { FLAG_FIRST_ROUND } else { 0 }
        | if h.plan { FLAG_PLAN } else { 0 }
        | if h.light { FLAG_LIGHT } else { 0 };
    w.write_all(&flags.to_le_bytes())?;
    w.write_all(&h.light_pixels.to_le_bytes())?;
    for i in h.shard.pixels(h.width, h.height) {
        w.write_all(&encode_pixel(&accum.pixels[i]))?;
        if let Some(aux) = &accum.aux {
            w.write_all(&encode_aux(&aux[i]))?;
        }
        if h.plan
            && let Some(plan) = &accum.adaptive
        {
            w.write_all(&encode_plan(&plan[i]))?;
        }
    }
    if h.light
        && let Some(light) = &accum.light
    {
        let mut entry = [0u8; LIGHT_ENTRY_BYTES as usize];
        for (i, s) in light.0.iter().enumerate().filter(|(_, s)| **s != [0; 3]) {
            entry[..4].copy_from_slice(&(i as u32).to_le_bytes());
            entry[4..].copy_from_slice(&encode_light(s));
            w.write_all(&entry)?;
        }
    }
    let sum = w.hash.finish();
    w.inner.write_all(&sum.to_le_bytes())?;
    w.flush()
}

/// A shard file opened for reading: its header read and checked against the file's size.
pub struct ShardReader {
    pub path: PathBuf,
    pub header: ShardHeader,
    reader: Box<dyn std::io::BufRead>,
    hash: Fnv1a,
}

impl ShardReader {
    /// Opens the shard file `path` and reads its header. Only a regular file whose size is
    /// the one its header implies is accepted.
    pub fn open(path: &Path) -> Result<ShardReader, ShardError> {
        use std::os::unix::fs::OpenOptionsExt;
        let read_err = |e: std::io::Error| ShardError::Read(path.to_path_buf(), e.to_string());
        // Non-blocking: opening a FIFO must not wait for a writer (regular files ignore it).
        let file =
            std::fs::OpenOptions::new().read(true).custom_flags(libc::O_NONBLOCK | libc::O_NOCTTY).open(path).map_err(
                |e| match e.kind() {
                    std::io::ErrorKind::NotFound => ShardError::Read(path.to_path_buf(), "no such file".into()),
                    _ => read_err(e),
                },
            )?;
        let meta = file.metadata().map_err(read_err)?;
        if !meta.is_file() {
            return Err(ShardError::Read(path.to_path_buf(), "is not a regular file".into()));
        }
        // No more than its size says (a /proc file says 0).
        let reader = std::io::BufReader::with_capacity(1 << 16, file.take(meta.len()));
        Self::from_reader(Box::new(reader), meta.len(), path)
    }

    /// [`ShardReader::open`] of a shard file's bytes (`path` names it in messages).
    pub fn from_bytes(bytes: Vec<u8>, path: &Path) -> Result<ShardReader, ShardError> {
        let len = bytes.len() as u64;
        Self::from_reader(Box::new(std::io::Cursor::new(bytes)), len, path)
    }

    /// Reads the header of the `len` bytes of shard file `path` from `reader`.
    fn from_reader(reader: Box<dyn std::io::BufRead>, len: u64, path: &Path) -> Result<ShardReader, ShardError> {
        let corrupt = |why: String| ShardError::Corrupt(path.to_path_buf(), why);
        let mut r = ShardReader {
            path: path.to_path_buf(),
            header: ShardHeader {
                scene: 0,
                settings: String::new(),
                shard: Shard { index: 0, count: 1 },
                width: 0,
                height: 0,
                spp: 0,
                nonfinite: 0,
                elapsed: Duration::ZERO,
                aux: false,
                denoise: false,
                first_round: false,
                plan: false,
                light: false,
                light_pixels: 0,
            },
            reader,
            hash: Fnv1a::default(),
        };
        if len < PREFIX_BYTES + FIELDS_BYTES + CHECKSUM_BYTES {
            return Err(corrupt(format!("{len} bytes: too short")));
        }
        let prefix = r.take(PREFIX_BYTES as usize)?;
        if prefix[..7] == MAGIC[..7] && (1..VERSION).contains(&prefix[7]) {
            let version = prefix[7];
            return Err(corrupt(format!(
                "a shard file of an earlier ember (format {version}): render the shard again"
            )));
        }
        if &prefix[..8] != MAGIC {
            return Err(corrupt("wrong header: not written by `ember render --shard`".into()));
        }
        let scene = u64::from_le_bytes(prefix[8..16].try_into().unwrap());
        let settings_len = u32::from_le_bytes(prefix[16..20].try_into().unwrap()) as u64;
        if settings_len > MAX_SETTINGS || settings_len > len - PREFIX_BYTES - FIELDS_BYTES - CHECKSUM_BYTES {
            return Err(corrupt(format!("settings of {settings_len} bytes in a file of {len}")));
        }
        let settings = r.take(settings_len as usize)?;
        // ember's settings are printable ASCII: anything else (a terminal's escape sequences)
        // is not printed in messages, but refused.
        if !settings_are_text(&settings) {
            return Err(corrupt("the settings are not text".into()));
        }
        let settings = String::from_utf8(settings).map_err(|_| corrupt("the settings are not text".into()))?;
        let fields = r.take(FIELDS_BYTES as usize)?;
        let u32_at = |i: usize| u32::from_le_bytes(fields[4 * i..4 * i + 4].try_into().unwrap());
        let u64_at = |at: usize| u64::from_le_bytes(fields[at..at + 8].try_into().unwrap());
        let (index, count, width, height, spp) = (u32_at(0), u32_at(1), u32_at(2), u32_at(3), u32_at(4));
        // A forged count must not size anything: the merge keeps a slot per shard.
        let shard = Shard::new(index as u64, count as u64).map_err(corrupt)?;
        let max_side = crate::scene::format::MAX_IMAGE_SIDE;
        if !(1..=max_side).contains(&width) || !(1..=max_side).contains(&height) || spp == 0 {
            return Err(corrupt(format!("image {width}x{height} at {spp} spp")));
        }
        r.header = ShardHeader {
            scene,
            settings,
            shard,
            width,
            height,
            spp,
            nonfinite: u64_at(20),
            elapsed: Duration::from_nanos(u64_at(28)),
            aux: false,
            denoise: false,
            first_round: false,
            plan: false,
            light: false,
            light_pixels: u64_at(40),
        };
        let flags = u32_at(9);
        let known = FLAG_AUX | FLAG_DENOISE | FLAG_FIRST_ROUND | FLAG_PLAN | FLAG_LIGHT;
        let lacking = |flag: u32, needs: u32| flags & flag != 0 && flags & needs == 0;
        if flags & !known != 0 || lacking(FLAG_DENOISE, FLAG_AUX) || lacking(FLAG_PLAN, FLAG_FIRST_ROUND) {
            return Err(corrupt(format!("unknown flags {flags:#x}")));
        }
        (r.header.aux, r.header.denoise) = (flags & FLAG_AUX != 0, flags & FLAG_DENOISE != 0);
        (r.header.first_round, r.header.plan) = (flags & FLAG_FIRST_ROUND != 0, flags & FLAG_PLAN != 0);
        r.header.light = flags & FLAG_LIGHT != 0;
        // Checked before the size, which it sizes: at most every pixel, and none without light
        // paths.
        let light_pixels = r.header.light_pixels;
        if light_pixels > if r.header.light { width as u64 * height as u64 } else { 0 } {
            return Err(corrupt(format!("{light_pixels} light-path entries for a {width}x{height} image")));
        }
        if len != r.header.file_size() {
            return Err(corrupt(format!(
                "{len} bytes, but shard {} of a {width}x{height} image takes {}: truncated or damaged",
                r.header.shard,
                r.header.file_size()
            )));
        }
        Ok(r)
    }

    fn take(&mut self, n: usize) -> Result<Vec<u8>, ShardError> {
        let mut b = vec![0u8; n];
        self.reader.read_exact(&mut b).map_err(|e| self.io(e))?;
        self.hash.write(&b);
        Ok(b)
    }

    fn io(&self, e: std::io::Error) -> ShardError {
        match e.kind() {
            std::io::ErrorKind::UnexpectedEof => ShardError::Corrupt(self.path.clone(), "truncated".into()),
            _ => ShardError::Read(self.path.clone(), e.to_string()),
        }
    }

    /// Reads the shard's pixels into `accum` (the image's, of the header's size, with
    /// auxiliary sums if the header has them), checking each and the checksum, and adds its
    /// light paths' sums to `accum`'s; on error `accum` may hold some of them.
    pub fn read_into(mut self, accum: &mut Accumulator) -> Result<(), ShardError> {
        let h = self.header.clone();
        assert_eq!((accum.width, accum.height), (h.width, h.height), "the accumulator is the image's");
        assert_eq!(accum.aux.is_some(), h.aux, "the accumulator takes the shard's auxiliary sums");
        assert_eq!(accum.adaptive.is_some(), h.plan, "the accumulator takes the shard's plan data");
        let corrupt = |why: String| ShardError::Corrupt(self.path.clone(), why);
        let mut record = [0u8; (PIXEL_BYTES + AUX_BYTES + ADAPTIVE_BYTES) as usize];
        let b = &mut record[..h.pixel_bytes() as usize];
        let mut samples = 0u64;
        for i in h.shard.pixels(h.width, h.height) {
            self.reader.read_exact(b).map_err(|e| self.io(e))?;
            self.hash.write(b);
            let p: PixelState = decode_pixel(b);
            let aux = h.aux.then(|| decode_aux(&b[PIXEL_BYTES as usize..]));
            let plan_at = (PIXEL_BYTES + if h.aux { AUX_BYTES } else { 0 }) as usize;
            let plan = h.plan.then(|| decode_plan(&b[plan_at..]));
            let problem = pixel_problem(&p, h.spp).or_else(|| aux.and_then(|a| check_aux(&a, p.count).err()));
            let problem = problem.or_else(|| {
                let a = plan?;
                sum_sq_problem(&a)
                    .or_else(|| (a.target != 0).then(|| format!("a plan of {} samples in a first round", a.target)))
            });
            if let Some(why) = problem {
                let (x, y) = (i % h.width as usize, i / h.width as usize);
                return Err(corrupt(format!("pixel ({x}, {y}): {why}")));
            }
            samples += p.count as u64;
            accum.pixels[i] = p;
            if let (Some(sums), Some(a)) = (accum.aux.as_mut(), aux) {
                sums[i] = a;
            }
            if let (Some(plans), Some(a)) = (accum.adaptive.as_mut(), plan) {
                plans[i] = a;
            }
        }
        if h.light {
            let pixels = h.width as usize * h.height as usize;
            let light = accum.light.get_or_insert_with(|| LightSums::new(pixels));
            let mut entry = [0u8; LIGHT_ENTRY_BYTES as usize];
            let mut next = 0;
            for _ in 0..h.light_pixels {
                self.reader.read_exact(&mut entry).map_err(|e| self.io(e))?;
                self.hash.write(&entry);
                let i = u32::from_le_bytes(entry[..4].try_into().unwrap()) as usize;
                let sums = decode_light(&entry[4..]);
                if i < next || i >= pixels {
                    return Err(corrupt(format!("light-path entry of pixel {i} out of order or outside the image")));
                }
                if let Some(why) = light_problem(i, &sums, h.width) {
                    return Err(corrupt(why));
                }
                light.add_at(i, &sums);
                next = i + 1;
            }
        }
        let mut tail = [0u8; CHECKSUM_BYTES as usize];
        self.reader.read_exact(&mut tail).map_err(|e| self.io(e))?;
        if self.hash.finish() != u64::from_le_bytes(tail) {
            return Err(corrupt("checksum mismatch: truncated or damaged".into()));
        }
        if h.nonfinite > samples {
            return Err(corrupt(format!("{} non-finite samples of {samples} samples in all", h.nonfinite)));
        }
        Ok(())
    }
}

/// Why the shard files `readers` (each checked by [`mismatch`] against the first) are not every
/// shard of one image exactly once, if they are not: a duplicate or a missing shard.
pub fn incomplete(readers: &[ShardReader]) -> Option<String> {
    let count = readers.first()?.header.shard.count;
    let mut by_index: Vec<Option<&Path>> = vec![None; count as usize];
    for r in readers {
        let slot = &mut by_index[r.header.shard.index as usize];
        if let Some(other) = slot {
            return Some(format!("{} and {} are both shard {}", other.display(), r.path.display(), r.header.shard));
        }
        *slot = Some(&r.path);
    }
    let missing: Vec<usize> = by_index.iter().enumerate().filter(|(_, p)| p.is_none()).map(|(i, _)| i).collect();
    // The first few named, not thousands.
    const NAMED: usize = 8;
    let mut named: Vec<String> = missing.iter().take(NAMED).map(|i| format!("{i}/{count}")).collect();
    if missing.len() > NAMED {
        named.push(format!("and {} more", missing.len() - NAMED));
    }
    (!missing.is_empty()).then(|| {
        format!(
            "shard{} {} of the image missing (given {} of {count})",
            if missing.len() == 1 { "" } else { "s" },
            named.join(", "),
            readers.len()
        )
    })
}

/// Why the shard `b` (from `b_path`) cannot be merged with `a` (from `a_path`), if it cannot:
/// another scene, other settings, another image size or spp, another shard count.
pub fn mismatch(a: &ShardHeader, a_path: &Path, b: &ShardHeader, b_path: &Path) -> Option<String> {
    let (an, bn) = (a_path.display(), b_path.display());
    if a.scene != b.scene {
        return Some(format!("{bn} is a shard of another scene than {an} (or a file the scene uses changed)"));
    }
    if a.settings != b.settings {
        return Some(format!(
            "{bn} was rendered with other settings than {an}: {}",
            words_diff(&a.settings, &format!("in {an}"), &b.settings, &format!("in {bn}"))
        ));
    }
    if (a.width, a.height, a.spp) != (b.width, b.height, b.spp) {
        return Some(format!(
            "{bn} is of a {}x{} image at {} spp, {an} of {}x{} at {}",
            b.width, b.height, b.spp, a.width, a.height, a.spp
        ));
    }
    if (a.aux, a.denoise) != (b.aux, b.denoise) {
        let says = |h: &ShardHeader| match (h.aux, h.denoise) {
            (_, true) => "with --denoise",
            (true, false) => "with --aux",
            _ => "without --aux or --denoise",
        };
        return Some(format!("{bn} was rendered {}, {an} {}", says(b), says(a)));
    }
    if a.first_round != b.first_round {
        let says = |h: &ShardHeader| if h.first_round { "a first round (--first-round)" } else { "a finished shard" };
        return Some(format!("{bn} is {}, {an} {}", says(b), says(a)));
    }
    if a.light != b.light {
        let says = |h: &ShardHeader| if h.light { "with light paths' sums" } else { "without light paths' sums" };
        return Some(format!("{bn} is {}, {an} {}", says(b), says(a)));
    }
    if a.plan != b.plan {
        let says =
            |h: &ShardHeader| if h.plan { "with an adaptive plan's data" } else { "without an adaptive plan's data" };
        return Some(format!("{bn} is a first round {}, {an} {}", says(b), says(a)));
    }
    if a.shard.count != b.shard.count {
        return Some(format!("{bn} is shard {} but {an} is shard {}: the counts differ", b.shard, a.shard));
    }
    None
}

/// Whether a settings text read from a file is one ember could have written: printable ASCII.
pub(super) fn settings_are_text(settings: &[u8]) -> bool {
    settings.iter().all(|&b| (b' '..=b'~').contains(&b))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// The header of `shard` of a `w` x `h` image at 4 spp, without auxiliary sums or light.
    fn header(w: u32, h: u32, shard: Shard) -> ShardHeader {
        ShardHeader {
            scene: 7,
            settings: format!("width={w} height={h} spp=4"),
            shard,
            width: w,
            height: h,
            spp: 4,
            nonfinite: 0,
            elapsed: Duration::from_millis(5),
            aux: false,
            denoise: false,
            first_round: false,
            plan: false,
            light: false,
            light_pixels: 0,
        }
    }

    #[test]
    fn a_shard_round_trips_its_own_pixels_and_detects_damage() {
        let (w, h) = (40, 20);
        let mut accum = Accumulator::new(w, h);
        for (i, p) in accum.pixels.iter_mut().enumerate() {
            for s in 0..(i % 3) {
                p.add(Vec3::new(0.1 * s as f32, i as f32, 0.5));
            }
        }
        let dir = std::env::temp_dir().join(format!("ember-shard-unit-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let shard = Shard { index: 1, count: 3 };
        let header = header(w, h, shard);
        let path = dir.join("p.shard");
        save(&path, &header, &accum).unwrap();
        assert_eq!(std::fs::metadata(&path).unwrap().len(), header.file_size());
        let r = ShardReader::open(&path).unwrap();
        assert_eq!(r.header, header);
        let mut back = Accumulator::new(w, h);
        r.read_into(&mut back).unwrap();
        for (i, (a, b)) in accum.pixels.iter().zip(&back.pixels).enumerate() {
            let mine = shard.owns_pixel(i as u32 % w, i as u32 / w);
            assert_eq!(a == b, mine || a.count == 0, "pixel {i}");
        }
        let mut bytes = std::fs::read(&path).unwrap();
        let at = bytes.len() - 20;
        bytes[at] ^= 1;
        std::fs::write(&path, &bytes).unwrap();
        let e = ShardReader::open(&path).unwrap().read_into(&mut Accumulator::new(w, h)).unwrap_err();
        assert!(e.to_string().contains("checksum mismatch"), "{e}");
        std::fs::write(&path, &bytes[..bytes.len() - 1]).unwrap();
        assert!(ShardReader::open(&path).err().unwrap().to_string().contains("truncated or damaged"));
        // With auxiliary sums: they come back too, and a sum no sample could give is refused.
        let mut accum = Accumulator::with_aux(w, h);
        for (i, (p, a)) in accum.pixels.iter_mut().zip(accum.aux.as_mut().unwrap()).enumerate() {
            for _ in 0..(i % 3) {
                p.add(Vec3::splat(0.5));
                a.add(Vec3::new(0.25, 0.5, 1.0), Vec3::new(0.0, -1.0, 0.0));
            }
        }
        let header = ShardHeader { aux: true, denoise: true, ..header };
        save(&path, &header, &accum).unwrap();
        assert_eq!(std::fs::metadata(&path).unwrap().len(), header.file_size());
        let r = ShardReader::open(&path).unwrap();
        assert_eq!(r.header, header);
        let mut back = Accumulator::with_aux(w, h);
        r.read_into(&mut back).unwrap();
        for i in shard.pixels(w, h) {
            assert_eq!(
                (back.pixels[i], back.aux.as_ref().unwrap()[i]),
                (accum.pixels[i], accum.aux.as_ref().unwrap()[i])
            );
        }
        let first = shard.pixels(w, h).find(|&i| accum.pixels[i].count == 2).unwrap();
        accum.aux.as_mut().unwrap()[first].albedo.x = 3.0; // more than 2 samples of albedo ≤ 1
        save(&path, &header, &accum).unwrap();
        let e = ShardReader::open(&path).unwrap().read_into(&mut Accumulator::with_aux(w, h)).unwrap_err();
        assert!(e.to_string().contains("the sum of its albedos"), "{e}");
        // A file of the first format is named as such.
        let mut bytes = std::fs::read(&path).unwrap();
        bytes[7] = 1;
        std::fs::write(&path, &bytes).unwrap();
        assert!(ShardReader::open(&path).err().unwrap().to_string().contains("format 1"));
        bytes[7] = 2;
        std::fs::write(&path, &bytes).unwrap();
        assert!(ShardReader::open(&path).err().unwrap().to_string().contains("format 2"));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn light_path_sums_are_stored_for_the_pixels_they_reached_only() {
        let (w, h) = (30, 20);
        let mut accum = Accumulator::new(w, h);
        let mut light = LightSums::new((w * h) as usize);
        for (i, v) in [(3usize, [5i64, 6, 7]), (250, [1 << 40, 0, 1]), (599, [0, 0, 9])] {
            light.0[i] = v;
        }
        accum.light = Some(light.clone());
        let dir = std::env::temp_dir().join(format!("ember-shard-light-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let header = ShardHeader { light: true, ..header(w, h, Shard { index: 0, count: 2 }) };
        let path = dir.join("l.shard");
        save(&path, &header, &accum).unwrap();
        // Three entries of 28 bytes, not 600 pixels of 24.
        let r = ShardReader::open(&path).unwrap();
        assert_eq!(r.header, ShardHeader { light_pixels: 3, ..header.clone() });
        assert_eq!(std::fs::metadata(&path).unwrap().len(), r.header.file_size());
        // Read twice into one image: the sums add.
        let mut back = Accumulator::new(w, h);
        r.read_into(&mut back).unwrap();
        ShardReader::open(&path).unwrap().read_into(&mut back).unwrap();
        let doubled: Vec<[i64; 3]> = light.0.iter().map(|s| s.map(|v| 2 * v)).collect();
        assert_eq!(back.light.as_ref().unwrap().0, doubled);

        // Damage with a valid checksum (as a forger would): each is named.
        let bytes = std::fs::read(&path).unwrap();
        let entries = bytes.len() - 8 - 3 * LIGHT_ENTRY_BYTES as usize;
        let forged = |edit: &dyn Fn(&mut Vec<u8>)| {
            let mut b = bytes.clone();
            edit(&mut b);
            let n = b.len() - 8;
            let sum = crate::hash::fnv1a(&b[..n]);
            b[n..].copy_from_slice(&sum.to_le_bytes());
            let r = ShardReader::from_bytes(b, &path)?;
            r.read_into(&mut Accumulator::new(w, h))
        };
        let second = entries + LIGHT_ENTRY_BYTES as usize;
        let e = forged(&|b| b[second..second + 4].copy_from_slice(&2u32.to_le_bytes())).unwrap_err();
        assert!(e.to_string().contains("light-path entry of pixel 2 out of order"), "{e}");
        let e = forged(&|b| b[second..second + 4].copy_from_slice(&600u32.to_le_bytes())).unwrap_err();
        assert!(e.to_string().contains("outside the image"), "{e}");
        let e = forged(&|b| b[second + 4..second + 12].copy_from_slice(&(-1i64).to_le_bytes())).unwrap_err();
        assert!(e.to_string().contains("pixel (10, 8): a negative light-path sum"), "{e}");
        // A count of entries the image cannot have is refused before it sizes anything.
        let count_at = PREFIX_BYTES as usize + header.settings.len() + 40;
        let e = forged(&|b| b[count_at..count_at + 8].copy_from_slice(&601u64.to_le_bytes())).unwrap_err();
        assert!(e.to_string().contains("601 light-path entries for a 30x20 image"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

//! Checkpoints: the accumulated samples of an unfinished render, saved so that it can be
//! resumed and end in the same image, bit for bit, as an uninterrupted render.
//!
//! A checkpoint records what it belongs to — a scene fingerprint and a description of the
//! image-affecting settings as `key=value` words — and resuming against anything else is
//! refused, naming what differs. The file is binary (little-endian), ends with a checksum, and
//! is written atomically, so a crash while writing leaves the previous checkpoint intact.

use super::accum::{Accumulator, PixelState};
use crate::hash::fnv1a;
use glam::DVec3;
use std::path::{Path, PathBuf};
use std::time::Duration;

const MAGIC: &[u8; 8] = b"EMBERCK\x01";

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

impl Checkpoint {
    pub fn save(&self, path: &Path) -> Result<(), CheckpointError> {
        let mut b = Vec::with_capacity(64 + self.settings.len() + self.accum.pixels.len() * 36);
        b.extend_from_slice(MAGIC);
        b.extend_from_slice(&self.scene.to_le_bytes());
        b.extend_from_slice(&(self.settings.len() as u32).to_le_bytes());
        b.extend_from_slice(self.settings.as_bytes());
        b.extend_from_slice(&self.nonfinite.to_le_bytes());
        b.extend_from_slice(&(self.elapsed.as_nanos() as u64).to_le_bytes());
        b.extend_from_slice(&self.accum.width.to_le_bytes());
        b.extend_from_slice(&self.accum.height.to_le_bytes());
        for p in &self.accum.pixels {
            b.extend_from_slice(&p.count.to_le_bytes());
            for x in [p.sum.x, p.sum.y, p.sum.z, p.sum_lum_sq] {
                b.extend_from_slice(&x.to_le_bytes());
            }
        }
        let sum = fnv1a(&b);
        b.extend_from_slice(&sum.to_le_bytes());
        crate::atomic_write::write_file(path, &b)?;
        Ok(())
    }

    pub fn load(path: &Path) -> Result<Checkpoint, CheckpointError> {
        let b = std::fs::read(path).map_err(|e| match e.kind() {
            std::io::ErrorKind::NotFound => CheckpointError::Missing(path.to_path_buf()),
            _ => CheckpointError::Read(path.to_path_buf(), e.to_string()),
        })?;
        let corrupt = |why: &str| CheckpointError::Corrupt(path.to_path_buf(), why.to_string());
        if b.len() < MAGIC.len() + 8 || &b[..8] != MAGIC {
            return Err(corrupt("wrong header"));
        }
        let (body, tail) = b.split_at(b.len() - 8);
        if fnv1a(body) != u64::from_le_bytes(tail.try_into().unwrap_or_default()) {
            return Err(corrupt("checksum mismatch: truncated or damaged"));
        }
        let mut r = Reader { b: body, at: 8 };
        let scene = r.u64().ok_or_else(|| corrupt("truncated"))?;
        let len = r.u32().ok_or_else(|| corrupt("truncated"))? as usize;
        let settings = String::from_utf8(r.take(len).ok_or_else(|| corrupt("truncated"))?.to_vec())
            .map_err(|_| corrupt("settings are not text"))?;
        let nonfinite = r.u64().ok_or_else(|| corrupt("truncated"))?;
        let elapsed = Duration::from_nanos(r.u64().ok_or_else(|| corrupt("truncated"))?);
        let (w, h) = (r.u32().ok_or_else(|| corrupt("truncated"))?, r.u32().ok_or_else(|| corrupt("truncated"))?);
        let n = w as usize * h as usize;
        if r.b.len() - r.at != n * 36 {
            return Err(corrupt("pixel data does not match the image size"));
        }
        let mut accum = Accumulator::new(w, h);
        for p in &mut accum.pixels {
            let count = r.u32().ok_or_else(|| corrupt("truncated"))?;
            let mut f = [0.0f64; 4];
            for x in &mut f {
                *x = f64::from_bits(r.u64().ok_or_else(|| corrupt("truncated"))?);
            }
            *p = PixelState { sum: DVec3::new(f[0], f[1], f[2]), sum_lum_sq: f[3], count };
        }
        Ok(Checkpoint { scene, settings, nonfinite, elapsed, accum })
    }

    /// Checks that this checkpoint belongs to `scene` rendered with `settings`; the error
    /// names every setting that differs.
    pub fn check_matches(&self, path: &Path, scene: u64, settings: &str) -> Result<(), CheckpointError> {
        if self.scene != scene {
            return Err(CheckpointError::OtherScene(path.to_path_buf()));
        }
        if self.settings != settings {
            let mine: Vec<&str> = self.settings.split_whitespace().collect();
            let diffs: Vec<String> = settings
                .split_whitespace()
                .filter(|w| !mine.contains(w))
                .map(|w| {
                    let key = w.split('=').next().unwrap_or(w);
                    let was = mine.iter().find(|m| m.split('=').next() == Some(key)).copied().unwrap_or("(absent)");
                    format!("{was} in the checkpoint, {w} now")
                })
                .collect();
            return Err(CheckpointError::OtherSettings(path.to_path_buf(), diffs.join("; ")));
        }
        Ok(())
    }
}

struct Reader<'a> {
    b: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn take(&mut self, n: usize) -> Option<&[u8]> {
        let s = self.b.get(self.at..self.at.checked_add(n)?)?;
        self.at += n;
        Some(s)
    }
    fn u32(&mut self) -> Option<u32> {
        self.take(4).map(|s| u32::from_le_bytes(s.try_into().unwrap_or_default()))
    }
    fn u64(&mut self) -> Option<u64> {
        self.take(8).map(|s| u64::from_le_bytes(s.try_into().unwrap_or_default()))
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

    #[test]
    fn round_trips_exactly_and_detects_damage() {
        let dir = std::env::temp_dir().join(format!("ember-ckpt-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("x.png.checkpoint");
        let c = sample();
        c.save(&path).unwrap();
        assert_eq!(Checkpoint::load(&path).unwrap(), c);
        let mut bytes = std::fs::read(&path).unwrap();
        bytes[40] ^= 1;
        std::fs::write(&path, &bytes).unwrap();
        assert!(matches!(Checkpoint::load(&path), Err(CheckpointError::Corrupt(..))));
        std::fs::write(&path, &bytes[..bytes.len() - 3]).unwrap();
        assert!(matches!(Checkpoint::load(&path), Err(CheckpointError::Corrupt(..))));
        assert!(matches!(Checkpoint::load(&dir.join("none")), Err(CheckpointError::Missing(..))));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn refuses_other_scenes_and_names_changed_settings() {
        let c = sample();
        let p = Path::new("x.checkpoint");
        assert!(c.check_matches(p, 42, "spp=16 seed=1").is_ok());
        assert!(matches!(c.check_matches(p, 43, "spp=16 seed=1"), Err(CheckpointError::OtherScene(_))));
        let e = c.check_matches(p, 42, "spp=32 seed=1").unwrap_err().to_string();
        assert!(e.contains("spp=16 in the checkpoint, spp=32 now"), "{e}");
    }

    #[test]
    fn lives_next_to_the_output() {
        assert_eq!(checkpoint_path(Path::new("out/teapot.png")), PathBuf::from("out/teapot.png.checkpoint"));
    }
}

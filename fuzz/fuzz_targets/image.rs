//! Texture and environment images: the input's first byte chooses which (bit 0: an
//! environment, which also takes OpenEXR and Radiance HDR; otherwise bit 1: a linear rather
//! than an sRGB texture), the rest is the file, decoded
//! within a memory limit of 256 MB. Decoding must return `Ok` or `Err`, never panic; what it
//! accepts has the pixels its size says, all finite and not negative, and a JPEG it accepts
//! passes ember's check of its compressed data.
#![no_main]

use ember::memory::{LoadBudget, MemoryLimit};
use ember::texture::{Encoding, Image, MipImage};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&mode, file)) = data.split_first() else { return };
    let budget = LoadBudget::new(MemoryLimit::bytes(256_000_000));
    let _ = ember::jpeg_scan::check(file);
    let accepted = if mode & 1 == 1 {
        Image::environment_from_memory(file, &budget).map(|img| {
            assert!(img.width > 0 && img.height > 0);
            assert_eq!(img.pixels.len(), img.width as usize * img.height as usize);
            assert!(img.pixels.iter().all(|p| p.is_finite() && p.min_element() >= 0.0));
        })
    } else {
        let encoding = if mode & 2 == 2 { Encoding::Linear } else { Encoding::Srgb };
        MipImage::decode(file, &budget, encoding).map(|img| {
            assert!(img.width() > 0 && img.height() > 0);
            assert!(img.mean().is_finite() && img.min().min_element() >= 0.0 && img.max().max_element() <= 1.0);
        })
    };
    if accepted.is_ok() && file.starts_with(&[0xFF, 0xD8]) {
        assert_eq!(ember::jpeg_scan::check(file), Ok(()));
    }
});

//! Texture and environment images: the input's first byte chooses which (bit 0: an
//! environment, which also takes OpenEXR and Radiance HDR), the rest is the file, decoded
//! within a memory limit of 256 MB. Decoding must return `Ok` or `Err`, never panic; what it
//! accepts has the pixels its size says, all finite and not negative, and a JPEG it accepts
//! passes ember's check of its compressed data.
#![no_main]

use ember::memory::{LoadBudget, MemoryLimit};
use ember::texture::Image;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&mode, file)) = data.split_first() else { return };
    let budget = LoadBudget::new(MemoryLimit::bytes(256_000_000));
    let image =
        if mode & 1 == 1 { Image::environment_from_memory(file, &budget) } else { Image::from_memory(file, &budget) };
    let _ = ember::jpeg_scan::check(file);
    if let Ok(img) = image {
        assert!(img.width > 0 && img.height > 0);
        assert_eq!(img.pixels.len(), img.width as usize * img.height as usize);
        assert!(img.pixels.iter().all(|p| p.is_finite() && p.min_element() >= 0.0));
        if file.starts_with(&[0xFF, 0xD8]) {
            assert_eq!(ember::jpeg_scan::check(file), Ok(()));
        }
    }
});

//! The checkpoint loader, fed arbitrary bytes as the checkpoint of a small render. The first
//! byte chooses the render (bits 1-2), whether it takes the auxiliary images (bit 3: the
//! checkpoint then holds their sums), whether it is adaptive (bit 4: the checkpoint then holds
//! each pixel's plan), whether it traces caustic light paths (bit 5: the checkpoint then holds
//! their sums) and whether the checksum at the end of the rest is recomputed first
//! (bit 0), as someone forging a checkpoint would: without that almost every input would stop
//! at the checksum. Loading must return `Ok` or `Err`, never panic, and what it accepts must
//! fit the render and write back to the same bytes; an adaptive plan it accepts goes through
//! the planner's own check.
#![no_main]

use ember::film::{Checkpoint, CheckpointKey};
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fn key(choice: u8) -> CheckpointKey {
    let (width, height, spp) = match choice & 3 {
        0 | 3 => (3, 2, 16),
        1 => (1, 1, 1),
        _ => (2, 3, 1024),
    };
    let aux = choice & 4 != 0;
    let adaptive = choice & 8 != 0;
    let light = choice & 16 != 0;
    let settings = format!(
        "width={width} height={height} spp={spp} seed=1{}{}{}",
        if adaptive { " adaptive=relmse-5x5" } else { "" },
        if light { " caustics=light-paths" } else { "" },
        if aux { " aux=albedo+normal" } else { "" }
    );
    let max_spp = if adaptive { ember::integrator::adaptive::max_spp(spp) } else { spp };
    CheckpointKey { scene: 42, settings, width, height, spp: max_spp, aux, adaptive, light }
}

fuzz_target!(|data: &[u8]| {
    let Some((&mode, file)) = data.split_first() else { return };
    let key = key(mode >> 1);
    let mut bytes = file.to_vec();
    if mode & 1 == 1 && bytes.len() >= 8 {
        let n = bytes.len() - 8;
        let sum = ember::hash::fnv1a(&bytes[..n]);
        bytes[n..].copy_from_slice(&sum.to_le_bytes());
    }
    if let Ok(c) = Checkpoint::from_bytes(&bytes, Path::new("fuzz.checkpoint"), &key) {
        let a = &c.accum;
        assert_eq!((a.width, a.height, a.pixels.len()), (key.width, key.height, (key.width * key.height) as usize));
        assert_eq!((c.scene, &c.settings), (key.scene, &key.settings));
        for p in &a.pixels {
            assert!(p.count <= key.spp && p.sum.is_finite() && p.sum_lum_sq.is_finite() && p.sum_lum_sq >= 0.0);
            assert!(p.sum.min_element() >= 0.0);
        }
        assert_eq!(a.aux.as_ref().map(Vec::len), key.aux.then_some(a.pixels.len()));
        assert_eq!(a.adaptive.as_ref().map(Vec::len), key.adaptive.then_some(a.pixels.len()));
        assert_eq!(a.light.as_ref().map(|l| l.0.len()), key.light.then_some(a.pixels.len()));
        assert!(a.light.iter().flat_map(|l| l.0.iter().flatten()).all(|&v| v >= 0));
        if let Some(plan) = &a.adaptive {
            let spp = if key.spp == 1 { 1 } else { key.spp / ember::integrator::adaptive::MAX_FACTOR };
            let _ = ember::integrator::adaptive::stored_plan_problem(&a.pixels, plan, key.width, key.height, spp, 40);
        }
        assert_eq!(c.to_bytes(), bytes);
    }
});

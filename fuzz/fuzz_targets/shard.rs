//! Shard and first-round files, as `ember merge` and `ember render --plan-from` read them: the
//! input is up to three files, split at the bytes `EMBERSPLIT`; the first byte chooses whether
//! each file's checksum is recomputed first (bit 0), as someone forging a shard would. Every
//! header is read and checked against the first (`mismatch`, `incomplete`), then each file's
//! pixels read into an image's accumulator (for images of at most a million pixels: a merge
//! checks the memory of larger ones first), and a first round's plan goes through the
//! planner's check. All must return `Ok` or `Err`, never panic, and never allocate what a
//! header merely claims.
#![no_main]

use ember::film::Accumulator;
use ember::film::shard::{ShardReader, incomplete, mismatch};
use libfuzzer_sys::fuzz_target;
use std::path::PathBuf;

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else { return };
    let mut files: Vec<Vec<u8>> = Vec::new();
    let mut from = 0;
    let sep = b"EMBERSPLIT";
    let mut i = 0;
    while i + sep.len() <= rest.len() && files.len() < 2 {
        if &rest[i..i + sep.len()] == sep {
            files.push(rest[from..i].to_vec());
            from = i + sep.len();
            i = from;
        } else {
            i += 1;
        }
    }
    files.push(rest[from..].to_vec());
    let mut readers = Vec::new();
    for (k, mut bytes) in files.into_iter().enumerate() {
        if mode & 1 == 1 && bytes.len() >= 8 {
            let n = bytes.len() - 8;
            let sum = ember::hash::fnv1a(&bytes[..n]);
            bytes[n..].copy_from_slice(&sum.to_le_bytes());
        }
        match ShardReader::from_bytes(bytes, &PathBuf::from(format!("part-{k}.shard"))) {
            Ok(r) => readers.push(r),
            Err(_) => return,
        }
    }
    let first = readers[0].header.clone();
    for r in &readers[1..] {
        if mismatch(&first, &readers[0].path, &r.header, &r.path).is_some() {
            return;
        }
    }
    let _ = incomplete(&readers);
    if first.width as u64 * first.height as u64 > 1 << 20 {
        return;
    }
    let mut accum = Accumulator::empty(first.width, first.height, first.aux, first.plan);
    for r in readers {
        if r.read_into(&mut accum).is_err() {
            return;
        }
    }
    for p in &accum.pixels {
        assert!(p.count <= first.spp && p.sum.is_finite() && p.sum.min_element() >= 0.0);
    }
    if let Some(plan) = &accum.adaptive {
        let spp = first.spp.div_ceil(ember::integrator::adaptive::MAX_FACTOR).max(1);
        let _ =
            ember::integrator::adaptive::stored_plan_problem(&accum.pixels, plan, first.width, first.height, spp, 40);
    }
});

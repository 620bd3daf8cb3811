//! A render's stage 2 reading the first rounds it plans from (`--plan-from`), as
//! `ember render` does: one first-round file (the input, its checksum recomputed when the
//! first byte's bit 0 is set), checked against the render it claims to belong to, read into
//! the image's accumulator and its plan data checked by the planner (`stored_plan_problem`),
//! then planned from (`adaptive::allocate`) when it passes: every step must return, never
//! panic, and the plan must stay within its bounds.
#![no_main]

use ember::film::Accumulator;
use ember::film::shard::ShardReader;
use ember::integrator::adaptive;
use libfuzzer_sys::fuzz_target;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Some((&mode, file)) = data.split_first() else { return };
    let mut bytes = file.to_vec();
    if mode & 1 == 1 && bytes.len() >= 8 {
        let n = bytes.len() - 8;
        let sum = ember::hash::fnv1a(&bytes[..n]);
        bytes[n..].copy_from_slice(&sum.to_le_bytes());
    }
    let Ok(r) = ShardReader::from_bytes(bytes, Path::new("first.shard")) else { return };
    let h = r.header.clone();
    // What `--plan-from` takes: a first round with the plan's data, of the one shard.
    if !(h.first_round && h.plan && h.shard.count == 1) || h.width as u64 * h.height as u64 > 1 << 16 {
        return;
    }
    let mut accum = Accumulator::empty(h.width, h.height, h.aux, true);
    if r.read_into(&mut accum).is_err() {
        return;
    }
    let spp = h.spp.div_ceil(adaptive::MAX_FACTOR).max(1);
    let plan = accum.adaptive.as_ref().unwrap();
    if adaptive::stored_plan_problem(&accum.pixels, plan, h.width, h.height, spp, 40).is_none() {
        let first = adaptive::first_round_spp(spp);
        if accum.pixels.iter().all(|p| p.count == first) {
            let targets = adaptive::allocate(&accum.pixels, plan, h.width, h.height, spp);
            assert!(targets.iter().all(|&t| t >= first && t <= adaptive::max_spp(spp)));
        }
    }
});

//! The hard-case suite (`src/check/`, documented in `docs/hard-cases.md`): one test per case.
//! Each asserts that the case passes, which includes zero non-finite samples, pixels and hit
//! values plus the case's own check (analytic value, energy bound, or agreement with a
//! reference render or double precision). `ember check` runs the same cases.

use ember::tools::check::{CaseResult, Quality, catalog, find};

fn check(name: &str) {
    let case = find(name).unwrap_or_else(|| panic!("no hard case named {name:?}"));
    let r = case.run(Quality::Full);
    println!(
        "{name}: error {} (limit {}, {}), {} non-finite, {:.1} s: {}",
        r.worst_error,
        r.limit,
        r.metric,
        r.nonfinite,
        r.elapsed.as_secs_f64(),
        r.detail
    );
    assert_eq!(r.nonfinite, 0, "{name}: non-finite values: {}", r.detail);
    assert!(r.pass, "{name}: {} = {} over the limit {}: {}", r.metric, r.worst_error, r.limit, r.detail);
}

/// Every case in the catalog has a test below (so a new case cannot be forgotten here).
#[test]
fn every_case_has_a_test() {
    let source = include_str!("hard_cases.rs");
    for case in catalog() {
        assert!(source.contains(&format!("check(\"{}\")", case.name)), "no test runs the case {:?}", case.name);
    }
}

#[test]
fn sky_and_area_light() {
    check("sky-and-area-light");
}

#[test]
fn far_1e5() {
    check("far-1e5");
}

#[test]
fn far_1e7() {
    check("far-1e7");
}

#[test]
fn scaled_1e_minus_4() {
    check("scaled-1e-4");
}

#[test]
fn scaled_1e4() {
    check("scaled-1e4");
}

#[test]
fn grazing_plane() {
    check("grazing-plane");
}

#[test]
fn tangent_sphere() {
    check("tangent-sphere");
}

#[test]
fn tangent_cylinder() {
    check("tangent-cylinder");
}

#[test]
fn self_intersection() {
    check("self-intersection");
}

#[test]
fn thin_cylinder() {
    check("thin-cylinder");
}

#[test]
fn long_cylinder() {
    check("long-cylinder");
}

#[test]
fn cylinder_seen_from_afar() {
    check("cylinder-seen-from-afar");
}

#[test]
fn degenerate_triangles() {
    check("degenerate-triangles");
}

#[test]
fn axis_parallel_rays() {
    check("axis-parallel-rays");
}

#[test]
fn inside_sphere() {
    check("inside-sphere");
}

#[test]
fn inside_cylinder() {
    check("inside-cylinder");
}

#[test]
fn inside_glass_total_internal_reflection() {
    check("inside-glass-tir");
}

#[test]
fn glass_ior_1() {
    check("glass-ior-1");
}

#[test]
fn glass_furnace_ior_1_5_and_3() {
    check("glass-furnace");
}

#[test]
fn roughness_0_and_1() {
    check("roughness-0-1");
}

#[test]
fn emitters_1e6_next_to_1e_minus_6() {
    check("emitters-1e6-1e-6");
}

#[test]
fn zero_area_lights() {
    check("zero-area-lights");
}

#[test]
fn camera_inside_closed_mesh() {
    check("inside-closed-mesh");
}

#[test]
fn up_vector_parallel_to_view() {
    check("up-parallel-to-view");
}

/// `ember check --seed` reaches every render of a case: `far-1e5` renders with the lab's seed,
/// `sky-and-area-light` averages renders of seeds derived from it. Another seed draws other
/// samples (another error) and passes the same tolerances.
#[test]
fn another_seed_draws_other_samples_and_passes() {
    for name in ["far-1e5", "sky-and-area-light"] {
        let case = find(name).unwrap();
        let a = case.run_seeded(Quality::Quick, ember::tools::check::DEFAULT_SEED);
        let b = case.run_seeded(Quality::Quick, ember::tools::check::DEFAULT_SEED + 1);
        assert_eq!(a, CaseResult { elapsed: a.elapsed, ..case.run(Quality::Quick) }, "{name}: run is run_seeded(7)");
        assert!(a.pass && b.pass, "{name}: {} / {}", a.detail, b.detail);
        assert_ne!(a.worst_error, b.worst_error, "{name}: the seed changed nothing ({})", a.detail);
    }
}

/// The tolerances hold for other seeds too, not only the default one every test above runs:
/// the whole quick suite with seeds 1–4 (docs/hard-cases.md: sweeps of 40 seeds × both sizes
/// pass; before session 7's fixes, seed 3 failed `sky-and-area-light` here).
#[test]
fn the_quick_suite_passes_with_other_seeds() {
    let mut failed = Vec::new();
    for seed in 1..=4 {
        for case in catalog() {
            let r = case.run_seeded(Quality::Quick, seed);
            if !r.pass || r.nonfinite != 0 {
                failed.push(format!(
                    "seed {seed}: {}: {} = {} (limit {}): {}",
                    r.name, r.metric, r.worst_error, r.limit, r.detail
                ));
            }
        }
    }
    assert!(failed.is_empty(), "{}", failed.join("\n"));
}

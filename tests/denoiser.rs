//! The denoiser layer (`ember::oidn`) on Intel Open Image Denoise: it lowers the error of a
//! noisy image, keeps its size, gives finite values, is deterministic, refuses bad input, and a
//! missing library is a clear error, not a crash.
//!
//! These tests need the library (`scripts/install-deps.sh` or `scripts/fetch-oidn.sh` installs
//! it); without it they fail with the loader's message, which names the command.

mod denoise_images;

use denoise_images::{mse, noisy, scene};
use ember::oidn::{Aux, DenoiseError, Denoiser, DenoiserOptions};
use glam::Vec3;
use std::process::Command;

fn denoiser() -> Denoiser {
    Denoiser::new().unwrap_or_else(|e| panic!("the denoiser tests need Open Image Denoise: {e}"))
}

fn bits(img: &[Vec3]) -> Vec<u32> {
    img.iter().flat_map(|p| p.to_array().map(f32::to_bits)).collect()
}

fn assert_finite(img: &[Vec3]) {
    if let Some(i) = img.iter().position(|p| !p.is_finite()) {
        panic!("pixel {i} is {:?}", img[i]);
    }
}

#[test]
fn it_loads_oidn_2_and_creates_a_cpu_device() {
    let d = denoiser();
    assert!(d.version().starts_with("2."), "{}", d.version());
    eprintln!("{d:?}");
}

#[test]
fn denoising_colour_alone_lowers_the_error_twentyfold() {
    let d = denoiser();
    let s = scene(128, 96);
    let input = noisy(&s.clean, 4, 7);
    let out = d.denoise(s.w, s.h, &input, None, None, Aux::Noisy).unwrap();
    assert_eq!(out.len(), input.len());
    assert_finite(&out);
    let (before, after) = (mse(&input, &s.clean), mse(&out, &s.clean));
    eprintln!("colour only: MSE {before:.3e} -> {after:.3e} ({:.1}x lower)", before / after);
    // Measured with OIDN 2.5.1 on an AMD EPYC (AVX2): 3.520e-2 -> 5.601e-4, 62.8x.
    assert!(after * 20.0 < before, "MSE {before:.3e} -> {after:.3e}");
}

#[test]
fn albedo_and_normal_images_lower_it_further() {
    let d = denoiser();
    let s = scene(128, 96);
    let input = noisy(&s.clean, 4, 7);
    let before = mse(&input, &s.clean);
    let alone = mse(&d.denoise(s.w, s.h, &input, None, None, Aux::Noisy).unwrap(), &s.clean);
    let with = |mode| {
        let out = d.denoise(s.w, s.h, &input, Some(&s.albedo), Some(&s.normal), mode).unwrap();
        assert_finite(&out);
        mse(&out, &s.clean)
    };
    let (as_noisy, as_clean) = (with(Aux::Noisy), with(Aux::Clean));
    eprintln!(
        "MSE {before:.3e}: colour alone {alone:.3e} ({:.1}x lower), exact aux as Noisy {as_noisy:.3e} ({:.1}x), \
         as Clean {as_clean:.3e} ({:.1}x)",
        before / alone,
        before / as_noisy,
        before / as_clean
    );
    // Measured: 5.601e-4 alone, 5.169e-4 as Noisy (68.1x), 2.742e-4 as Clean (128.4x).
    assert!(as_noisy * 20.0 < before, "MSE {before:.3e} -> {as_noisy:.3e}");
    assert!(as_noisy < alone, "aux images did not help: {as_noisy:.3e} vs {alone:.3e} without");
    // Exact aux images are what cleanAux is for.
    assert!(as_clean * 1.5 < as_noisy, "cleanAux did not help: {as_clean:.3e} vs {as_noisy:.3e}");
}

#[test]
fn noisy_aux_images_are_prefiltered() {
    let d = denoiser();
    let s = scene(128, 96);
    let input = noisy(&s.clean, 4, 7);
    // Aux images with noise of their own (as a path tracer's are at edges, under depth of field
    // or behind glossy surfaces): 16 "samples" of the same multiplicative noise.
    let albedo = noisy(&s.albedo, 16, 8);
    let normal: Vec<Vec3> = noisy(&s.normal.iter().map(|n| *n * 0.5 + 0.5).collect::<Vec<_>>(), 16, 9)
        .into_iter()
        .map(|n| (n * 2.0 - 1.0).clamp(Vec3::NEG_ONE, Vec3::ONE))
        .collect();
    let raw = mse(&d.denoise(s.w, s.h, &input, Some(&albedo), Some(&normal), Aux::Noisy).unwrap(), &s.clean);
    let out = d.denoise(s.w, s.h, &input, Some(&albedo), Some(&normal), Aux::Prefilter).unwrap();
    assert_finite(&out);
    let (before, after) = (mse(&input, &s.clean), mse(&out, &s.clean));
    eprintln!(
        "noisy aux: MSE {before:.3e} -> {after:.3e} prefiltered ({:.1}x lower), {raw:.3e} as given",
        before / after
    );
    // Measured: 4.248e-4 prefiltered, 82.9x; 1.104e-3 with the noisy aux images as given.
    assert!(after * 20.0 < before, "MSE {before:.3e} -> {after:.3e}");
    assert!(after * 1.5 < raw, "prefiltering did not help: {after:.3e} vs {raw:.3e} without");
    // The caller's aux images are not modified by prefiltering (it works on copies).
    assert_eq!(bits(&albedo), bits(&noisy(&s.albedo, 16, 8)));
}

#[test]
fn output_has_the_input_size_for_odd_and_tiny_sizes() {
    let d = denoiser();
    for (w, h) in [(1, 1), (3, 2), (97, 61), (200, 7)] {
        let s = scene(w, h);
        let input = noisy(&s.clean, 4, 3);
        for aux in [false, true] {
            let (a, n) = if aux { (Some(&s.albedo[..]), Some(&s.normal[..])) } else { (None, None) };
            let out = d.denoise(w, h, &input, a, n, if aux { Aux::Prefilter } else { Aux::Noisy }).unwrap();
            assert_eq!(out.len(), (w * h) as usize, "{w}x{h}");
            assert_finite(&out);
        }
    }
}

#[test]
fn two_runs_are_bit_identical() {
    let s = scene(160, 120);
    let input = noisy(&s.clean, 4, 11);
    let d = denoiser();
    let run =
        |d: &Denoiser| bits(&d.denoise(s.w, s.h, &input, Some(&s.albedo), Some(&s.normal), Aux::Prefilter).unwrap());
    let first = run(&d);
    assert_eq!(first, run(&d), "same device, second call");
    // A new device, and one limited to a single thread: OIDN's CPU output does not depend on
    // its thread count (docs/denoiser.md has the measurements).
    assert_eq!(first, run(&denoiser()), "new device");
    let one = Denoiser::with_options(&DenoiserOptions { threads: Some(1), ..Default::default() }).unwrap();
    assert_eq!(first, run(&one), "numThreads 1");
}

#[test]
fn wrong_sizes_and_a_normal_without_albedo_are_refused() {
    let d = denoiser();
    let s = scene(8, 4);
    let bad = |r: Result<Vec<Vec3>, DenoiseError>| match r {
        Err(DenoiseError::InvalidInput(m)) => m,
        other => panic!("expected InvalidInput, got {other:?}"),
    };
    assert!(bad(d.denoise(8, 5, &s.clean, None, None, Aux::Noisy)).contains("expected 8x5 = 40"));
    assert!(bad(d.denoise(0, 4, &[], None, None, Aux::Noisy)).contains("0x4"));
    assert!(bad(d.denoise(8, 4, &s.clean, Some(&s.albedo[1..]), None, Aux::Noisy)).contains("albedo"));
    assert!(bad(d.denoise(8, 4, &s.clean, None, Some(&s.normal), Aux::Noisy)).contains("albedo image too"));
}

/// Set by `a_missing_library_is_a_clear_error` for the child process it starts.
const CHILD: &str = "EMBER_DENOISER_TEST_CHILD";

fn oidn_is_mapped() -> bool {
    std::fs::read_to_string("/proc/self/maps").unwrap().contains("libOpenImageDenoise")
}

/// Runs only as the child of `a_missing_library_is_a_clear_error` (a no-op otherwise): with
/// `EMBER_OIDN_DIR` pointing at an empty folder, creating a denoiser fails; the process is
/// running without the library, which was never linked.
#[test]
fn missing_library_child() {
    if std::env::var_os(CHILD).is_none() {
        return;
    }
    assert!(!oidn_is_mapped(), "libOpenImageDenoise is mapped before any denoiser was created: linked at build time?");
    let e = Denoiser::new().expect_err("EMBER_OIDN_DIR is an empty folder");
    assert!(matches!(e, DenoiseError::LibraryNotFound { .. }), "{e:?}");
    println!("MESSAGE: {e}");
    assert!(!oidn_is_mapped());
}

#[test]
fn a_missing_library_is_a_clear_error() {
    let empty = std::env::temp_dir().join(format!("ember-oidn-empty-{}", std::process::id()));
    std::fs::create_dir_all(&empty).unwrap();

    // In this process, through the options.
    let e = Denoiser::with_options(&DenoiserOptions { library_dir: Some(empty.clone()), ..Default::default() })
        .expect_err("an empty folder");
    let m = e.to_string();
    eprintln!("{m}");
    let expected_file = empty.join("libOpenImageDenoise.so.2");
    assert!(m.contains(&format!("{} (given folder): does not exist", expected_file.display())), "{m}");
    assert!(m.contains("scripts/fetch-oidn.sh"), "{m}");
    assert!(m.contains("EMBER_OIDN_DIR"), "{m}");

    // Through EMBER_OIDN_DIR, in a fresh process (this test binary, running only the child).
    let out = Command::new(std::env::current_exe().unwrap())
        .args(["--exact", "missing_library_child", "--nocapture", "--test-threads=1"])
        .env(CHILD, "1")
        .env("EMBER_OIDN_DIR", &empty)
        .env_remove("LD_LIBRARY_PATH")
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "child failed: {stdout}\n{}", String::from_utf8_lossy(&out.stderr));
    let line = stdout.split_once("MESSAGE: ").expect("the child printed the error").1.lines().next().unwrap();
    assert!(line.contains(&format!("{} (EMBER_OIDN_DIR): does not exist", expected_file.display())), "{line}");
    assert!(line.contains("scripts/fetch-oidn.sh"), "{line}");
    let _ = std::fs::remove_dir_all(&empty);
}

/// OIDN 2.5.1 treats a NaN or negative colour value as 0 (measured: the same output for both,
/// 741 of 4,096 pixels of a 64x64 image changed by > 1e-3 around it), but an infinite one
/// changes every pixel and leaves values up to 7e19; so the layer refuses non-finite input
/// (ember's film never holds any: non-finite samples are counted and replaced by zero).
#[test]
fn non_finite_input_is_refused() {
    let d = denoiser();
    let s = scene(16, 8);
    for v in [Vec3::new(f32::INFINITY, 1.0, 1.0), Vec3::new(0.0, f32::NAN, 0.0), Vec3::splat(f32::NEG_INFINITY)] {
        let mut input = s.clean.clone();
        input[16 * 3 + 5] = v;
        match d.denoise(16, 8, &input, None, None, Aux::Noisy) {
            Err(DenoiseError::InvalidInput(m)) => {
                assert!(m.contains("colour image has 1 non-finite pixel") && m.contains("(5, 3)"), "{m}")
            }
            other => panic!("{v:?}: expected InvalidInput, got {other:?}"),
        }
        match d.denoise(16, 8, &s.clean, Some(&input), None, Aux::Noisy) {
            Err(DenoiseError::InvalidInput(m)) => assert!(m.contains("albedo image"), "{m}"),
            other => panic!("{v:?}: expected InvalidInput, got {other:?}"),
        }
    }
}

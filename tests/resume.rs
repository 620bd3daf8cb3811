//! Interrupt and resume: a render stopped by SIGTERM (or killed outright, after periodic
//! checkpoints) and resumed ends in the same image, bit for bit, as an uninterrupted one; a
//! checkpoint for other settings, another scene or another accelerator is refused, and so is
//! one whose header or contents could not have come from the render (however its checksum
//! was made); a periodic checkpoint that cannot be written is a warning.

mod common;

use ember::accel::{Accel, AccelKind, EmbreeAccel};
use ember::embree::{BuildOptions, Device};
use ember::film::{Accumulator, Checkpoint, CheckpointError, CheckpointKey, Film};
use ember::integrator::{RenderControl, RenderError, RenderPlan, RenderSettings, render, render_controlled};
use ember::scene::Scene;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

/// The ray count an `ember render` summary line reports.
fn rays_traced(stderr: &[u8]) -> u64 {
    let text = String::from_utf8_lossy(stderr);
    let at = text.find(" rays, ").unwrap_or_else(|| panic!("no ray count in {text}"));
    let start = text[..at].rfind('(').unwrap() + 1;
    text[start..at].parse().unwrap()
}

/// Long enough (a few seconds on 2 cores) to be interrupted part-way.
const ARGS: [&str; 8] = ["--width", "32", "--height", "24", "--spp", "10000", "--seed", "5"];

fn ember(out: &Path, extra: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_ember"));
    c.arg("render").arg(common::scene_path("cornell-area.toml")).arg("-o").arg(out).args(ARGS).args(extra);
    c
}

/// The checkpoint key of `ember render cornell-area.toml --width W --height H --spp N
/// --seed S` with the default Embree accelerator (or `accel`).
fn cli_key(width: u32, height: u32, spp: u32, seed: u64, accel: Option<&str>) -> CheckpointKey {
    let scene = Scene::load(&common::scene_path("cornell-area.toml")).unwrap();
    // Adaptive unless the spp is at most one packet, as `ember render` decides.
    let adaptive = ember::integrator::adaptive::by_default(spp);
    let settings = RenderSettings { width, height, spp, seed, adaptive, ..RenderSettings::from_scene(&scene.render) };
    // As `ember render` builds it (the low quality, for this box).
    let cli = ember::accel::build_options_for(&scene.geometry);
    let accel = accel.map_or_else(|| AccelKind::Embree.image_key(cli), str::to_string);
    RenderPlan::new(&scene, &settings).checkpoint_key(scene.fingerprint(), &accel)
}

/// The key of a render with [`ARGS`].
fn args_key() -> CheckpointKey {
    cli_key(32, 24, 10000, 5, None)
}

/// Starts a render, waits until it is rendering, waits `after`, sends `signal` (via kill).
fn start_and_signal(out: &Path, extra: &[&str], after: Duration, signal: &str) -> std::process::Output {
    let mut child = ember(out, extra).stderr(Stdio::piped()).spawn().unwrap();
    let mut stderr = BufReader::new(child.stderr.take().unwrap());
    let mut seen = String::new();
    let mut line = String::new();
    while stderr.read_line(&mut line).unwrap() > 0 {
        seen.push_str(&line);
        if line.starts_with("kernel:") {
            break;
        }
        line.clear();
    }
    std::thread::sleep(after);
    let status = Command::new("kill").arg(format!("-{signal}")).arg(child.id().to_string()).status().unwrap();
    assert!(status.success());
    let mut rest = String::new();
    std::io::Read::read_to_string(&mut stderr, &mut rest).unwrap();
    let status = child.wait().unwrap();
    std::process::Output { status, stdout: Vec::new(), stderr: (seen + &rest).into_bytes() }
}

#[test]
fn interrupted_and_resumed_renders_equal_the_uninterrupted_one() {
    let dir = common::fresh_dir("resume", "signal");
    let reference = dir.join("reference.exr");
    let done = ember(&reference, &[]).output().unwrap();
    assert!(done.status.success(), "{}", String::from_utf8_lossy(&done.stderr));
    let reference = Film::load_exr(&reference).unwrap();
    let full_rays = rays_traced(&done.stderr);

    // SIGTERM: the render finishes the pixels in flight, writes its checkpoint, says how to
    // resume, exits 143 (128 + SIGTERM) and writes no image.
    let out = dir.join("interrupted.exr");
    let ckpt = dir.join("interrupted.exr.checkpoint");
    let run = start_and_signal(&out, &["--threads", "2"], Duration::from_millis(700), "TERM");
    let msg = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(143), "{msg}");
    assert!(msg.contains("checkpoint written to") && msg.contains("--resume"), "{msg}");
    // It says how far the render got as the progress bar does, and in spp.
    assert!(msg.contains("% of the render done (") && msg.contains(" spp on average so far, --spp 10000)"), "{msg}");
    assert!(ckpt.exists() && !out.exists());
    let partial = Checkpoint::load(&ckpt, &args_key()).unwrap();
    let (min, _, max) = partial.accum.spp_range();
    assert!(min < 10000, "the render finished before the signal: make it longer");
    assert!(partial.accum.samples() > 0, "nothing was rendered before the signal");
    println!("interrupted with spp between {min} and {max}");
    // Resume with another thread count.
    let resumed = ember(&out, &["--threads", "1", "--resume"]).output().unwrap();
    assert!(resumed.status.success(), "{}", String::from_utf8_lossy(&resumed.stderr));
    assert!(!ckpt.exists(), "a finished render removes its checkpoint");
    assert_eq!(Film::load_exr(&out).unwrap(), reference, "resumed image differs");
    // It continued rather than starting over.
    assert!(rays_traced(&resumed.stderr) < full_rays);

    // A crash (SIGKILL) after periodic checkpoints loses at most the interval.
    let out = dir.join("crashed.exr");
    let ckpt = dir.join("crashed.exr.checkpoint");
    let run = start_and_signal(&out, &["--checkpoint-every", "0.2s"], Duration::from_millis(2000), "KILL");
    assert_eq!(run.status.code(), None, "killed by a signal");
    let saved = Checkpoint::load(&ckpt, &args_key()).expect("a periodic checkpoint");
    assert!(saved.accum.samples() > 0);
    let resumed = ember(&out, &["--resume"]).output().unwrap();
    assert!(resumed.status.success(), "{}", String::from_utf8_lossy(&resumed.stderr));
    assert_eq!(Film::load_exr(&out).unwrap(), reference, "image resumed after a crash differs");
    assert!(rays_traced(&resumed.stderr) < full_rays);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn resume_refuses_other_settings_and_other_scenes() {
    let dir = common::fresh_dir("resume", "refuse");
    let scene = Scene::load(&common::scene_path("cornell-area.toml")).unwrap();
    let device = Device::new().unwrap();
    let accel = EmbreeAccel::new(&device, &scene.geometry, BuildOptions::default()).unwrap();
    let settings = RenderSettings { width: 16, height: 12, spp: 8, ..Default::default() };
    let ckpt = dir.join("x.exr.checkpoint");
    // Stopped before it starts: nothing rendered, checkpoint written.
    let stop = AtomicBool::new(true);
    let control = RenderControl { stop: Some(&stop), checkpoint: Some((&ckpt, None)), ..Default::default() };
    let r = render_controlled(&scene, &accel, &RenderPlan::new(&scene, &settings), control).unwrap();
    assert!(!r.complete);
    assert_eq!(r.accum.samples(), 0);

    let key = RenderPlan::new(&scene, &settings).checkpoint_key(scene.fingerprint(), &accel.image_key());
    let resume_with = |scene: &Scene, s: &RenderSettings| {
        let c = Checkpoint::load(&ckpt, &key).unwrap();
        let control = RenderControl { resume: Some((&ckpt, c)), ..Default::default() };
        render_controlled(scene, &accel, &RenderPlan::new(scene, s), control)
    };
    match resume_with(&scene, &RenderSettings { spp: 16, ..settings.clone() }) {
        Err(RenderError::Checkpoint(e @ CheckpointError::OtherSettings(..))) => {
            assert!(e.to_string().contains("spp=8 in the checkpoint, spp=16 now"), "{e}")
        }
        other => panic!("expected a settings mismatch, got {:?}", other.map(|r| r.complete)),
    }
    let other = Scene::load(&common::scene_path("cornell.toml")).unwrap();
    assert!(matches!(resume_with(&other, &settings), Err(RenderError::Checkpoint(CheckpointError::OtherScene(_)))));
    // The pixel filter is a setting; a camera given on the command line makes another scene.
    let gaussian = RenderSettings { filter: ember::film::PixelFilter::Gaussian, ..settings.clone() };
    match resume_with(&scene, &gaussian) {
        Err(RenderError::Checkpoint(e @ CheckpointError::OtherSettings(..))) => {
            assert!(e.to_string().contains("filter=box in the checkpoint, filter=gaussian now"), "{e}")
        }
        other => panic!("expected a settings mismatch, got {:?}", other.map(|r| r.complete)),
    }
    // A sample clamp changes the image: a render without one does not resume with one.
    match resume_with(&scene, &RenderSettings { clamp: Some(10.0), ..settings.clone() }) {
        Err(RenderError::Checkpoint(e @ CheckpointError::OtherSettings(..))) => {
            assert!(e.to_string().contains("(absent) in the checkpoint, clamp=10 now"), "{e}")
        }
        other => panic!("expected a settings mismatch, got {:?}", other.map(|r| r.complete)),
    }
    let mut moved = scene.clone();
    let fov = ember::scene::CameraOverride { fov: Some(30.0), ..Default::default() };
    moved.override_camera(&fov, 16.0 / 12.0).unwrap();
    assert!(matches!(resume_with(&moved, &settings), Err(RenderError::Checkpoint(CheckpointError::OtherScene(_)))));
    let mut flat = scene.clone();
    flat.override_camera(&ember::scene::CameraOverride { ortho: Some(600.0), ..Default::default() }, 16.0 / 12.0)
        .unwrap();
    assert!(matches!(resume_with(&flat, &settings), Err(RenderError::Checkpoint(CheckpointError::OtherScene(_)))));
    // The right scene and settings resume and give the uninterrupted image.
    let r = resume_with(&scene, &settings).unwrap();
    assert!(r.complete);
    assert_eq!(r.accum.film(), render(&scene, &accel, &settings).unwrap().0);

    // On the command line: exit 2, the file named, nothing written.
    let out = dir.join("cli.exr");
    let run = Command::new(env!("CARGO_BIN_EXE_ember"))
        .args([
            "render",
            common::scene_path("cornell-area.toml").to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--resume",
        ])
        .output()
        .unwrap();
    let msg = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(2), "{msg}");
    assert!(msg.contains("cli.exr.checkpoint: no checkpoint to resume from"), "{msg}");
    assert!(!out.exists());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Runs `c` and waits at most 30 s for it (a checkpoint path that blocks a reader must not
/// hang the test).
fn output_within(c: &mut Command) -> Output {
    let mut child = c.stdout(Stdio::null()).stderr(Stdio::piped()).spawn().unwrap();
    let mut stderr = child.stderr.take().unwrap();
    let reader = std::thread::spawn(move || {
        let mut s = Vec::new();
        std::io::Read::read_to_end(&mut stderr, &mut s).unwrap();
        s
    });
    let start = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if start.elapsed() > Duration::from_secs(30) {
            child.kill().unwrap();
            panic!("{c:?} still running after 30 s");
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    Output { status, stdout: Vec::new(), stderr: reader.join().unwrap() }
}

fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> =
        std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    v.sort();
    v
}

/// `ember render … -o out --resume extra…` fails at once: exit 2, an error naming the
/// checkpoint and containing `needle`, no image, the folder (and the checkpoint in it) as it
/// was.
fn expect_refused(out: &Path, extra: &[&str], needle: &str) {
    let ckpt = ember::film::checkpoint_path(out);
    let dir = out.parent().unwrap();
    // (Not read through a link, nor from a FIFO or device.)
    let regular = std::fs::symlink_metadata(&ckpt).is_ok_and(|m| m.is_file());
    let (before, bytes) = (listing(dir), if regular { std::fs::read(&ckpt).ok() } else { None });
    let o = output_within(ember(out, extra).arg("--resume"));
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{extra:?}: {e}");
    let line = e.lines().find(|l| l.starts_with("error: ")).unwrap_or("");
    assert!(line.starts_with(&format!("error: {}: ", ckpt.display())), "{extra:?}: {e}");
    assert!(line.contains(needle), "{extra:?}: expected {needle:?} in {e}");
    assert!(!out.exists(), "{extra:?}: an image was written");
    assert_eq!(listing(dir), before, "{extra:?}");
    if bytes.is_some() {
        assert_eq!(std::fs::read(&ckpt).ok(), bytes, "{extra:?}: the checkpoint changed");
    }
}

/// `c`'s bytes with the image size in its header replaced, and the checksum recomputed.
fn with_size(c: &Checkpoint, w: u32, h: u32) -> Vec<u8> {
    let mut b = c.to_bytes();
    b.truncate(b.len() - 8);
    let at = 8 + 8 + 4 + c.settings.len() + 8 + 8;
    b[at..at + 4].copy_from_slice(&w.to_le_bytes());
    b[at + 4..at + 8].copy_from_slice(&h.to_le_bytes());
    let sum = ember::hash::fnv1a(&b);
    b.extend_from_slice(&sum.to_le_bytes());
    b
}

#[test]
fn resume_refuses_checkpoints_that_lie() {
    let dir = common::fresh_dir("resume", "lies");
    let out = dir.join("out.exr");
    let ckpt = dir.join("out.exr.checkpoint");
    let key = args_key();
    let good = Checkpoint {
        scene: key.scene,
        settings: key.settings.clone(),
        nonfinite: 0,
        elapsed: Duration::from_secs(1),
        // At 10000 spp, an adaptive render's: with its plan.
        accum: Accumulator::new(32, 24).adaptive(),
    };
    assert!(key.adaptive);
    good.save(&ckpt).unwrap();
    assert_eq!(Checkpoint::load(&ckpt, &key).unwrap(), good);

    // Headers that lie about the image size, with a valid checksum: as long as the real
    // file, or as long as the lie (they panicked, or wrote an image of the wrong size).
    for (w, h) in [(1u32, 1u32), (1 << 31, 1 << 31), (65536, 1)] {
        let needle = format!("not a valid ember checkpoint (its image is {w}x{h} but its settings say 32x24)");
        std::fs::write(&ckpt, with_size(&good, w, h)).unwrap();
        expect_refused(&out, &[], &needle);
        if (w as u64) * (h as u64) <= 65536 {
            Checkpoint { accum: Accumulator::new(w, h).adaptive(), ..good.clone() }.save(&ckpt).unwrap();
            expect_refused(&out, &[], &needle);
        }
    }
    // Contents no render makes (they were accepted).
    let with_pixel = |i: usize, edit: &dyn Fn(&mut ember::film::PixelState)| {
        let mut c = good.clone();
        edit(&mut c.accum.pixels[i]);
        c.save(&ckpt).unwrap();
    };
    with_pixel(5, &|p| p.sum.x = f64::NAN);
    expect_refused(&out, &[], "(pixel (5, 0): the sum of its samples is not finite ([NaN, 0, 0]))");
    with_pixel(33, &|p| p.count = u32::MAX);
    expect_refused(
        &out,
        &[],
        "(pixel (1, 1): 4294967295 samples, more than the 160000 a pixel of this render takes at most)",
    );
    with_pixel(0, &|p| {
        p.count = 1;
        p.sum_lum_sq = f64::INFINITY
    });
    expect_refused(&out, &[], "(pixel (0, 0): the sum of its squared luminances is inf");
    // Radiance is never negative.
    with_pixel(7, &|p| {
        p.count = 1;
        p.sum = glam::DVec3::new(-1.0, 0.0, 0.0);
        p.sum_lum_sq = 1.0;
    });
    expect_refused(&out, &[], "(pixel (7, 0): the sum of its samples [-1, 0, 0] is negative, which radiance never is)");
    // A plan's data no render records: a first round that traced 2^32 − 1 rays (the plan would
    // send the samples elsewhere: a resume 17 times longer), and a finished first round with
    // every target at the most a pixel may take (16 times the samples of --spp).
    let mut forged = good.clone();
    forged.accum.adaptive.as_mut().unwrap()[3].rays = u32::MAX;
    forged.save(&ckpt).unwrap();
    expect_refused(&out, &[], "(pixel (3, 0): 4294967295 rays in a first round of 0 samples, more than the 0 they");
    let first = ember::integrator::adaptive::first_round_spp(10000);
    let mut forged = good.clone();
    for (p, a) in forged.accum.pixels.iter_mut().zip(forged.accum.adaptive.as_mut().unwrap()) {
        for _ in 0..first {
            p.add(glam::Vec3::splat(0.5));
        }
        a.rays = 10 * first;
        a.sum_sq = glam::DVec3::splat(0.25 * first as f64);
        a.target = 160_000;
    }
    forged.save(&ckpt).unwrap();
    expect_refused(&out, &[], "more samples than --spp 10000 gives)");

    // Another accelerator, or other BVH build options: a different estimator of the image.
    good.save(&ckpt).unwrap();
    for (args, needle) in [
        (&["--accel", "naive"][..], "different settings: accel=embree in the checkpoint, accel=naive now"),
        (&["--bvh-quality", "high"], "different settings: bvh=low in the checkpoint, bvh=high now"),
        (&["--no-robust"], "different settings: robust=on in the checkpoint, robust=off now"),
    ] {
        expect_refused(&out, args, needle);
    }
    let naive = cli_key(32, 24, 10000, 5, Some(&AccelKind::Naive.image_key(BuildOptions::default())));
    Checkpoint { settings: naive.settings, ..good.clone() }.save(&ckpt).unwrap();
    expect_refused(&out, &[], "different settings: accel=naive in the checkpoint, accel=embree now");

    // Not a regular file: refused at once, never read (a FIFO blocked, /dev/zero filled memory).
    std::fs::remove_file(&ckpt).unwrap();
    std::os::unix::fs::symlink("/dev/zero", &ckpt).unwrap();
    expect_refused(&out, &[], "cannot read checkpoint: is not a regular file");
    std::fs::remove_file(&ckpt).unwrap();
    assert!(Command::new("mkfifo").arg(&ckpt).status().unwrap().success());
    expect_refused(&out, &[], "cannot read checkpoint: is not a regular file");
    std::fs::remove_file(&ckpt).unwrap();
    std::fs::create_dir(&ckpt).unwrap();
    expect_refused(&out, &[], "cannot read checkpoint: is a directory");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_periodic_checkpoint_that_cannot_be_written_is_a_warning() {
    let dir = common::fresh_dir("resume", "periodic");
    let scene = Scene::load(&common::scene_path("cornell-area.toml")).unwrap();
    let device = Device::new().unwrap();
    let accel = EmbreeAccel::new(&device, &scene.geometry, BuildOptions::default()).unwrap();
    let settings = RenderSettings { width: 16, height: 12, spp: 4, ..Default::default() };
    let plan = RenderPlan::new(&scene, &settings);
    // Its folder does not exist: every write fails (as on a full disk).
    let ckpt: PathBuf = dir.join("gone").join("x.exr.checkpoint");
    let control = RenderControl { checkpoint: Some((&ckpt, Some(Duration::ZERO))), ..Default::default() };
    let r = render_controlled(&scene, &accel, &plan, control).unwrap();
    assert!(r.complete);
    assert_eq!(r.accum.film(), render(&scene, &accel, &settings).unwrap().0);
    assert_eq!(r.warnings.len(), 1, "one warning for all the failures: {:?}", r.warnings);
    let w = &r.warnings[0];
    let (failed, tried) = w.split_once(" periodic").unwrap().0.split_once(" of ").unwrap();
    assert_eq!(failed, tried, "{w}");
    assert!(failed.parse::<u32>().unwrap() > 0, "{w}");
    assert!(
        w.ends_with(&format!(
            "could not be written; the render went on without them (first failure: {}: cannot write: folder {} does not exist)",
            ckpt.display(),
            dir.join("gone").display()
        )),
        "{w}"
    );
    // The checkpoint written when a render stops is what resuming needs: failing is an error.
    let stop = AtomicBool::new(true);
    let control = RenderControl { stop: Some(&stop), checkpoint: Some((&ckpt, None)), ..Default::default() };
    match render_controlled(&scene, &accel, &plan, control) {
        Err(RenderError::Checkpoint(CheckpointError::Write(e))) => assert_eq!(e.path, ckpt),
        other => panic!("expected a write error, got {:?}", other.map(|r| r.complete)),
    }

    // On the command line: the checkpoint's name becomes a folder while the render runs.
    let out = dir.join("cli.exr");
    let ckpt = dir.join("cli.exr.checkpoint");
    let mut child = Command::new(env!("CARGO_BIN_EXE_ember"))
        .arg("render")
        .arg(common::scene_path("cornell-area.toml"))
        .arg("-o")
        .arg(&out)
        .args(["--width", "32", "--height", "24", "--spp", "1000", "--checkpoint-every", "0.05s"])
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stderr = BufReader::new(child.stderr.take().unwrap());
    let mut seen = String::new();
    while !seen.contains("\nkernel:") && stderr.read_line(&mut seen).unwrap() > 0 {}
    let start = Instant::now();
    while std::fs::create_dir(&ckpt).is_err() {
        let _ = std::fs::remove_file(&ckpt);
        assert!(start.elapsed() < Duration::from_secs(5));
    }
    std::io::Read::read_to_string(&mut stderr, &mut seen).unwrap();
    let status = child.wait().unwrap();
    assert!(status.success(), "{seen}");
    assert!(seen.contains("warning: ") && seen.contains(" periodic checkpoints could not be written"), "{seen}");
    assert_eq!(seen.matches(" periodic checkpoints could not be written").count(), 1, "{seen}");
    assert!(seen.contains(&format!("(first failure: {}: cannot write: ", ckpt.display())), "{seen}");
    assert_eq!(Film::load_exr(&out).unwrap().width, 32);
    assert!(ckpt.is_dir(), "a folder is not the render's to remove");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Waits up to `limit` for `running` to end (else kills it and fails): a stop that is not
/// honoured would hang the test.
fn finish_within(mut running: common::Running, limit: Duration) -> (std::process::ExitStatus, String) {
    let start = Instant::now();
    while running.child.try_wait().unwrap().is_none() {
        if start.elapsed() > limit {
            let _ = running.child.kill();
            let (_, seen) = running.finish();
            panic!("not stopped within {limit:?}: {seen}");
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    running.finish()
}

/// A stop request is honoured within a group of samples, inside a pixel too: `--spp
/// 4294967295` on one pixel (a stop was checked only between pixels: Ctrl-C never ended it)
/// stops within a second; and a render stopped inside its pixels — uniform, with a target
/// error (its rounds decide on each pixel's error), adaptive (its first round sums squares for
/// the plan) — and resumed ends in the image of one never stopped, bit for bit.
#[test]
fn a_stop_is_honoured_inside_a_pixel_and_resumes_exactly() {
    let dir = common::fresh_dir("resume", "inside-pixel");
    let scene = common::scene_path("cornell-area.toml");
    let render = |out: &Path, args: &[&str]| {
        let mut c = Command::new(env!("CARGO_BIN_EXE_ember"));
        c.arg("render").arg(&scene).arg("-o").arg(out).args(args);
        c
    };
    let out = dir.join("huge.exr");
    let running = common::Running::start_rendering(&mut render(
        &out,
        &["--width", "1", "--height", "1", "--spp", "4294967295", "--uniform"],
    ));
    std::thread::sleep(Duration::from_millis(200));
    running.signal("INT");
    let signalled = Instant::now();
    let (status, seen) = finish_within(running, Duration::from_secs(10));
    println!("stopped {:?} after the signal", signalled.elapsed());
    assert_eq!(status.code(), Some(130), "{seen}");
    assert!(seen.contains("--spp 4294967295); checkpoint written to"), "{seen}");

    // One 16x16 tile: one thread renders its pixels in turn, and stops inside one of them.
    let size = ["--width", "3", "--height", "2", "--seed", "3"];
    for (name, mode) in [
        ("uniform", &["--spp", "400000", "--uniform"][..]),
        ("target", &["--spp", "400000", "--target-error", "0.0005"]),
        ("adaptive", &["--spp", "400000"]),
        ("wavefront", &["--spp", "400000", "--path-loop", "wavefront"]),
    ] {
        let whole = dir.join(format!("{name}-whole.exr"));
        let o = render(&whole, &[&size[..], mode].concat()).output().unwrap();
        assert!(o.status.success(), "{name}: {}", String::from_utf8_lossy(&o.stderr));
        let out = dir.join(format!("{name}.exr"));
        let running = common::Running::start_rendering(&mut render(&out, &[&size[..], mode].concat()));
        std::thread::sleep(Duration::from_millis(150));
        running.signal("TERM");
        let (status, seen) = finish_within(running, Duration::from_secs(10));
        assert_eq!(status.code(), Some(143), "{name}: {seen}");
        let o = render(&out, &[&size[..], mode, &["--resume"]].concat()).output().unwrap();
        assert!(o.status.success(), "{name}: {}", String::from_utf8_lossy(&o.stderr));
        assert!(
            std::fs::read(&out).unwrap() == std::fs::read(&whole).unwrap(),
            "{name}: resumed image differs ({seen})"
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A signal while a finished render is denoised cancels the denoiser and writes a checkpoint
/// of the finished render (it was answered after the denoise, exit 0, no checkpoint); resuming
/// it only denoises and writes. A signal while the image is written lets the write complete
/// and says so, with the signal's exit code (it said "then writing a checkpoint", exit 0).
#[test]
fn signals_while_denoising_or_writing_say_what_happened() {
    let dir = common::fresh_dir("resume", "late-signals");
    let scene = common::scene_path("spheres.toml");
    let out = dir.join("denoised.png");
    let ckpt = dir.join("denoised.png.checkpoint");
    let args = ["--width", "640", "--height", "480", "--spp", "1", "--denoise"];
    let mut c = Command::new(env!("CARGO_BIN_EXE_ember"));
    c.arg("render").arg(&scene).arg("-o").arg(&out).args(args);
    let mut running = common::Running::start_rendering(&mut c);
    running.wait_for_line("denoising ");
    running.signal("TERM");
    let signalled = Instant::now();
    let (status, seen) = finish_within(running, Duration::from_secs(30));
    println!("denoiser stopped {:?} after the signal", signalled.elapsed());
    assert_eq!(status.code(), Some(143), "{seen}");
    assert!(
        seen.contains(&format!(
            "SIGTERM while denoising: the render was complete; checkpoint written to {}",
            ckpt.display()
        )),
        "{seen}"
    );
    assert!(ckpt.exists() && !out.exists(), "{seen}");
    let o = Command::new(env!("CARGO_BIN_EXE_ember"))
        .arg("render")
        .arg(&scene)
        .arg("-o")
        .arg(&out)
        .args(args)
        .arg("--resume")
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{e}");
    assert!(
        e.contains("(1.0 spp on average done, --spp 1)") && e.lines().any(|l| l.starts_with("denoised in ")),
        "{e}"
    );
    assert_eq!(rays_traced(&o.stderr), 0, "the resumed render rendered again");
    assert!(out.exists() && !ckpt.exists());

    // While writing: the temporary file appears, the signal comes, the write completes.
    let out = dir.join("written.png");
    let mut c = Command::new(env!("CARGO_BIN_EXE_ember"));
    c.arg("render").arg(&scene).arg("-o").arg(&out).args(["--width", "2000", "--height", "1500", "--spp", "1"]);
    let running = common::Running::start_rendering(&mut c);
    let start = Instant::now();
    let temporary = || {
        std::fs::read_dir(&dir).unwrap().any(|e| e.unwrap().file_name().to_string_lossy().starts_with(".written.png."))
    };
    while !temporary() {
        assert!(start.elapsed() < Duration::from_secs(60), "no temporary file");
        std::thread::sleep(Duration::from_millis(1));
    }
    running.signal("TERM");
    let (status, seen) = finish_within(running, Duration::from_secs(30));
    assert_eq!(status.code(), Some(143), "{seen}");
    assert!(
        seen.contains("SIGTERM: the render is finished: completing the image being written, then quitting"),
        "{seen}"
    );
    assert!(seen.contains(&format!("SIGTERM while {} was written: it was written in full", out.display())), "{seen}");
    assert_eq!(image::image_dimensions(&out).unwrap(), (2000, 1500));
    std::fs::remove_dir_all(&dir).unwrap();
}

//! Interrupt and resume: a render stopped by SIGTERM (or killed outright, after periodic
//! checkpoints) and resumed ends in the same image, bit for bit, as an uninterrupted one; a
//! checkpoint for other settings or another scene is refused.

mod common;

use ember::accel::EmbreeAccel;
use ember::embree::{BuildOptions, Device};
use ember::film::{Checkpoint, CheckpointError, Film};
use ember::integrator::{RenderControl, RenderError, RenderPlan, RenderSettings, render, render_controlled};
use ember::scene::Scene;
use std::io::{BufRead, BufReader};
use std::path::Path;
use std::process::{Command, Stdio};
use std::sync::atomic::AtomicBool;
use std::time::Duration;

/// The ray count an `ember render` summary line reports.
fn rays_traced(stderr: &[u8]) -> u64 {
    let text = String::from_utf8_lossy(stderr);
    let at = text.find(" rays, ").unwrap_or_else(|| panic!("no ray count in {text}"));
    let start = text[..at].rfind('(').unwrap() + 1;
    text[start..at].parse().unwrap()
}

/// Long enough (a few seconds on 2 cores) to be interrupted part-way.
const ARGS: [&str; 8] = ["--width", "32", "--height", "24", "--spp", "3000", "--seed", "5"];

fn ember(out: &Path, extra: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_ember"));
    c.arg("render").arg(common::scene_path("cornell-area.toml")).arg("-o").arg(out).args(ARGS).args(extra);
    c
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
    assert!(ckpt.exists() && !out.exists());
    let partial = Checkpoint::load(&ckpt).unwrap();
    let (min, _, max) = partial.accum.spp_range();
    assert!(min < 3000, "the render finished before the signal: make it longer");
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
    let run = start_and_signal(&out, &["--checkpoint-every", "0.2s"], Duration::from_millis(900), "KILL");
    assert_eq!(run.status.code(), None, "killed by a signal");
    let saved = Checkpoint::load(&ckpt).expect("a periodic checkpoint");
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

    let resume_with = |scene: &Scene, s: &RenderSettings| {
        let c = Checkpoint::load(&ckpt).unwrap();
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

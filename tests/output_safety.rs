//! What a render writes, and only that: two renders to one output cannot run together.

mod common;

use common::Running;
use ember::film::Checkpoint;
use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> =
        std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    v.sort();
    v
}

#[test]
fn a_second_render_to_the_same_output_is_refused() {
    let dir = common::fresh_dir("safety", "two-renders");
    let out = dir.join("out.exr");
    let ckpt = dir.join("out.exr.checkpoint");
    let lock = dir.join("out.exr.lock");
    let scene = common::scene_path("cornell-area.toml");
    let render = |extra: &[&str]| {
        let mut c = Command::new(env!("CARGO_BIN_EXE_ember"));
        c.arg("render").arg(&scene).arg("-o").arg(&out);
        c.args(["--width", "32", "--height", "24", "--spp", "3000", "--seed", "0", "--checkpoint-every", "0.05s"]);
        c.args(extra);
        c
    };
    let first = Running::start_rendering(&mut render(&[]));
    let start = Instant::now();
    while !ckpt.exists() {
        assert!(start.elapsed() < Duration::from_secs(10), "no periodic checkpoint");
        std::thread::sleep(Duration::from_millis(10));
    }
    let key = common::cli_checkpoint_key(&scene, 32, 24, 3000, 0);
    for extra in [&[][..], &["--resume"]] {
        let o = render(extra).output().unwrap();
        let e = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{extra:?}: {e}");
        assert_eq!(
            e.trim(),
            format!(
                "error: {}: another render is writing this output (it holds the lock {}); wait for it to end or \
                 choose another output",
                out.display(),
                lock.display()
            )
        );
        assert!(lock.exists(), "the second render removed the first one's lock");
        Checkpoint::load(&ckpt, &key).expect("the first render's checkpoint is intact");
    }
    first.signal("TERM");
    let (status, seen) = first.finish();
    assert_eq!(status.code(), Some(143), "{seen}");
    let saved = Checkpoint::load(&ckpt, &key).unwrap();
    assert!(saved.accum.samples() > 0);
    assert_eq!(listing(&dir), ["out.exr.checkpoint"]);
    std::fs::remove_dir_all(&dir).unwrap();
}

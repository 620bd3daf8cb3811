//! What a render writes, and only that: symbolic links planted at any name ember could write
//! are never followed, no temporary file is left behind (even when a second signal ends ember
//! at once), two renders to one output cannot run together, and the exit code says which
//! signal stopped a render.

mod common;

use common::Running;
use ember::film::Checkpoint;
use std::io::Write;
use std::os::unix::fs::symlink;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> =
        std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    v.sort();
    v
}

fn is_link(p: &Path) -> bool {
    std::fs::symlink_metadata(p).is_ok_and(|m| m.file_type().is_symlink())
}

fn is_file(p: &Path) -> bool {
    std::fs::symlink_metadata(p).is_ok_and(|m| m.file_type().is_file())
}

const PRECIOUS: &str = "precious: must survive every render";

/// The names an attacker who can write `dir` would plant links at for a render of `out` by
/// process `pid`: predictable temporary and probe names (`.PID.tmp.NAME`, for a few pids
/// around it), the checkpoint, the lock and the output itself.
fn planted_names(out: &str, pid: u32) -> Vec<String> {
    let mut names = vec![out.to_string(), format!("{out}.checkpoint"), format!("{out}.lock")];
    for p in pid.saturating_sub(3)..=pid + 3 {
        for name in [out.to_string(), format!("{out}.checkpoint")] {
            names.push(format!(".{p}.tmp.{name}"));
            names.push(format!(".{name}.{p}.probe"));
        }
    }
    names
}

/// Runs `ember ARGS` through `sh`, which stops until links are planted at every name for its
/// process id (`exec` keeps it), then lets it go on; the process, rendering or done. `planted`
/// gets the names.
fn spawn_after_planting(
    dir: &Path,
    out: &str,
    victim: &Path,
    args: &[&str],
    planted: &mut Vec<String>,
) -> std::process::Child {
    let mut child = Command::new("sh")
        .arg("-c")
        .arg("read go; exec \"$0\" \"$@\"")
        .arg(env!("CARGO_BIN_EXE_ember"))
        .args(args)
        .stdin(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let names = planted_names(out, child.id());
    for name in &names {
        let p = dir.join(name);
        let _ = std::fs::remove_file(&p);
        symlink(victim, &p).unwrap();
    }
    let mut stdin = child.stdin.take().unwrap();
    stdin.write_all(b"go\n").unwrap();
    drop(stdin);
    planted.extend(names);
    child
}

/// The victim is as it was, and `dir` holds nothing but the planted links (each still a link
/// or gone) and `made` (each now a regular file): no temporary file, no lock.
fn check_aftermath(dir: &Path, victim: &Path, planted: &[String], made: &[&str], what: &str) {
    assert_eq!(std::fs::read_to_string(victim).unwrap(), PRECIOUS, "{what}: the victim was written through a link");
    for name in listing(dir) {
        let p = dir.join(&name);
        if made.contains(&name.as_str()) {
            assert!(is_file(&p), "{what}: {name} should be a regular file");
        } else {
            assert!(planted.contains(&name), "{what}: {name} was left in the folder");
            assert!(is_link(&p), "{what}: {name} is no longer a link");
        }
    }
    for name in made {
        assert!(is_file(&dir.join(name)), "{what}: {name} was not written");
    }
}

#[test]
fn links_planted_at_every_name_ember_could_write_are_never_followed() {
    let dir = common::fresh_dir("safety", "links");
    let elsewhere = common::fresh_dir("safety", "victim");
    let victim = elsewhere.join("victim.png");
    std::fs::write(&victim, PRECIOUS).unwrap();
    let out = dir.join("out.png");
    let out_s = out.to_str().unwrap();

    let mut planted = Vec::new();
    // A render that succeeds: the image replaces the link at out.png.
    let spheres = common::scene_path("spheres.toml");
    let args = ["render", spheres.to_str().unwrap(), "-o", out_s, "--width", "16", "--height", "12", "--spp", "2"];
    let child = spawn_after_planting(&dir, "out.png", &victim, &args, &mut planted);
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    check_aftermath(&dir, &victim, &planted, &["out.png"], "success");
    assert_eq!(image::open(&out).unwrap().width(), 16);

    // A render stopped by SIGINT (exit code 130): the checkpoint replaces its link.
    std::fs::remove_file(&out).unwrap();
    let scene = common::scene_path("cornell-area.toml");
    let args = [
        "render",
        scene.to_str().unwrap(),
        "-o",
        out_s,
        "--width",
        "32",
        "--height",
        "24",
        "--spp",
        "3000",
        "--seed",
        "0",
        "--checkpoint-every",
        "0.05s",
    ];
    let mut child = spawn_after_planting(&dir, "out.png", &victim, &args, &mut planted);
    let stderr = child.stderr.take().unwrap();
    let mut running = Running::from_child(child, stderr);
    running.wait_for_line("kernel:");
    std::thread::sleep(Duration::from_millis(300));
    running.signal("INT");
    let (status, seen) = running.finish();
    assert_eq!(status.code(), Some(130), "{seen}");
    assert!(seen.contains("checkpoint written to"), "{seen}");
    check_aftermath(&dir, &victim, &planted, &["out.png.checkpoint"], "interrupted");
    let key = common::cli_checkpoint_key(&scene, 32, 24, 3000, 0);
    Checkpoint::load(&dir.join("out.png.checkpoint"), &key).unwrap();
    std::fs::remove_file(dir.join("out.png.checkpoint")).unwrap();

    // Renders that fail: resuming from a checkpoint that is a link to the victim (the wrong
    // size: refused unread), and a render that ends in an error (--strict).
    let args = ["render", spheres.to_str().unwrap(), "-o", out_s, "--width", "16", "--height", "12", "--resume"];
    let child = spawn_after_planting(&dir, "out.png", &victim, &args, &mut planted);
    let o = child.wait_with_output().unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("out.png.checkpoint: not a valid ember checkpoint"), "{e}");
    check_aftermath(&dir, &victim, &planted, &[], "failed resume");
    let hot = dir.join("hot.toml");
    std::fs::write(&hot, common::OVERFLOW_SCENE).unwrap();
    let args =
        ["render", hot.to_str().unwrap(), "-o", out_s, "--width", "8", "--height", "8", "--spp", "2", "--strict"];
    let child = spawn_after_planting(&dir, "out.png", &victim, &args, &mut planted);
    let o = child.wait_with_output().unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("--strict allows none"), "{e}");
    check_aftermath(&dir, &victim, &planted, &["hot.toml"], "failed render");
    std::fs::remove_dir_all(&dir).unwrap();
    std::fs::remove_dir_all(&elsewhere).unwrap();
}

#[test]
fn a_second_signal_quits_at_once_and_leaves_no_file() {
    let dir = common::fresh_dir("safety", "hard-exit");
    let out = dir.join("out.exr");
    // Two pixels of many samples: a pixel in flight takes seconds to finish.
    let running = Running::start_rendering(
        Command::new(env!("CARGO_BIN_EXE_ember"))
            .arg("render")
            .arg(common::scene_path("cornell-area.toml"))
            .arg("-o")
            .arg(&out)
            .args(["--width", "2", "--height", "1", "--spp", "50000000", "--checkpoint-every", "0.01s"]),
    );
    std::thread::sleep(Duration::from_millis(50));
    assert_eq!(listing(&dir), ["out.exr.lock"], "the lock is held while rendering");
    // A first signal is honoured within a group of samples: the second follows at once (two
    // `kill`s of one shell, a shell builtin), before the checkpoint is written.
    let pid = running.child.id();
    let start = Instant::now();
    let both = Command::new("sh").arg("-c").arg(format!("kill -INT {pid}; kill -TERM {pid}")).status().unwrap();
    assert!(both.success());
    let (status, seen) = running.finish();
    assert!(start.elapsed() < Duration::from_secs(5), "the second signal did not end ember at once");
    // Both signals are pending when the handler wakes; it may take them in either order, and
    // the exit code is the second one's.
    let (first, second, code) = if seen.contains("SIGTERM again: quitting") {
        ("interrupt", "SIGTERM", 143)
    } else {
        ("SIGTERM", "interrupt", 130)
    };
    assert_eq!(status.code(), Some(code), "{seen}");
    assert!(seen.contains(&format!("{first}: finishing the samples in flight")), "{seen}");
    assert!(seen.contains(&format!("{second} again: quitting without a checkpoint")), "{seen}");
    assert!(listing(&dir).is_empty(), "left behind: {:?}", listing(&dir));
    std::fs::remove_dir_all(&dir).unwrap();
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

/// `OUT.lock` is ember's name, but a file there that ember did not make as a lock (someone's
/// data, empty or not) is never taken for a stale lock: the render is refused and the file is
/// left as it was. A lock a killed render left is taken over.
#[test]
fn a_file_at_the_lock_name_that_is_not_a_lock_is_left_alone() {
    let dir = common::fresh_dir("safety", "foreign-lock");
    let out = dir.join("out.png");
    let lock = dir.join("out.png.lock");
    let scene = common::scene_path("spheres.toml");
    let render = || {
        Command::new(env!("CARGO_BIN_EXE_ember"))
            .arg("render")
            .arg(&scene)
            .arg("-o")
            .arg(&out)
            .args(["--width", "8", "--height", "6", "--spp", "1"])
            .output()
            .unwrap()
    };
    for data in ["data\n", ""] {
        std::fs::write(&lock, data).unwrap();
        let o = render();
        let e = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{e}");
        assert!(
            e.contains(&format!(
                "{}: {} is in the way: a file that is not a lock file of ember's",
                out.display(),
                lock.display()
            )),
            "{e}"
        );
        assert_eq!(std::fs::read_to_string(&lock).unwrap(), data, "the file at the lock's name changed");
        assert_eq!(listing(&dir), ["out.png.lock"]);
    }
    // A lock file a render killed outright left: taken over, and removed at the end.
    std::fs::write(&lock, ember::output_lock::MARKER).unwrap();
    let o = render();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_eq!(listing(&dir), ["out.png"]);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `ember merge` writes only its output, as a render does: it refuses an output that is one
/// of its inputs (shard files may have any name), holds the output's lock (a render to the
/// same output is refused, and the other way round), and a signal ends it at once with the
/// signal's exit code, leaving no temporary file and no lock.
#[test]
fn merge_refuses_its_inputs_as_output_holds_the_lock_and_stops_cleanly() {
    let dir = common::fresh_dir("safety", "merge");
    let scene = common::scene_path("spheres.toml");
    let shard = |k: u32, extra: &[&str]| {
        let out = dir.join(format!("part-{k}{}.shard", extra.len()));
        let o = Command::new(env!("CARGO_BIN_EXE_ember"))
            .arg("render")
            .arg(&scene)
            .arg("-o")
            .arg(&out)
            .args(["--shard", &format!("{k}/2"), "--spp", "1"])
            .args(if extra.is_empty() { &["--width", "96", "--height", "64"][..] } else { extra })
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        out
    };
    // A shard named like an image, and the merge asked to write over it.
    let a = dir.join("a.png");
    std::fs::rename(shard(0, &[]), &a).unwrap();
    let b = shard(1, &[]);
    let before = std::fs::read(&a).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_ember")).arg("merge").arg(&a).arg(&b).arg("-o").arg(&a).output().unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(
        e.contains(&format!(
            "{}: the merge reads this file ({}); writing the merged image there would destroy it",
            a.display(),
            a.display()
        )),
        "{e}"
    );
    assert_eq!(std::fs::read(&a).unwrap(), before, "an input of the merge was overwritten");

    // A render writing o.png holds its lock: the merge to o.png is refused.
    let o_png = dir.join("o.png");
    let render = Running::start_rendering(
        Command::new(env!("CARGO_BIN_EXE_ember"))
            .arg("render")
            .arg(common::scene_path("cornell-area.toml"))
            .arg("-o")
            .arg(&o_png)
            .args(["--width", "16", "--height", "16", "--spp", "100000"]),
    );
    let o =
        Command::new(env!("CARGO_BIN_EXE_ember")).arg("merge").arg(&a).arg(&b).arg("-o").arg(&o_png).output().unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("another render is writing this output"), "{e}");
    render.signal("KILL");
    let _ = render.finish();
    std::fs::remove_file(dir.join("o.png.lock")).unwrap();

    // Stopped while it works (denoising, here): exit 130, nothing left behind.
    let parts: Vec<_> = (0..2).map(|k| shard(k, &["--aux", "--width", "320", "--height", "240"])).collect();
    let mut merge = Command::new(env!("CARGO_BIN_EXE_ember"))
        .arg("merge")
        .args(&parts)
        .arg("-o")
        .arg(&o_png)
        .arg("--denoise")
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let lock = dir.join("o.png.lock");
    let start = Instant::now();
    while !lock.exists() {
        assert!(start.elapsed() < Duration::from_secs(20), "the merge never took its lock");
        std::thread::sleep(Duration::from_millis(1));
    }
    let kill = Command::new("kill").arg("-INT").arg(merge.id().to_string()).status().unwrap();
    assert!(kill.success());
    let status = merge.wait().unwrap();
    let mut e = String::new();
    std::io::Read::read_to_string(&mut merge.stderr.take().unwrap(), &mut e).unwrap();
    assert_eq!(status.code(), Some(130), "{e}");
    assert!(e.contains(&format!("interrupt: quitting; {} was not written", o_png.display())), "{e}");
    let mut left = listing(&dir);
    left.retain(|n| !n.ends_with(".shard") && n != "a.png");
    assert!(left.is_empty(), "left behind: {left:?}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A signal that reaches `ember merge` once its image is in place does not say the image was
/// not written: the merge ends with the signal's code and says it was written in full (or, if
/// the signal came too late, the merge had ended with 0).
#[test]
fn a_merge_stopped_after_its_image_is_in_place_says_it_was_written() {
    let dir = common::fresh_dir("safety", "merge-written");
    // Large enough that the merge still runs for a while after the rename (the summary's pass
    // over the pixels).
    let parts: Vec<_> = (0..2)
        .map(|k| {
            let out = dir.join(format!("part-{k}.shard"));
            let o = Command::new(env!("CARGO_BIN_EXE_ember"))
                .arg("render")
                .arg(common::scene_path("spheres.toml"))
                .arg("-o")
                .arg(&out)
                .args(["--shard", &format!("{k}/2"), "--spp", "1", "--uniform", "--width", "1500", "--height", "1500"])
                .output()
                .unwrap();
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
            out
        })
        .collect();
    let out = dir.join("big.exr");
    let mut merge = Command::new(env!("CARGO_BIN_EXE_ember"))
        .arg("merge")
        .args(&parts)
        .arg("-o")
        .arg(&out)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while !out.exists() {
        assert!(start.elapsed() < Duration::from_secs(60), "the merge never wrote its image");
        std::thread::yield_now();
    }
    let _ = Command::new("kill").arg("-TERM").arg(merge.id().to_string()).status();
    let status = merge.wait().unwrap();
    let mut e = String::new();
    std::io::Read::read_to_string(&mut merge.stderr.take().unwrap(), &mut e).unwrap();
    assert!(!e.contains("was not written"), "the image is there: {e}");
    match status.code() {
        Some(0) => {}
        Some(143) => assert!(e.contains("it was written in full; the merge is finished"), "{e}"),
        c => panic!("exit {c:?}: {e}"),
    }
    assert!(out.exists());
    let mut left = listing(&dir);
    left.retain(|n| !n.ends_with(".shard") && n != "big.exr");
    assert!(left.is_empty(), "left behind: {left:?}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The `resume with:` line is a command a POSIX shell runs as it was given: an output named
/// `a'$(touch PWNED)'b.png` is quoted so that pasting the line resumes the render and runs
/// nothing else.
#[test]
fn the_resume_line_is_quoted_for_a_shell() {
    let dir = common::fresh_dir("safety", "resume-quoting");
    let name = "a'$(touch PWNED)'b.png";
    let running = Running::start_rendering(
        Command::new(env!("CARGO_BIN_EXE_ember"))
            .current_dir(&dir)
            .arg("render")
            .arg(common::scene_path("cornell-area.toml"))
            .args(["-o", name, "--width", "4", "--height", "4", "--spp", "50000", "--uniform"]),
    );
    std::thread::sleep(Duration::from_millis(100));
    running.signal("INT");
    let (status, seen) = running.finish();
    assert_eq!(status.code(), Some(130), "{seen}");
    let line = seen.lines().find_map(|l| l.strip_prefix("resume with: ")).expect("a resume line");
    assert!(line.contains(r"'a'\''$(touch PWNED)'\''b.png'"), "{line}");
    let o = Command::new("sh").arg("-c").arg(line).current_dir(&dir).output().unwrap();
    assert!(o.status.success(), "{line}: {}", String::from_utf8_lossy(&o.stderr));
    assert!(!dir.join("PWNED").exists(), "the resume line ran a command substitution");
    assert_eq!(listing(&dir), [name]);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Output names are checked up front against the longest name ember writes beside them: a
/// name whose checkpoint's name would not fit in a file name (255 bytes) is refused before
/// rendering, and a name that fits but whose temporary files' names would not gets them
/// shortened: an interrupted render writes its checkpoint.
#[test]
fn long_output_names_are_refused_up_front_or_their_checkpoints_written() {
    let dir = common::fresh_dir("safety", "long-names");
    let refused = format!("{}.png", "r".repeat(246)); // 250 bytes: its checkpoint's name 261
    let o = Command::new(env!("CARGO_BIN_EXE_ember"))
        .current_dir(&dir)
        .arg("render")
        .arg(common::scene_path("spheres.toml"))
        .args(["-o", &refused, "--width", "8", "--height", "8", "--spp", "1"])
        .output()
        .unwrap();
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(
        e.contains("ember also writes its checkpoint beside it, whose name would be 261 bytes long, more than the 255"),
        "{e}"
    );
    assert!(listing(&dir).is_empty());
    // 229 bytes: its checkpoint's name (240) fits, its temporary file's name did not.
    let long = format!("{}.png", "l".repeat(225));
    let running = Running::start_rendering(
        Command::new(env!("CARGO_BIN_EXE_ember"))
            .current_dir(&dir)
            .arg("render")
            .arg(common::scene_path("cornell-area.toml"))
            .args(["-o", &long, "--width", "8", "--height", "8", "--spp", "200000", "--uniform"])
            .args(["--checkpoint-every", "0.05s"]),
    );
    std::thread::sleep(Duration::from_millis(300));
    running.signal("INT");
    let (status, seen) = running.finish();
    assert_eq!(status.code(), Some(130), "{seen}");
    assert!(!seen.contains("could not be written"), "{seen}");
    assert_eq!(listing(&dir), [format!("{long}.checkpoint")]);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A closed stderr (`ember render … 2>&1 | true`, a terminal gone) loses the messages, not the
/// render: no panic, the image written, exit 0; a closed stdout likewise for `ember info`.
#[test]
fn closed_standard_streams_lose_only_the_text() {
    let dir = common::fresh_dir("safety", "closed-stderr");
    let out = dir.join("out.png");
    let mut child = Command::new(env!("CARGO_BIN_EXE_ember"))
        .arg("render")
        .arg(common::scene_path("spheres.toml"))
        .arg("-o")
        .arg(&out)
        .args(["--width", "8", "--height", "8", "--spp", "1"])
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stderr.take()); // its reading end closed: every write fails (EPIPE)
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(0));
    assert!(out.is_file(), "no image");
    let mut info = Command::new(env!("CARGO_BIN_EXE_ember"))
        .arg("info")
        .arg(common::scene_path("spheres.toml"))
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    drop(info.stdout.take());
    assert_eq!(info.wait().unwrap().code(), Some(0));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `--preview-every`: while a render runs, the output is a whole image of the render so far
/// (an image viewer that reloads it shows the render converging); the final image is the one
/// a render without previews writes, byte for byte; a render interrupted after a preview
/// leaves that preview, a whole image, and its checkpoint, and no temporary file.
#[test]
fn previews_are_whole_images_and_change_nothing() {
    let dir = common::fresh_dir("safety", "preview");
    let scene = common::scene_path("cornell-area.toml");
    let render = |out: &Path, extra: &[&str]| {
        let mut c = Command::new(env!("CARGO_BIN_EXE_ember"));
        c.arg("render").arg(&scene).arg("-o").arg(out);
        c.args(["--width", "32", "--height", "24", "--spp", "1500", "--seed", "3"]).args(extra);
        c
    };
    // Waits for the first preview while `running` renders; returns it, decoded.
    let first_preview = |out: &Path| {
        let lock = out.with_extension("png.lock");
        let start = Instant::now();
        while !out.exists() {
            assert!(start.elapsed() < Duration::from_secs(20), "no preview");
            assert!(lock.exists(), "the render ended before its first preview: make it longer");
            std::thread::sleep(Duration::from_millis(5));
        }
        image::open(out).expect("a preview is a whole PNG").to_rgb8()
    };
    let reference = dir.join("reference.png");
    let o = render(&reference, &[]).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));

    let out = dir.join("out.png");
    let running = Running::start_rendering(&mut render(&out, &["--preview-every", "0.05s"]));
    let preview = first_preview(&out);
    assert_eq!(preview.dimensions(), (32, 24));
    let (status, seen) = running.finish();
    assert!(status.success(), "{seen}");
    assert!(std::fs::read(&out).unwrap() == std::fs::read(&reference).unwrap(), "the final image changed");
    assert_ne!(preview, image::open(&out).unwrap().to_rgb8(), "the preview was the final image");

    let out = dir.join("stopped.png");
    let running = Running::start_rendering(&mut render(&out, &["--preview-every", "0.05s"]));
    first_preview(&out);
    running.signal("INT");
    let (status, seen) = running.finish();
    assert_eq!(status.code(), Some(130), "{seen}");
    assert_eq!(image::open(&out).expect("the last preview is a whole PNG").to_rgb8().dimensions(), (32, 24));
    let left: Vec<String> = listing(&dir).into_iter().filter(|n| n.starts_with("stopped")).collect();
    assert_eq!(left, ["stopped.png", "stopped.png.checkpoint"], "{:?}", listing(&dir));
    assert!(listing(&dir).iter().all(|n| !n.starts_with('.')), "temporary files left: {:?}", listing(&dir));
    std::fs::remove_dir_all(&dir).unwrap();
}

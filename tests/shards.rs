//! One image rendered as shards (`ember render --shard K/N`, on as many machines) and merged
//! (`ember merge`) is the image of a whole render, byte for byte, whatever N; the merge refuses
//! a missing or duplicate shard, shards of another scene or other settings, and damaged files,
//! naming them and writing nothing; a shard interrupted and resumed merges to the same image.

mod common;

use common::Running;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const SIZE: [&str; 6] = ["--width", "53", "--height", "37", "--spp", "8"];

fn ember(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_ember")).args(args).output().unwrap()
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

fn ok(o: &Output) {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// Renders shard `k` of `n` of `scene` into `dir`; its path.
fn shard(dir: &Path, scene: &Path, k: u32, n: u32, extra: &[&str]) -> PathBuf {
    let out = dir.join(format!("part-{k}-of-{n}.shard"));
    let shard = format!("{k}/{n}");
    ok(&ember(&[&["render", s(scene), "-o", s(&out), "--shard", &shard][..], &SIZE, extra].concat()));
    out
}

fn merge(parts: &[PathBuf], out: &Path) -> Output {
    merge_with(parts, out, &[])
}

fn merge_with(parts: &[PathBuf], out: &Path, extra: &[&str]) -> Output {
    let mut args: Vec<&str> = vec!["merge"];
    args.extend(parts.iter().map(|p| s(p)));
    args.extend(["-o", s(out)]);
    args.extend(extra);
    ember(&args)
}

/// The look of a PNG (exposure, tone curve) is the merge's to apply, as a whole render's; and
/// Gaussian-filtered shards merge to the whole Gaussian render.
#[test]
fn merged_shards_take_the_look_and_filter_of_a_whole_render() {
    let d = common::fresh_dir("shards", "look");
    let scene = common::scene_path("spheres.toml");
    let look = ["--exposure", "1.5", "--tonemap", "aces"];
    let filter = ["--filter", "gaussian"];
    let whole = d.join("whole.png");
    ok(&ember(&[&["render", s(&scene), "-o", s(&whole)][..], &SIZE, &filter, &look].concat()));
    let parts: Vec<PathBuf> = (0..3).map(|k| shard(&d, &scene, k, 3, &filter)).collect();
    let merged = d.join("merged.png");
    ok(&merge_with(&parts, &merged, &look));
    assert!(std::fs::read(&merged).unwrap() == std::fs::read(&whole).unwrap(), "merged PNG differs");
    // Without the look, a different PNG: the flags were not ignored.
    let plain = d.join("plain.png");
    ok(&merge(&parts, &plain));
    assert!(std::fs::read(&plain).unwrap() != std::fs::read(&whole).unwrap());
    // A shard of another filter is another image's (it replaces part 0, no longer needed).
    let other = shard(&d, &scene, 0, 3, &[]);
    refused(&d, &[other, parts[1].clone(), parts[2].clone()], "filter=box in ");
}

#[test]
fn merged_shards_are_the_whole_render_byte_for_byte() {
    let d = common::fresh_dir("shards", "equal");
    // Area light, glass, glossy: every kind of path; and adaptive sampling, whose per-pixel
    // stopping must not depend on the split either.
    for (scene, extra) in [
        (common::scene_path("spheres.toml"), &[][..]),
        (common::scene_path("cornell-area.toml"), &["--target-error", "0.2"]),
    ] {
        for ext in ["png", "exr"] {
            let whole = d.join(format!("whole.{ext}"));
            ok(&ember(&[&["render", s(&scene), "-o", s(&whole)][..], &SIZE, extra].concat()));
            for n in [1, 2, 3, 7] {
                let parts: Vec<PathBuf> = (0..n).rev().map(|k| shard(&d, &scene, k, n, extra)).collect();
                let merged = d.join(format!("merged-{n}.{ext}"));
                ok(&merge(&parts, &merged));
                assert!(
                    std::fs::read(&merged).unwrap() == std::fs::read(&whole).unwrap(),
                    "{}: {n} shards merged to {ext} differ from the whole render",
                    scene.display()
                );
            }
        }
    }
}

/// Shards rendered with --aux keep the albedo and normal sums: merged, the EXR with its
/// layers is a whole --aux render's, byte for byte; rendered with --denoise, the merge
/// denoises and gives the whole --denoise render's EXR. Without the sums, --denoise at the
/// merge is refused, and shards with and without them are not merged together.
#[test]
fn shards_with_aux_sums_merge_and_denoise_as_a_whole_render() {
    let d = common::fresh_dir("shards", "aux");
    let scene = common::scene_path("spheres.toml");
    for flag in ["--aux", "--denoise"] {
        let whole = d.join(format!("whole{flag}.exr"));
        ok(&ember(&[&["render", s(&scene), "-o", s(&whole), flag][..], &SIZE].concat()));
        let parts: Vec<PathBuf> = (0..3).map(|k| shard(&d, &scene, k, 3, &[flag])).collect();
        let merged = d.join(format!("merged{flag}.exr"));
        let o = merge(&parts, &merged);
        ok(&o);
        let said = String::from_utf8_lossy(&o.stderr);
        assert_eq!(said.lines().any(|l| l.starts_with("denoised in ")), flag == "--denoise", "{said}");
        assert!(std::fs::read(&merged).unwrap() == std::fs::read(&whole).unwrap(), "{flag}: merged EXR differs");
    }
    // --aux shards denoised at the merge: the --denoise render's image.
    let parts: Vec<PathBuf> = (0..2).map(|k| shard(&d, &scene, k, 2, &["--aux"])).collect();
    let merged = d.join("merged-then-denoised.exr");
    ok(&merge_with(&parts, &merged, &["--denoise"]));
    assert!(std::fs::read(&merged).unwrap() == std::fs::read(d.join("whole--denoise.exr")).unwrap());
    // Without the sums there is nothing to denoise with; and a mixed set is refused.
    let plain_dir = d.join("plain");
    std::fs::create_dir_all(&plain_dir).unwrap();
    let plain: Vec<PathBuf> = (0..2).map(|k| shard(&plain_dir, &scene, k, 2, &[])).collect();
    let out = d.join("refused.exr");
    let o = merge_with(&plain, &out, &["--denoise"]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("--denoise needs the albedo and normal sums"), "{e}");
    assert!(!out.exists());
    refused(&d, &[plain[0].clone(), parts[1].clone()], "rendered with --aux");
}

/// `ember merge PARTS -o out.png` fails with exit code 2, `needle` in its error, and writes
/// nothing.
fn refused(dir: &Path, parts: &[PathBuf], needle: &str) {
    let out = dir.join("out.png");
    let o = merge(parts, &out);
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{parts:?}: {e}");
    assert!(e.contains(needle), "{parts:?}: expected {needle:?} in {e}");
    assert!(e.contains("error: "), "{e}");
    assert!(!out.exists(), "{parts:?}: an image was written");
}

#[test]
fn the_merge_refuses_a_wrong_set_of_shards() {
    let d = common::fresh_dir("shards", "refusals");
    let scene = common::scene_path("cornell-area.toml");
    let parts: Vec<PathBuf> = (0..3).map(|k| shard(&d, &scene, k, 3, &[])).collect();
    let name = |p: &PathBuf| p.file_name().unwrap().to_str().unwrap().to_string();
    refused(&d, &parts[..2], "shard 2/3 of the image missing (given 2 of 3)");
    refused(
        &d,
        &[parts[0].clone(), parts[1].clone(), parts[1].clone()],
        &format!("{} and {} are both shard 1/3", s(&parts[1]), s(&parts[1])),
    );
    // Another scene, other settings, another shard count.
    let other_scene = d.join("other-scene");
    std::fs::create_dir_all(&other_scene).unwrap();
    let other = shard(&other_scene, &common::scene_path("cornell.toml"), 2, 3, &[]);
    refused(&d, &[parts[0].clone(), parts[1].clone(), other.clone()], "is a shard of another scene");
    let other_settings = d.join("other-settings");
    std::fs::create_dir_all(&other_settings).unwrap();
    let seeded = shard(&other_settings, &scene, 2, 3, &["--seed", "5"]);
    refused(&d, &[parts[0].clone(), parts[1].clone(), seeded], "seed=0 in");
    // Embree's SSE4.2 kernels round hit points otherwise than the widest set the CPU runs
    // (the default, whatever it is here): the merge would not be the whole render's image.
    let narrow = shard(&other_settings, &scene, 2, 3, &["--embree-kernels", "sse4.2"]);
    let widest = ember::embree::Kernels::widest();
    if widest != ember::embree::Kernels::Sse42 {
        refused(&d, &[parts[0].clone(), parts[1].clone(), narrow], &format!("kernels={widest} in"));
    }
    let four = shard(&d, &scene, 3, 4, &[]);
    refused(&d, &[parts[0].clone(), parts[1].clone(), four], "the counts differ");
    // Damaged: cut short, one byte changed, not a shard at all.
    let bytes = std::fs::read(&parts[2]).unwrap();
    let cut = d.join("cut.shard");
    std::fs::write(&cut, &bytes[..bytes.len() - 100]).unwrap();
    refused(&d, &[parts[0].clone(), parts[1].clone(), cut], "truncated or damaged");
    let mut flipped = bytes.clone();
    let at = bytes.len() / 2;
    flipped[at] ^= 0x40;
    let flip = d.join("flip.shard");
    std::fs::write(&flip, &flipped).unwrap();
    refused(&d, &[parts[0].clone(), parts[1].clone(), flip], "checksum mismatch");
    let png = d.join("image.png");
    ok(&ember(&[&["render", s(&scene), "-o", s(&png)][..], &SIZE].concat()));
    refused(&d, &[parts[0].clone(), parts[1].clone(), png], "not written by `ember render --shard`");
    // The right set, in any order, merges.
    ok(&merge(&[parts[2].clone(), parts[0].clone(), parts[1].clone()], &d.join("fine.png")));
    assert!(!name(&parts[0]).is_empty());
}

#[test]
fn a_shard_needs_a_shard_file_name_and_a_valid_index() {
    let d = common::fresh_dir("shards", "flags");
    let scene = common::scene_path("cornell-area.toml");
    for (args, needle) in [
        (&["--shard", "1/2", "-o", "x.png"][..], "give the output a name ending in .shard"),
        (&["--shard", "2/2", "-o", "x.shard"], "expected K/N with 0 <= K < N"),
        (&["--shard", "auto", "-o", "x.shard"], "SLURM_ARRAY_TASK_COUNT is not set"),
        // No image has more tile diagonals: a count that could only make empty shards (and a
        // merge that allocated 64 GB for them) is refused with the limit.
        (&["--shard", "0/4000000000", "-o", "x.shard"], "4000000000 shards: at most 2047"),
        (&["--shard", "0/2048", "-o", "x.shard", "--first-round"], "2048 shards: at most 2047"),
    ] {
        let o = Command::new(env!("CARGO_BIN_EXE_ember"))
            .current_dir(&d)
            .args([&["render", s(&scene)][..], args, &SIZE].concat())
            .env_remove("SLURM_ARRAY_TASK_ID")
            .env_remove("SLURM_ARRAY_TASK_COUNT")
            .env_remove("JOB_COMPLETION_INDEX")
            .output()
            .unwrap();
        let e = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {e}");
        assert!(e.contains(needle), "{args:?}: {e}");
    }
    assert_eq!(std::fs::read_dir(&d).unwrap().count(), 0, "files were written");
    // The index from Slurm's environment.
    let o = Command::new(env!("CARGO_BIN_EXE_ember"))
        .current_dir(&d)
        .args([&["render", s(&scene), "--shard", "auto", "-o", "slurm.shard"][..], &SIZE].concat())
        .env("SLURM_ARRAY_TASK_ID", "1")
        .env("SLURM_ARRAY_TASK_COUNT", "2")
        .output()
        .unwrap();
    ok(&o);
    let header = ember::film::shard::ShardReader::open(&d.join("slurm.shard")).unwrap().header;
    assert_eq!(header.shard, "1/2".parse().unwrap());
}

#[test]
fn a_shard_interrupted_and_resumed_merges_to_the_same_image() {
    let d = common::fresh_dir("shards", "resume");
    let scene = common::scene_path("cornell-area.toml");
    // Long enough to be interrupted part-way; adaptive, so in two stages, the second
    // interrupted and resumed.
    let long = ["--width", "48", "--height", "32", "--spp", "3000", "--threads", "2"];
    let whole = d.join("whole.exr");
    ok(&ember(&[&["render", s(&scene), "-o", s(&whole)][..], &long].concat()));
    let firsts: Vec<PathBuf> = (0..2).map(|k| d.join(format!("first{k}.shard"))).collect();
    for (k, f) in firsts.iter().enumerate() {
        let shard = format!("{k}/2");
        ok(&ember(&[&["render", s(&scene), "--shard", &shard, "--first-round", "-o", s(f)][..], &long].concat()));
    }
    let plan_from = ["--plan-from", s(&firsts[0]), s(&firsts[1])];
    let parts: Vec<PathBuf> = (0..2).map(|k| d.join(format!("p{k}.shard"))).collect();
    ok(&ember(&[&["render", s(&scene), "--shard", "0/2", "-o", s(&parts[0])][..], &long, &plan_from].concat()));
    let mut c = Command::new(env!("CARGO_BIN_EXE_ember"));
    c.args([&["render", s(&scene), "--shard", "1/2", "-o", s(&parts[1])][..], &long, &plan_from].concat());
    let run = Running::start_rendering(&mut c);
    std::thread::sleep(std::time::Duration::from_millis(300));
    run.signal("INT");
    let (status, stderr) = run.finish();
    assert_eq!(status.code(), Some(130), "{stderr}");
    assert!(!parts[1].exists(), "an interrupted shard wrote its file");
    let mut checkpoint = parts[1].clone().into_os_string();
    checkpoint.push(".checkpoint");
    assert!(Path::new(&checkpoint).is_file(), "{stderr}");
    let resume = [&["render", s(&scene), "--shard", "1/2", "-o", s(&parts[1]), "--resume"][..], &long, &plan_from];
    ok(&ember(&resume.concat()));
    let merged = d.join("merged.exr");
    ok(&merge(&parts, &merged));
    assert!(std::fs::read(&merged).unwrap() == std::fs::read(&whole).unwrap(), "the resumed shard's merge differs");
}

/// Adaptive sampling (the default above 8 spp) plans from the whole image's first round, so a
/// shard of it takes two stages: `--first-round` (what needs no other shard), then
/// `--plan-from` every shard's first round. The merged image is the whole render's, byte for
/// byte; each stage refuses what is not its input.
#[test]
fn adaptive_shards_render_in_two_stages_and_merge_to_the_whole_render() {
    let d = common::fresh_dir("shards", "two-stages");
    let scene = common::scene_path("cornell-area.toml");
    let size = ["--width", "53", "--height", "37", "--spp", "32"];
    let render = |extra: &[&str]| ember(&[&["render", s(&scene)][..], &size, extra].concat());
    let stages = |mode: &[&str], n: u32| -> Vec<PathBuf> {
        let firsts: Vec<PathBuf> = (0..n).map(|k| d.join(format!("first-{k}-of-{n}.shard"))).collect();
        for (k, f) in firsts.iter().enumerate() {
            ok(&render(&[mode, &["--shard", &format!("{k}/{n}"), "--first-round", "-o", s(f)]].concat()));
        }
        (0..n)
            .map(|k| {
                let out = d.join(format!("part-{k}-of-{n}.shard"));
                let mut args = vec!["--shard".to_string(), format!("{k}/{n}"), "-o".into(), s(&out).into()];
                args.push("--plan-from".into());
                // In reverse order: any order does.
                args.extend(firsts.iter().rev().map(|f| s(f).to_string()));
                let args: Vec<&str> = mode.iter().copied().chain(args.iter().map(String::as_str)).collect();
                ok(&render(&args));
                out
            })
            .collect()
    };
    for (mode, n) in [(&[][..], 3), (&["--uniform"][..], 2)] {
        let whole = d.join("whole.exr");
        let o = render(&[mode, &["-o", s(&whole)]].concat());
        ok(&o);
        let said = String::from_utf8_lossy(&o.stderr);
        // The default is adaptive: pixels take different counts for the budget of 32 spp.
        assert_eq!(said.contains(" spp on average (adaptive: "), mode.is_empty(), "{said}");
        let parts = stages(mode, n);
        let merged = d.join("merged.exr");
        ok(&merge(&parts, &merged));
        assert!(std::fs::read(&merged).unwrap() == std::fs::read(&whole).unwrap(), "{mode:?}: merged EXR differs");
    }
    // One stage is refused for an adaptive shard, before anything is written.
    let one = d.join("one.shard");
    let o = render(&["--shard", "0/3", "-o", s(&one)]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("two stages, --first-round then --plan-from"), "{e}");
    assert!(!one.exists());
    // The merge refuses first rounds; stage 2 refuses a missing first round, a finished shard,
    // other settings, and writing over its input.
    let firsts: Vec<PathBuf> = (0..3).map(|k| d.join(format!("first-{k}-of-3.shard"))).collect();
    refused(&d, &firsts, "is the first round of a shard (ember render --first-round)");
    let stage2 = |out: &Path, from: &[&Path], extra: &[&str]| {
        let mut args = vec!["--shard", "1/3", "-o", s(out)];
        args.extend(extra);
        args.push("--plan-from");
        args.extend(from.iter().map(|p| s(p)));
        let o = render(&args);
        assert_eq!(o.status.code(), Some(2), "{}", String::from_utf8_lossy(&o.stderr));
        assert!(!out.exists() || out == firsts[1].as_path());
        String::from_utf8_lossy(&o.stderr).into_owned()
    };
    let out = d.join("refused.shard");
    let e = stage2(&out, &[&firsts[0], &firsts[1]], &[]);
    assert!(e.contains("shard 2/3 of the image missing"), "{e}");
    let finished = d.join("part-2-of-3.shard");
    let e = stage2(&out, &[&firsts[0], &firsts[1], &finished], &[]);
    assert!(e.contains("not a first-round file"), "{e}");
    let e = stage2(&out, &[&firsts[0], &firsts[1], &firsts[2]], &["--seed", "3"]);
    assert!(e.contains("seed=0 in"), "{e}");
    let e = stage2(&firsts[1], &[&firsts[0], &firsts[1], &firsts[2]], &[]);
    assert!(e.contains("--plan-from reads this file"), "{e}");
}

/// A shard file's header is checked before anything is sized by it: a shard count forged to
/// 2^32 − 1 (the merge used to allocate a slot per shard, 64 GB, before the checksum was read)
/// and settings holding a terminal's escape sequences are refused, naming the file.
#[test]
fn forged_shard_headers_are_refused_before_use() {
    let d = common::fresh_dir("shards", "forged");
    // One tile: shard 0 of any count holds all of it, so the forged file has the size its
    // header implies.
    let part = d.join("part.shard");
    let scene = common::scene_path("spheres.toml");
    ok(&ember(&["render", s(&scene), "-o", s(&part), "--shard", "0/1", "--width", "8", "--height", "8", "--spp", "2"]));
    let bytes = std::fs::read(&part).unwrap();
    let settings_len = u32::from_le_bytes(bytes[16..20].try_into().unwrap()) as usize;
    let fields = 20 + settings_len; // shard index, count, width, height, spp, …
    let mut forged = bytes.clone();
    forged[fields + 4..fields + 8].copy_from_slice(&u32::MAX.to_le_bytes());
    let bad = d.join("count.shard");
    std::fs::write(&bad, &forged).unwrap();
    refused(&d, &[bad], "not a valid ember shard file (4294967295 shards: at most 2047");
    // ESC [ 2 J (clear the screen) in place of a setting's bytes: refused, not printed.
    let mut forged = bytes;
    forged[20..24].copy_from_slice(b"\x1b[2J");
    let sum = ember::hash::fnv1a(&forged[..forged.len() - 8]);
    let n = forged.len();
    forged[n - 8..].copy_from_slice(&sum.to_le_bytes());
    let bad = d.join("escape.shard");
    std::fs::write(&bad, &forged).unwrap();
    let o = merge(&[part.clone(), bad.clone()], &d.join("out.png"));
    let e = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains(&format!("{}: not a valid ember shard file (the settings are not text)", s(&bad))), "{e}");
    assert!(!e.contains('\x1b'), "an escape sequence was printed: {e:?}");
    std::fs::remove_dir_all(&d).unwrap();
}

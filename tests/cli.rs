//! The command line: what it prints and writes when things go right (error paths are in
//! `cli_errors.rs`).

mod common;

use common::OVERFLOW_SCENE as OVERFLOW;
use common::ember;
use std::path::{Path, PathBuf};
use std::process::Output;

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn info_reports_counts_bounds_and_build_time() {
    let o = ember(&["info", common::scene_path("teapot.obj").to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("triangles:  6320"), "{out}");
    assert!(out.contains("(-3.0000, 0.0000, -2.0000) .. (3.4340, 3.1500, 2.0000)"), "{out}");
    assert!(out.contains("bvh build:") && out.contains("(medium quality, as ember render builds it)"), "{out}");
    assert!(out.contains("lights:     1 light in 1 group: nothing to choose"), "{out}");
    let o = ember(&["info", common::scene_path("cornell_box.obj").to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("triangles:  34"), "{out}");
    // A small all-triangle scene: the Morton build (accel::build_quality_for).
    assert!(out.contains("(low quality, as ember render builds it)"), "{out}");
    // The teapot scene's quad light (two triangles) and sky: two groups.
    let o = ember(&["info", common::scene_path("teapot.toml").to_str().unwrap()]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        out.contains("lights:     3 lights in 2 groups: a group chosen by importance at each shading point, a light within it by power"),
        "{out}"
    );
}

#[test]
fn render_writes_a_png_atomically() {
    let d = common::fresh_dir("cli", "render");
    let out = d.join("teapot.png");
    let o = ember(&[
        "render",
        common::scene_path("teapot.obj").to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--width",
        "64",
        "--height",
        "48",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let img = image::open(&out).unwrap();
    assert_eq!((img.width(), img.height()), (64, 48));
    // Nothing but the image: no temporary or probe file left behind, whatever its name.
    let names: Vec<_> = std::fs::read_dir(&d).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(names, ["teapot.png"]);
}

#[test]
fn exr_output_is_linear_float_and_matches_png() {
    let d = common::fresh_dir("cli", "exr");
    let (exr, png) = (d.join("o.exr"), d.join("o.png"));
    let scene = common::scene_path("cornell-area.toml");
    for out in [&exr, &png] {
        let o = ember(&[
            "render",
            scene.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--width",
            "16",
            "--height",
            "16",
            "--spp",
            "4",
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let film = ember::film::Film::load_exr(&exr).unwrap();
    assert_eq!((film.width, film.height), (16, 16));
    assert!(film.pixels.iter().all(|p| p.is_finite()));
    // Same seed: the PNG is the EXR's values in 8-bit sRGB.
    assert_eq!(image::open(&png).unwrap().to_rgb8().into_raw(), film.to_rgb8());
}

#[test]
fn exposure_and_tone_curve_change_the_png_only() {
    use ember::film::{Film, Look, Tonemap};
    let d = common::fresh_dir("cli", "look");
    let scene = common::scene_path("cornell-area.toml");
    let small = ["--width", "16", "--height", "16", "--spp", "4"];
    let run = |scene: &Path, out: &Path, extra: &[&str]| {
        let mut args = vec!["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap()];
        args.extend(small);
        args.extend(extra);
        let o = ember(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        stderr(&o)
    };
    // EXR stays linear: the look changes nothing in it, and a note says so.
    let (plain, looked) = (d.join("plain.exr"), d.join("looked.exr"));
    run(&scene, &plain, &[]);
    let e = run(&scene, &looked, &["--exposure", "-1.5", "--tonemap", "aces"]);
    assert!(e.contains("note: exposure -1.5 and tone curve aces apply to 8-bit output only"), "{e}");
    assert_eq!(std::fs::read(&plain).unwrap(), std::fs::read(&looked).unwrap());
    let film = Film::load_exr(&plain).unwrap();
    // PNG: exposure, then the curve, then sRGB.
    let png = d.join("neutral.png");
    let e = run(&scene, &png, &["--exposure", "1", "--tonemap", "neutral"]);
    assert!(!e.contains("note:"), "{e}");
    let look = Look { exposure: 1.0, tonemap: Tonemap::Neutral };
    let pixels = image::open(&png).unwrap().to_rgb8().into_raw();
    assert_eq!(pixels, film.to_rgb8_with(&look));
    assert_ne!(pixels, film.to_rgb8());
    // The same from the scene file's [render] keys; the command line wins over them.
    let text = std::fs::read_to_string(&scene).unwrap();
    let text = text.replacen("[render]\n", "[render]\nexposure = 1.0\ntonemap = \"neutral\"\n", 1);
    let keyed = write(&d, "keyed.toml", &text);
    for asset in ["cornell_box.obj", "cornell_box.mtl"] {
        let _ = std::fs::copy(common::scene_path(asset), d.join(asset));
    }
    let from_keys = d.join("keys.png");
    run(&keyed, &from_keys, &[]);
    assert_eq!(image::open(&from_keys).unwrap().to_rgb8().into_raw(), pixels);
    let overridden = d.join("overridden.png");
    run(&keyed, &overridden, &["--exposure", "0", "--tonemap", "clamp"]);
    assert_eq!(image::open(&overridden).unwrap().to_rgb8().into_raw(), film.to_rgb8());
}

#[test]
fn the_pixel_filter_from_the_command_line_or_the_scene() {
    let d = common::fresh_dir("cli", "filter");
    let scene = write(&d, "s.toml", &format!("[render]\nfilter = \"gaussian\"\n{SKY_SPHERE}"));
    let plain = write(&d, "plain.toml", SKY_SPHERE);
    let run = |scene: &Path, name: &str, extra: &[&str]| {
        let out = d.join(name);
        let mut args = vec!["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap()];
        args.extend(["--width", "12", "--height", "12", "--spp", "4"]);
        args.extend(extra);
        let o = ember(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        std::fs::read(&out).unwrap()
    };
    let from_scene = run(&scene, "scene.exr", &[]);
    assert_eq!(run(&plain, "flag.exr", &["--filter", "gaussian"]), from_scene);
    assert_ne!(run(&plain, "box.exr", &[]), from_scene);
    assert_eq!(run(&scene, "box-over-scene.exr", &["--filter", "box"]), run(&plain, "box2.exr", &[]));
}

#[test]
fn a_camera_on_the_command_line() {
    let d = common::fresh_dir("cli", "camera");
    let run = |scene: &Path, name: &str, extra: &[&str]| {
        let out = d.join(name);
        let mut args = vec!["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap()];
        args.extend(["--width", "12", "--height", "8", "--spp", "2"]);
        args.extend(extra);
        let o = ember(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        std::fs::read(&out).unwrap()
    };
    let camera = "[camera]\nposition = [0.5, 1.0, -4.0]\nlook_at = [0.0, 0.2, 0.0]\nup = [0.1, 1.0, 0.0]\nfov = 35.0\n";
    let with = write(&d, "with.toml", &format!("{camera}{SKY_SPHERE}"));
    let without = write(&d, "without.toml", SKY_SPHERE);
    // A scene without a camera given one: the image of the scene with that camera in its file.
    let from_file = run(&with, "file.exr", &[]);
    let flags = ["--camera-position", "0.5,1,-4", "--look-at", "0,0.2,0", "--up", "0.1,1,0", "--fov", "35"];
    assert_eq!(run(&without, "flags.exr", &flags), from_file);
    // Embree's tutorials' names.
    let aliases = ["--vp", "0.5,1,-4", "--vi", "0,0.2,0", "--vu", "0.1,1,0", "--fov", "35"];
    assert_eq!(run(&without, "aliases.exr", &aliases), from_file);
    // One part over a scene's camera.
    let wide = write(&d, "wide.toml", &format!("{}{SKY_SPHERE}", camera.replace("35.0", "70.0")));
    assert_eq!(run(&wide, "fov.exr", &["--fov", "35"]), from_file);
    // A mesh, from the other side of the framing camera.
    let teapot = common::scene_path("teapot.obj");
    assert_ne!(run(&teapot, "framed.exr", &[]), run(&teapot, "behind.exr", &["--camera-position", "-3,-2,-6"]));
}

/// The value of `key = [x, y, z]` in TOML lines, as `x,y,z`.
fn toml_vec3(text: &str, key: &str) -> String {
    let line = text.lines().find(|l| l.starts_with(&format!("{key} = ["))).unwrap_or_else(|| panic!("{key}: {text}"));
    line.split('[').nth(1).unwrap().trim_end_matches(']').replace(' ', "")
}

/// `ember render scenes/teapot.obj` to `out` at 16×12 and 2 spp with `extra`: the image's
/// bytes and what it printed.
fn render_teapot_obj(out: &Path, extra: &[&str]) -> (Vec<u8>, String) {
    let teapot = common::scene_path("teapot.obj");
    let mut args = vec!["render", teapot.to_str().unwrap(), "-o", out.to_str().unwrap()];
    args.extend(["--width", "16", "--height", "12", "--spp", "2"]);
    args.extend(extra);
    let o = ember(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    (std::fs::read(out).unwrap(), stderr(&o))
}

#[test]
fn the_automatic_camera_is_printed_as_a_scene_files_lines() {
    let teapot = common::scene_path("teapot.obj");
    let o = ember(&["info", teapot.to_str().unwrap()]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("camera: automatic, framing the scene for a 1.333:1 image (--orbit 28.8,21.5,"), "{out}");
    assert!(out.contains("; as a scene file's lines:\n[camera]\nposition = ["), "{out}");
    assert!(out.contains("\nlook_at = [0.21700001, 1.575, 0]\nup = [0, 1, 0]\nfov = 40\n"), "{out}");
    // `ember render` says the same, and its numbers are exact: given back as flags, the same
    // image.
    let d = common::fresh_dir("cli", "auto-camera");
    let run = |name: &str, extra: &[&str]| render_teapot_obj(&d.join(name), extra);
    let (image, said) = run("auto.exr", &[]);
    assert!(said.contains("camera: automatic, framing the scene for a 1.333:1 image"), "{said}");
    let (position, look_at) = (toml_vec3(&said, "position"), toml_vec3(&said, "look_at"));
    let (again, said) = run("given.exr", &["--camera-position", &position, "--look-at", &look_at]);
    assert_eq!(again, image);
    assert!(said.contains("camera: set by the command line"), "{said}");
    // A scene's own camera is not repeated.
    let o = ember(&["info", common::scene_path("cornell.toml").to_str().unwrap()]);
    assert!(String::from_utf8_lossy(&o.stdout).contains("camera: the scene's; as a scene file's lines:"));
    let out = d.join("c.png");
    let cornell = common::scene_path("cornell.toml");
    let o = ember(&["render", cornell.to_str().unwrap(), "-o", out.to_str().unwrap(), "--width", "8", "--height", "8"]);
    assert!(!stderr(&o).contains("[camera]"), "{}", stderr(&o));
}

#[test]
fn an_orbit_and_an_orthographic_view_on_the_command_line() {
    let d = common::fresh_dir("cli", "orbit");
    let run = |name: &str, extra: &[&str]| render_teapot_obj(&d.join(name), extra);
    // The teapot's bounds are (-3, 0, -2)..(3.434, 3.15, 2): its centre (0.217, 1.575, 0). At
    // azimuth 90, elevation 0, distance 10 the camera is 10 along +X from it.
    let (side, said) = run("side.exr", &["--orbit", "90,0,10"]);
    assert!(said.contains("(--orbit 90.0,0.0,10.0000 around the scene's centre)"), "{said}");
    let position: Vec<f32> = toml_vec3(&said, "position").split(',').map(|v| v.parse().unwrap()).collect();
    assert!((position[0] - 10.217).abs() < 1e-4 && (position[1] - 1.575).abs() < 1e-6 && position[2].abs() < 1e-5);
    // Orthographic from the same place: another image, and the lines say so.
    let (flat, said) = run("flat.exr", &["--orbit", "90,0,10", "--ortho", "8"]);
    assert_ne!(flat, side);
    assert!(said.contains("type = \"orthographic\"\nwidth = 8\n"), "{said}");
}

#[test]
fn a_scene_without_light_is_said_before_rendering() {
    let d = common::fresh_dir("cli", "dark");
    let sphere = SKY_SPHERE.split("[materials.m]").nth(1).unwrap();
    let scene = write(&d, "dark.toml", &format!("[materials.m]{sphere}"));
    let out = d.join("dark.png");
    let o = ember(&["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--width", "8", "--height", "8"]);
    let e = stderr(&o);
    assert!(o.status.success(), "{e}");
    let warning = format!(
        "warning: {}: nothing in the scene emits light: the image will be black; add a light, an emissive material or a [background]",
        scene.display()
    );
    let lines: Vec<&str> = e.lines().collect();
    let at = lines.iter().position(|l| *l == warning).unwrap_or_else(|| panic!("no warning line in {e}"));
    let rendered = lines.iter().position(|l| l.starts_with("rendered ")).unwrap();
    assert!(at < rendered && !lines[..at].iter().any(|l| l.starts_with("kernel:")), "{e}");
    assert!(image::open(&out).unwrap().to_rgb8().into_raw().iter().all(|&c| c == 0));
}

/// A grey sphere under a sky gradient.
const SKY_SPHERE: &str = "[background]\ntype = \"gradient\"\nzenith = [1.0, 1.0, 1.0]\nhorizon = [0.5, 0.6, 0.8]\n[materials.m]\ntype = \"diffuse\"\n[[spheres]]\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nmaterial = \"m\"\n";

#[test]
fn environment_image_background_lights_the_scene() {
    let d = common::fresh_dir("cli", "env");
    std::fs::copy(common::scene_path("earthmap.jpg"), d.join("env.jpg")).unwrap();
    let scene = write(
        &d,
        "env.toml",
        "[background]\ntype = \"image\"\nfile = \"env.jpg\"\nscale = 2.0\n[materials.m]\ntype = \"diffuse\"\n[[spheres]]\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nmaterial = \"m\"\n",
    );
    let out = d.join("env.exr");
    let o = ember(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--width",
        "16",
        "--height",
        "16",
        "--spp",
        "16",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let film = ember::film::Film::load_exr(&out).unwrap();
    // The framing camera sees the sphere in the middle; it must be lit (not black).
    assert!(film.get(8, 8).max_element() > 0.05, "{:?}", film.get(8, 8));
}

#[test]
fn check_runs_cases_and_prints_a_table() {
    let o = ember(&["check", "--quick", "--seed", "8", "grazing-plane", "inside-sphere"]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert_eq!(o.status.code(), Some(0), "{out}{}", stderr(&o));
    let lines: Vec<&str> = out.lines().collect();
    assert!(lines[0].contains("quick run, seed 8,"), "{out}");
    assert!(lines[1].starts_with("case") && lines[1].contains("result") && lines[1].contains("non-finite"), "{out}");
    for name in ["grazing-plane", "inside-sphere"] {
        let row = lines.iter().find(|l| l.starts_with(name)).unwrap_or_else(|| panic!("no row for {name}: {out}"));
        assert!(row.split_whitespace().nth(1) == Some("pass"), "{row}");
    }
    assert!(lines.last().unwrap().starts_with("2 cases, 2 passed, 0 failed"), "{out}");
}

/// `ember check --quick` is what a user runs to trust a build on a new machine: every case
/// must pass at the quick size too, not only at the full size `tests/hard_cases.rs` runs.
#[test]
fn the_quick_check_suite_passes() {
    let o = ember(&["check", "--quick"]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert_eq!(o.status.code(), Some(0), "{out}{}", stderr(&o));
    let n = ember::tools::check::catalog().len();
    assert!(out.lines().last().unwrap().starts_with(&format!("{n} cases, {n} passed, 0 failed")), "{out}");
}

#[test]
fn check_lists_cases_and_refuses_unknown_ones() {
    let o = ember(&["check", "--list"]);
    assert!(o.status.success());
    let out = String::from_utf8_lossy(&o.stdout);
    assert_eq!(out.lines().count(), ember::tools::check::catalog().len(), "{out}");
    assert!(out.contains("self-intersection"), "{out}");
    let o = ember(&["check", "no-such-case"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).starts_with("error: unknown case \"no-such-case\""), "{}", stderr(&o));
}

#[test]
fn strict_fails_on_non_finite_samples_and_writes_nothing() {
    let d = common::fresh_dir("cli", "strict");
    let scene = write(&d, "hot.toml", OVERFLOW);
    let out = d.join("hot.png");
    let args = [
        "render",
        scene.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--width",
        "16",
        "--height",
        "16",
        "--spp",
        "4",
    ];
    // Without --strict: rendered, and the summary counts the dropped samples.
    let o = ember(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let summary = stderr(&o);
    let count: u64 =
        summary.split(" non-finite samples dropped").next().unwrap().rsplit(' ').next().unwrap().parse().unwrap();
    assert!(count > 0, "{summary}");
    std::fs::remove_file(&out).unwrap();
    // With --strict: exit 2, a message naming the scene and the count, no image.
    let mut strict = args.to_vec();
    strict.push("--strict");
    let o = ember(&strict);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(e.contains(&format!("error: {}: {count} of 1024 samples were NaN or infinite", scene.display())), "{e}");
    assert!(e.contains("--strict allows none"), "{e}");
    assert!(!out.exists());
    // A clean scene passes --strict.
    let o = ember(&[
        "render",
        common::scene_path("spheres.toml").to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--width",
        "16",
        "--height",
        "12",
        "--spp",
        "2",
        "--strict",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains(" 0 non-finite samples dropped"), "{}", stderr(&o));
}

#[test]
fn degenerate_triangles_are_skipped_with_a_warning() {
    let d = common::fresh_dir("cli", "degenerate");
    let p = write(&d, "deg.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 2 2\nv nan 0 0\nf 1 2 3\nf 1 1 2\nf 1 4 5\nf 4 4 4\n");
    let o = ember(&["info", p.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("triangles:  1\n"), "{}", String::from_utf8_lossy(&o.stdout));
    let e = stderr(&o);
    assert!(
        e.starts_with(&format!("warning: {}: object", p.display())) && e.contains("skipped 3 degenerate triangle(s)"),
        "{e}"
    );
    // Only degenerate triangles: an error, not an empty scene.
    let p = write(&d, "all.obj", "v 0 0 0\nv 1 1 1\nv 2 2 2\nf 1 2 3\n");
    let o = ember(&["info", p.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("no triangles"), "{}", stderr(&o));
}

/// An error estimate takes two samples a pixel: at 1 spp the summary says so instead of
/// "estimated relative error: mean inf, max inf"; `--checkpoint-every 1e-3s` is a millisecond
/// (its unit was read as "e-3s").
#[test]
fn the_summary_and_durations_say_what_they_mean() {
    let d = common::fresh_dir("cli", "estimate");
    let out = d.join("out.png");
    let o = common::ember(&[
        "render",
        common::scene_path("spheres.toml").to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--width",
        "8",
        "--height",
        "8",
        "--spp",
        "1",
        "--checkpoint-every",
        "1e-3s",
    ]);
    let e = stderr(&o);
    assert!(o.status.success(), "{e}");
    assert!(!e.contains("inf"), "{e}");
    assert!(
        e.contains("estimated relative error: none (it takes at least 2 samples a pixel; every pixel has 1)"),
        "{e}"
    );
    std::fs::remove_dir_all(&d).unwrap();
}

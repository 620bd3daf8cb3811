//! The command line: what it prints and writes when things go right (error paths are in
//! `cli_errors.rs`).

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn ember(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_ember")).args(args).output().expect("ember runs")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("ember-cli-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
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
    assert!(out.contains("bvh build:"), "{out}");
    let o = ember(&["info", common::scene_path("cornell_box.obj").to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("triangles:  34"));
}

#[test]
fn render_writes_a_png_atomically() {
    let d = tmpdir("render");
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
    // No temporary file left behind.
    let leftovers: Vec<_> = std::fs::read_dir(&d).unwrap().filter_map(|e| e.ok()).filter(|e| e.file_name().to_string_lossy().ends_with(".tmp")).collect();
    assert!(leftovers.is_empty());
}

#[test]
fn exr_output_is_linear_float_and_matches_png() {
    let d = tmpdir("exr");
    let (exr, png) = (d.join("o.exr"), d.join("o.png"));
    let scene = common::scene_path("cornell-area.toml");
    for out in [&exr, &png] {
        let o = ember(&["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--width", "16", "--height", "16", "--spp", "4"]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let film = ember::film::Film::load_exr(&exr).unwrap();
    assert_eq!((film.width, film.height), (16, 16));
    assert!(film.pixels.iter().all(|p| p.is_finite()));
    // Same seed: the PNG is the EXR's values in 8-bit sRGB.
    assert_eq!(image::open(&png).unwrap().to_rgb8().into_raw(), film.to_rgb8());
}

#[test]
fn environment_image_background_lights_the_scene() {
    let d = tmpdir("env");
    std::fs::copy(common::scene_path("earthmap.jpg"), d.join("env.jpg")).unwrap();
    let scene = write(
        &d,
        "env.toml",
        "[background]\ntype = \"image\"\nfile = \"env.jpg\"\nscale = 2.0\n[materials.m]\ntype = \"diffuse\"\n[[spheres]]\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nmaterial = \"m\"\n",
    );
    let out = d.join("env.exr");
    let o = ember(&["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--width", "16", "--height", "16", "--spp", "16"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let film = ember::film::Film::load_exr(&out).unwrap();
    // The framing camera sees the sphere in the middle; it must be lit (not black).
    assert!(film.get(8, 8).max_element() > 0.05, "{:?}", film.get(8, 8));
}

//! The command line: output, exit codes and error messages.

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
fn missing_file_is_exit_2_with_path() {
    let o = ember(&["info", "no/such/file.obj"]);
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(stderr(&o).trim(), "error: no/such/file.obj: no such file");
}

#[test]
fn directory_given_as_file() {
    let d = tmpdir("dir");
    let p = d.join("folder.obj");
    std::fs::create_dir_all(&p).unwrap();
    let o = ember(&["info", p.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("is a directory"), "{}", stderr(&o));
}

#[test]
fn malformed_obj_names_file_and_line() {
    let d = tmpdir("malformed");
    let p = write(&d, "bad.obj", "# a triangle\nv 0 0 0\nv 1 0 0\nv 0 1 zero\nf 1 2 3\n");
    let o = ember(&["info", p.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(e.starts_with(&format!("error: {}:4: ", p.display())), "{e}");
    assert!(e.contains("\"zero\" is not a number"), "{e}");

    let p = write(&d, "range.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 7\n");
    let o = ember(&["info", p.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(e.starts_with(&format!("error: {}:5: ", p.display())) && e.contains("out of range"), "{e}");
}

#[test]
fn obj_without_faces_is_an_error() {
    let d = tmpdir("nofaces");
    let p = write(&d, "empty.obj", "v 0 0 0\n");
    let o = ember(&["info", p.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("no faces"), "{}", stderr(&o));
}

#[test]
fn unsupported_output_extension_writes_nothing() {
    let d = tmpdir("ext");
    let out = d.join("out.bmp");
    let o = ember(&["render", common::scene_path("teapot.obj").to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("unsupported output format"), "{}", stderr(&o));
    assert!(!out.exists());
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

/// Renders `toml` (written to a temp folder with the scene assets) and expects failure with
/// exit code 2, a message naming the file and `line`, containing `needle`, and no output.
fn expect_scene_error(name: &str, toml: &str, line: Option<usize>, needle: &str) {
    let d = tmpdir(name);
    let scene = write(&d, "scene.toml", toml);
    let out = d.join("out.png");
    let o = ember(&["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--width", "8", "--height", "8", "--spp", "1"]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{name}: {e}");
    let prefix = match line {
        Some(l) => format!("error: {}:{l}: ", scene.display()),
        None => format!("error: {}: ", scene.display()),
    };
    assert!(e.starts_with(&prefix), "{name}: expected prefix {prefix:?} in {e:?}");
    assert!(e.contains(needle), "{name}: expected {needle:?} in {e:?}");
    assert!(!out.exists(), "{name}: an output file was written");
}

const SPHERE_OK: &str = "[materials.m]\ntype = \"diffuse\"\n[[spheres]]\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nmaterial = \"m\"\n";

#[test]
fn scene_file_errors_name_file_line_and_problem() {
    expect_scene_error("unknown-material", &SPHERE_OK.replace("material = \"m\"", "material = \"steel\""), Some(6), "unknown material \"steel\"");
    expect_scene_error("unknown-type", &SPHERE_OK.replace("\"diffuse\"", "\"velvet\""), Some(2), "unknown variant `velvet`");
    expect_scene_error("unknown-key", &format!("{SPHERE_OK}colour = 3\n"), Some(7), "unknown field `colour`");
    expect_scene_error("negative-radius", &SPHERE_OK.replace("radius = 1.0", "radius = -2.0"), Some(5), "greater than 0");
    expect_scene_error("zero-radius", &SPHERE_OK.replace("radius = 1.0", "radius = 0.0"), Some(5), "greater than 0");
    expect_scene_error("nan", &SPHERE_OK.replace("[0.0, 0.0, 0.0]", "[nan, 0.0, 0.0]"), Some(4), "not a finite number");
    expect_scene_error("inf", &SPHERE_OK.replace("radius = 1.0", "radius = inf"), Some(5), "not a finite number");
    expect_scene_error("malformed", "[materials.m\ntype = 1\n", Some(1), "");
    expect_scene_error("spp-zero", &format!("[render]\nspp = 0\n{SPHERE_OK}"), Some(2), "at least 1");
    expect_scene_error("huge-width", &format!("[render]\nwidth = 100000\n{SPHERE_OK}"), Some(2), "between 1 and 16384");
    // Inside a material the value's own span is lost (serde buffers tagged enums): the line
    // is the material's header.
    expect_scene_error("roughness", &SPHERE_OK.replace("type = \"diffuse\"", "type = \"metal\"\nroughness = 1.5"), Some(1), "between 0 and 1");
    expect_scene_error("missing-obj", "[[meshes]]\nfile = \"nothere.obj\"\n", Some(2), "no such file");
    expect_scene_error(
        "missing-texture",
        "[materials.m]\ntype = \"diffuse\"\ntexture = \"nothere.png\"\n[[spheres]]\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nmaterial = \"m\"\n",
        Some(1),
        "no such file",
    );
    expect_scene_error("empty", "", None, "no geometry");
}

#[test]
fn render_flag_errors_exit_2_without_output() {
    let d = tmpdir("flags");
    let out = d.join("o.png");
    let scene = common::scene_path("spheres.toml");
    for args in [["--spp", "0"], ["--width", "0"], ["--height", "-3"], ["--accel", "octree"]] {
        let mut all = vec!["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap()];
        all.extend(args);
        let o = ember(&all);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains("error"), "{args:?}");
        assert!(!out.exists());
    }
}

#[test]
fn unwritable_output_folder() {
    let o = ember(&["render", common::scene_path("spheres.toml").to_str().unwrap(), "-o", "/nonexistent/dir/out.png", "--width", "8", "--height", "8", "--spp", "1"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("/nonexistent/dir/out.png: cannot write"), "{}", stderr(&o));
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

#[test]
fn check_runs_cases_and_prints_a_table() {
    let o = ember(&["check", "--quick", "grazing-plane", "inside-sphere"]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert_eq!(o.status.code(), Some(0), "{out}{}", stderr(&o));
    let lines: Vec<&str> = out.lines().collect();
    assert!(lines[1].starts_with("case") && lines[1].contains("result") && lines[1].contains("non-finite"), "{out}");
    for name in ["grazing-plane", "inside-sphere"] {
        let row = lines.iter().find(|l| l.starts_with(name)).unwrap_or_else(|| panic!("no row for {name}: {out}"));
        assert!(row.split_whitespace().nth(1) == Some("pass"), "{row}");
    }
    assert!(lines.last().unwrap().starts_with("2 cases, 2 passed, 0 failed"), "{out}");
}

#[test]
fn check_lists_cases_and_refuses_unknown_ones() {
    let o = ember(&["check", "--list"]);
    assert!(o.status.success());
    let out = String::from_utf8_lossy(&o.stdout);
    assert_eq!(out.lines().count(), ember::check::catalog().len(), "{out}");
    assert!(out.contains("self-intersection"), "{out}");
    let o = ember(&["check", "no-such-case"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).starts_with("error: unknown case \"no-such-case\""), "{}", stderr(&o));
}

/// A 4 × 4 emitter of radiance 3e38 half a unit above a floor: next-event estimation
/// overflows f32 (samples become infinite) and so do pixel sums.
const OVERFLOW: &str = "[camera]\nposition = [0.0, 0.3, 3.0]\nlook_at = [0.0, 0.0, 0.0]\n\
    [materials.floor]\ntype = \"diffuse\"\n[materials.hot]\ntype = \"emissive\"\nemission = [3.0e38, 3.0e38, 3.0e38]\n\
    [[quads]]\ncorner = [-2.0, 0.0, -2.0]\nedge1 = [0.0, 0.0, 4.0]\nedge2 = [4.0, 0.0, 0.0]\nmaterial = \"floor\"\n\
    [[quads]]\ncorner = [-2.0, 0.5, -2.0]\nedge1 = [4.0, 0.0, 0.0]\nedge2 = [0.0, 0.0, 4.0]\nmaterial = \"hot\"\n";

#[test]
fn strict_fails_on_non_finite_samples_and_writes_nothing() {
    let d = tmpdir("strict");
    let scene = write(&d, "hot.toml", OVERFLOW);
    let out = d.join("hot.png");
    let args = ["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--width", "16", "--height", "16", "--spp", "4"];
    // Without --strict: rendered, and the summary counts the dropped samples.
    let o = ember(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let summary = stderr(&o);
    let count: u64 = summary.split(" non-finite samples dropped").next().unwrap().rsplit(' ').next().unwrap().parse().unwrap();
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
    let o = ember(&["render", common::scene_path("spheres.toml").to_str().unwrap(), "-o", out.to_str().unwrap(), "--width", "16", "--height", "12", "--spp", "2", "--strict"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains(" 0 non-finite samples dropped"), "{}", stderr(&o));
}

#[test]
fn degenerate_triangles_are_skipped_with_a_warning() {
    let d = tmpdir("degenerate");
    let p = write(&d, "deg.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 2 2\nv nan 0 0\nf 1 2 3\nf 1 1 2\nf 1 4 5\nf 4 4 4\n");
    let o = ember(&["info", p.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(String::from_utf8_lossy(&o.stdout).contains("triangles:  1\n"), "{}", String::from_utf8_lossy(&o.stdout));
    let e = stderr(&o);
    assert!(e.starts_with(&format!("warning: {}: object", p.display())) && e.contains("skipped 3 degenerate triangle(s)"), "{e}");
    // Only degenerate triangles: an error, not an empty scene.
    let p = write(&d, "all.obj", "v 0 0 0\nv 1 1 1\nv 2 2 2\nf 1 2 3\n");
    let o = ember(&["info", p.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("no triangles"), "{}", stderr(&o));
}

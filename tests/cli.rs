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

//! Every error path of the command line. Each case checks the exit code (2), that the message
//! names the file (and the line where known) and the problem, and that no output file (nor a
//! temporary one) was created.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs `ember` with `env` set and `EMBER_MEMORY_LIMIT` otherwise unset.
fn ember_env(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_ember"));
    c.args(args).env_remove("EMBER_MEMORY_LIMIT");
    for (k, v) in env {
        c.env(k, v);
    }
    c.output().expect("ember runs")
}

fn ember(args: &[&str]) -> Output {
    ember_env(args, &[])
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A fresh, empty folder for one test case.
fn write(dir: &Path, name: &str, contents: impl AsRef<[u8]>) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, contents).unwrap();
    p
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// The names in `dir`, sorted.
fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> =
        std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    v.sort();
    v
}

/// `error: PATH: ` or `error: PATH:LINE: `.
fn at(path: &Path, line: Option<usize>) -> String {
    match line {
        Some(l) => format!("error: {}:{l}: ", path.display()),
        None => format!("error: {}: ", path.display()),
    }
}

/// Runs `ember render SCENE -o OUT ARGS…` (a tiny image unless `args` say otherwise) and checks
/// the failure: exit code 2, its `error: ` line starting with `prefix` and containing `needle`,
/// `out` not created and the folder it would be written to left as it was.
fn expect_render_error(scene: &Path, out: &Path, args: &[&str], env: &[(&str, &str)], prefix: &str, needle: &str) {
    let out_dir = out.parent().filter(|d| d.is_dir());
    let before = out_dir.map(listing);
    let mut all = vec!["render", s(scene), "-o", s(out)];
    all.extend(if args.is_empty() { &["--width", "8", "--height", "8", "--spp", "1"][..] } else { args });
    let o = ember_env(&all, env);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{all:?}: {e}");
    let line = e.lines().find(|l| l.starts_with("error: ")).unwrap_or("");
    assert!(line.starts_with(prefix), "{all:?}: expected prefix {prefix:?} in {e:?}");
    assert!(line.contains(needle), "{all:?}: expected {needle:?} in {e:?}");
    assert!(!out.is_file(), "{all:?}: an output file was written");
    if let (Some(d), Some(before)) = (out_dir, before) {
        assert_eq!(listing(d), before, "{all:?}: files appeared in the output folder");
    }
}

/// Writes `toml` as `scene.toml` in a fresh folder and expects `render` to fail at `line`
/// of it with `needle`.
fn expect_scene_error(name: &str, toml: &str, line: Option<usize>, needle: &str) {
    let d = common::fresh_dir("cli-errors", name);
    let scene = write(&d, "scene.toml", toml);
    expect_render_error(&scene, &d.join("out.png"), &[], &[], &at(&scene, line), needle);
}

const SPHERE_OK: &str =
    "[materials.m]\ntype = \"diffuse\"\n[[spheres]]\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nmaterial = \"m\"\n";
const TRIANGLE_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

#[test]
fn missing_file() {
    let d = common::fresh_dir("cli-errors", "missing");
    for name in ["no/such/file.toml", "no/such/file.obj", "no/such/file.dae"] {
        let p = PathBuf::from(name);
        expect_render_error(&p, &d.join("out.png"), &[], &[], &format!("error: {name}: "), "no such file");
        let o = ember(&["info", name]);
        assert_eq!(o.status.code(), Some(2));
        assert_eq!(stderr(&o).trim(), format!("error: {name}: no such file"));
    }
}

#[test]
fn unknown_scene_format() {
    let d = common::fresh_dir("cli-errors", "format");
    let p = write(&d, "scene.txt", SPHERE_OK);
    expect_render_error(
        &p,
        &d.join("out.png"),
        &[],
        &[],
        &at(&p, None),
        "unknown scene format (expected .toml or a mesh file: .obj, .ply, .gltf, .glb)",
    );
}

#[test]
fn unreadable_file() {
    use std::os::unix::fs::PermissionsExt;
    let d = common::fresh_dir("cli-errors", "unreadable");
    let out = d.join("out.png");

    // Permission bits: only meaningful without the privilege to read any file (root).
    let p = write(&d, "locked.toml", SPHERE_OK);
    std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o000)).unwrap();
    if std::fs::read(&p).is_ok() {
        eprintln!("skipped the chmod 000 case: this process can read a mode-000 file (running as root)");
    } else {
        expect_render_error(&p, &out, &[], &[], &at(&p, None), "permission denied");
    }
    std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o644)).unwrap();
    std::fs::remove_file(&p).unwrap();

    // A FIFO (would block a reader forever): refused whoever runs the test.
    let fifo = d.join("fifo.toml");
    let made = Command::new("mkfifo").arg(&fifo).status().expect("mkfifo runs");
    assert!(made.success());
    expect_render_error(&fifo, &out, &[], &[], &at(&fifo, None), "is not a regular file");
    let fifo_obj = d.join("fifo.obj");
    assert!(Command::new("mkfifo").arg(&fifo_obj).status().unwrap().success());
    expect_render_error(&fifo_obj, &out, &[], &[], &at(&fifo_obj, None), "is not a regular file");
    std::fs::remove_file(&fifo).unwrap();
    std::fs::remove_file(&fifo_obj).unwrap();

    // Bytes that are not text.
    let p = write(&d, "binary.toml", b"[render]\nspp = 1\n\xff\xfe\x00\n");
    expect_render_error(&p, &out, &[], &[], &at(&p, Some(3)), "is not UTF-8 text");
}

#[test]
fn directory_given_as_file() {
    let d = common::fresh_dir("cli-errors", "dir");
    let out = d.join("out.png");
    for name in ["folder.toml", "folder.obj"] {
        let p = d.join(name);
        std::fs::create_dir_all(&p).unwrap();
        expect_render_error(&p, &out, &[], &[], &at(&p, None), "is a directory, expected a file");
        let o = ember(&["info", s(&p)]);
        assert_eq!(o.status.code(), Some(2));
        assert_eq!(stderr(&o).trim(), format!("{}is a directory, expected a file", at(&p, None)));
    }
    // Files a scene names: the scene's line that names them.
    let mesh_dir = d.join("folder.obj");
    let scene = write(&d, "mesh.toml", "[[meshes]]\nfile = \"folder.obj\"\n");
    expect_render_error(
        &scene,
        &out,
        &[],
        &[],
        &at(&scene, Some(2)),
        &format!("mesh {}: is a directory", mesh_dir.display()),
    );
    std::fs::create_dir_all(d.join("tex.png")).unwrap();
    let scene =
        write(&d, "tex.toml", SPHERE_OK.replace("type = \"diffuse\"", "type = \"diffuse\"\ntexture = \"tex.png\""));
    expect_render_error(&scene, &out, &[], &[], &at(&scene, Some(1)), "tex.png: is a directory");
}

#[test]
fn malformed_obj_line() {
    let d = common::fresh_dir("cli-errors", "malformed-obj");
    let out = d.join("out.png");
    for (text, line, needle) in [
        ("# a triangle\nv 0 0 0\nv 1 0 0\nv 0 1 zero\nf 1 2 3\n", 4, "vertex position: \"zero\" is not a number"),
        ("v 0 0 0\nv 1 0\n", 2, "vertex position needs 3, 4 or 6 numbers, found 2"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0\n", 4, "vertex normal needs 3 numbers, found 2"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2\n", 4, "a face needs at least 3 vertices, found 2"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n", 4, "face vertex \"x\": \"x\" is not an index"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1/1/1 2 3\n", 4, "face vertex \"1/1/1/1\" is malformed"),
    ] {
        let p = write(&d, "bad.obj", text);
        expect_render_error(&p, &out, &[], &[], &at(&p, Some(line)), needle);
        let o = ember(&["info", s(&p)]);
        assert_eq!(o.status.code(), Some(2));
        assert!(stderr(&o).starts_with(&at(&p, Some(line))), "{}", stderr(&o));
    }
    // Through a scene file, the message names the OBJ file and its line.
    let obj = write(&d, "bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 zero\nf 1 2 3\n");
    let scene = write(&d, "scene.toml", "[[meshes]]\nfile = \"bad.obj\"\n");
    expect_render_error(&scene, &out, &[], &[], &at(&obj, Some(3)), "\"zero\" is not a number");
    // No faces at all.
    let p = write(&d, "empty.obj", "v 0 0 0\n");
    expect_render_error(&p, &out, &[], &[], &at(&p, None), "no triangles: the file has no faces");
}

#[test]
fn face_index_out_of_range() {
    let d = common::fresh_dir("cli-errors", "range");
    let out = d.join("out.png");
    for (text, line, needle) in [
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 7\n",
            5,
            "face vertex index 7 is out of range (1 to 3 defined so far)",
        ),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n", 4, "face vertex index 0 is out of range"),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 -2 -1\n", 4, "face vertex index -4 is out of range"),
        // Indices refer to vertices defined above the face.
        ("v 0 0 0\nv 1 0 0\nf 1 2 3\nv 0 1 0\n", 3, "face vertex index 3 is out of range (1 to 2 defined so far)"),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/2 3/1\n",
            5,
            "face texture coordinate index 2 is out of range (1 to 1 defined so far)",
        ),
        ("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//9\n", 5, "face normal index 9 is out of range"),
    ] {
        let p = write(&d, "range.obj", text);
        expect_render_error(&p, &out, &[], &[], &at(&p, Some(line)), needle);
    }
}

#[test]
fn malformed_toml() {
    expect_scene_error("unclosed", "[materials.m\ntype = 1\n", Some(1), "unclosed table, expected `]`");
    expect_scene_error(
        "unquoted",
        &format!("{SPHERE_OK}[render]\nseed = banana\n"),
        Some(8),
        "string values must be quoted",
    );
    expect_scene_error("duplicate", &format!("[render]\nspp = 1\nspp = 2\n{SPHERE_OK}"), Some(3), "duplicate key");
    expect_scene_error(
        "type",
        &format!("[render]\nspp = \"many\"\n{SPHERE_OK}"),
        Some(2),
        "invalid type: string \"many\"",
    );
    expect_scene_error(
        "vector",
        &SPHERE_OK.replace("[0.0, 0.0, 0.0]", "[0.0, 0.0]"),
        Some(4),
        "expected 3 numbers, found 2",
    );
    expect_scene_error("empty", "", None, "the scene has no geometry");
}

#[test]
fn unknown_key() {
    expect_scene_error("top", &format!("{SPHERE_OK}colour = 3\n"), Some(7), "unknown field `colour`");
    expect_scene_error("render", &format!("[render]\nsamples = 4\n{SPHERE_OK}"), Some(2), "unknown field `samples`");
    expect_scene_error(
        "sphere",
        &SPHERE_OK.replace("radius = 1.0", "radius = 1.0\nradios = 2.0"),
        Some(6),
        "unknown field `radios`",
    );
    expect_scene_error("variant", &SPHERE_OK.replace("\"diffuse\"", "\"velvet\""), Some(2), "unknown variant `velvet`");
    expect_scene_error(
        "material",
        &SPHERE_OK.replace("material = \"m\"", "material = \"steel\""),
        Some(6),
        "unknown material \"steel\" (defined: m)",
    );
}

#[test]
fn out_of_range_values() {
    expect_scene_error(
        "negative-radius",
        &SPHERE_OK.replace("radius = 1.0", "radius = -2.0"),
        Some(5),
        "must be greater than 0, found -2",
    );
    expect_scene_error(
        "zero-radius",
        &SPHERE_OK.replace("radius = 1.0", "radius = 0.0"),
        Some(5),
        "must be greater than 0, found 0",
    );
    expect_scene_error("spp-zero", &format!("[render]\nspp = 0\n{SPHERE_OK}"), Some(2), "must be at least 1, found 0");
    expect_scene_error(
        "huge-width",
        &format!("[render]\nwidth = 100000\n{SPHERE_OK}"),
        Some(2),
        "must be between 1 and 16384, found 100000",
    );
    expect_scene_error(
        "filter",
        &format!("[render]\nfilter = \"tent\"\n{SPHERE_OK}"),
        Some(2),
        "unknown pixel filter \"tent\" (expected box or gaussian)",
    );
    expect_scene_error(
        "tonemap",
        &format!("[render]\ntonemap = \"filmic\"\n{SPHERE_OK}"),
        Some(2),
        "unknown tone curve \"filmic\" (expected clamp, aces or neutral)",
    );
    expect_scene_error(
        "exposure",
        &format!("[render]\nexposure = -70.0\n{SPHERE_OK}"),
        Some(2),
        "exposure must be a number of stops between -64 and 64, found -70",
    );
    expect_scene_error(
        "negative-depth",
        &format!("[render]\nmax_depth = -1\n{SPHERE_OK}"),
        Some(2),
        "invalid value: integer `-1`",
    );
    expect_scene_error(
        "colour",
        &SPHERE_OK.replace("type = \"diffuse\"", "type = \"diffuse\"\ncolor = [0.5, -0.1, 0.5]"),
        Some(1),
        "colour components must not be negative",
    );
    // Inside a material the value's own span is lost (serde buffers tagged enums): the line
    // is the material's header.
    expect_scene_error(
        "roughness",
        &SPHERE_OK.replace("type = \"diffuse\"", "type = \"metal\"\nroughness = 1.5"),
        Some(1),
        "must be between 0 and 1, found 1.5",
    );
    expect_scene_error(
        "fov",
        &format!("[camera]\nposition = [0.0, 0.0, 5.0]\nlook_at = [0.0, 0.0, 0.0]\nfov = 180\n{SPHERE_OK}"),
        Some(4),
        "fov must be below 180 degrees, found 180",
    );
    expect_scene_error(
        "aperture",
        &format!("[camera]\nposition = [0.0, 0.0, 5.0]\nlook_at = [0.0, 0.0, 0.0]\naperture = -1.0\n{SPHERE_OK}"),
        Some(4),
        "camera aperture must not be negative",
    );
    expect_scene_error(
        "look-at",
        &format!("[camera]\nposition = [1.0, 2.0, 3.0]\nlook_at = [1.0, 2.0, 3.0]\n{SPHERE_OK}"),
        Some(2),
        "camera position and look_at are the same point",
    );
    let ortho = "[camera]\ntype = \"orthographic\"\nposition = [0.0, 0.0, 5.0]\nlook_at = [0.0, 0.0, 0.0]\n";
    for (name, text, line, needle) in [
        ("ortho-width", format!("{ortho}{SPHERE_OK}"), 2, "an orthographic camera needs `width`"),
        ("ortho-fov", format!("{ortho}width = 2.0\nfov = 30\n{SPHERE_OK}"), 6, "an orthographic camera has no fov"),
        (
            "ortho-aperture",
            format!("{ortho}width = 2.0\naperture = 0.1\n{SPHERE_OK}"),
            6,
            "an orthographic camera has no aperture",
        ),
        (
            "width-perspective",
            format!("[camera]\nposition = [0.0, 0.0, 5.0]\nlook_at = [0.0, 0.0, 0.0]\nwidth = 2.0\n{SPHERE_OK}"),
            4,
            "`width` is an orthographic camera's",
        ),
        (
            "camera-type",
            format!("[camera]\ntype = \"fisheye\"\nposition = [0.0, 0.0, 5.0]\nlook_at = [0.0, 0.0, 0.0]\n{SPHERE_OK}"),
            2,
            "unknown camera type \"fisheye\" (expected \"perspective\" or \"orthographic\")",
        ),
    ] {
        expect_scene_error(name, &text, Some(line), needle);
    }
    expect_scene_error(
        "quad",
        "[materials.m]\ntype = \"diffuse\"\n[[quads]]\ncorner = [0.0, 0.0, 0.0]\nedge1 = [1.0, 0.0, 0.0]\nedge2 = [2.0, 0.0, 0.0]\nmaterial = \"m\"\n",
        Some(7),
        "quad edges are parallel or zero: the quad has no area",
    );
    expect_scene_error(
        "cylinder",
        "[materials.m]\ntype = \"diffuse\"\n[[cylinders]]\np0 = [0.0, 1.0, 0.0]\np1 = [0.0, 1.0, 0.0]\nradius = 1.0\nmaterial = \"m\"\n",
        Some(7),
        "cylinder p0 and p1 are the same point",
    );
    let d = common::fresh_dir("cli-errors", "scale");
    write(&d, "t.obj", TRIANGLE_OBJ);
    let scene = write(&d, "scene.toml", "[[meshes]]\nfile = \"t.obj\"\nscale = 0.0\n");
    expect_render_error(&scene, &d.join("out.png"), &[], &[], &at(&scene, Some(3)), "scale must not be 0");
}

#[test]
fn nan_and_inf_values() {
    expect_scene_error(
        "nan",
        &SPHERE_OK.replace("[0.0, 0.0, 0.0]", "[nan, 0.0, 0.0]"),
        Some(4),
        "NaN is not a finite number",
    );
    expect_scene_error(
        "inf",
        &SPHERE_OK.replace("radius = 1.0", "radius = inf"),
        Some(5),
        "inf is not a finite number",
    );
    expect_scene_error(
        "neg-inf",
        &SPHERE_OK.replace("[0.0, 0.0, 0.0]", "[0.0, -inf, 0.0]"),
        Some(4),
        "-inf is not a finite number",
    );
    expect_scene_error(
        "overflow",
        &SPHERE_OK.replace("radius = 1.0", "radius = 1e39"),
        Some(5),
        "is not a finite number",
    );
    let d = common::fresh_dir("cli-errors", "nan-obj");
    let out = d.join("out.png");
    for (text, line, needle) in [
        // (A non-finite vertex *position* is not an error: its triangles are skipped with a
        // warning, tests/cli.rs degenerate_triangles_are_skipped_with_a_warning.)
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 inf\nf 1/1 2/1 3/1\n",
            4,
            "texture coordinate: \"inf\" is not a finite number",
        ),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 1e39\nf 1/1 2/1 3/1\n",
            4,
            "texture coordinate: \"1e39\" is not a finite number",
        ),
        (
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 NaN\nf 1//1 2//1 3//1\n",
            4,
            "vertex normal: \"NaN\" is not a finite number",
        ),
    ] {
        let p = write(&d, "nan.obj", text);
        expect_render_error(&p, &out, &[], &[], &at(&p, Some(line)), needle);
    }
}

#[test]
fn unwritable_output_path() {
    use std::os::unix::fs::PermissionsExt;
    let scene = common::scene_path("spheres.toml");
    let d = common::fresh_dir("cli-errors", "unwritable");
    let cases = [
        (PathBuf::from("/nonexistent/dir/out.png"), "cannot write: folder /nonexistent/dir does not exist"),
        (write(&d, "file.txt", "x").join("out.png"), "is not a folder"),
    ];
    for (out, needle) in cases {
        expect_render_error(&scene, &out, &[], &[], &at(&out, None), needle);
    }
    // An existing folder where the image should go.
    let out = d.join("folder.png");
    std::fs::create_dir_all(&out).unwrap();
    let o = ember(&["render", s(&scene), "-o", s(&out), "--width", "8", "--height", "8", "--spp", "1"]);
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(stderr(&o).trim(), format!("{}cannot write: is a directory", at(&out, None)));
    assert!(out.is_dir() && listing(&out).is_empty());
    // A folder nobody may create files in: /sys refuses even root.
    if Path::new("/sys").is_dir() {
        expect_render_error(
            &scene,
            Path::new("/sys/out.png"),
            &[],
            &[],
            "error: /sys/out.png: cannot write: ",
            "ermission denied",
        );
    } else {
        eprintln!("skipped the /sys case: no /sys folder");
    }
    // A read-only folder (mode 555): only meaningful without root's privileges.
    let ro = d.join("readonly");
    std::fs::create_dir_all(&ro).unwrap();
    std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o555)).unwrap();
    let probe = ro.join("probe");
    if std::fs::write(&probe, "x").is_ok() {
        std::fs::remove_file(&probe).unwrap();
        eprintln!("skipped the mode-555 folder case: this process can write there (running as root)");
    } else {
        expect_render_error(&scene, &ro.join("out.png"), &[], &[], &at(&ro.join("out.png"), None), "ermission denied");
    }
    std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o755)).unwrap();
}

#[test]
fn unsupported_output_extension() {
    let scene = common::scene_path("teapot.obj");
    let d = common::fresh_dir("cli-errors", "ext");
    for name in ["out.bmp", "out", "out.png.txt"] {
        let out = d.join(name);
        expect_render_error(&scene, &out, &[], &[], &at(&out, None), "unsupported output format (use .png or .exr)");
    }
}

#[test]
fn texture_errors() {
    let d = common::fresh_dir("cli-errors", "texture");
    let out = d.join("out.png");
    let textured =
        |file: &str| SPHERE_OK.replace("type = \"diffuse\"", &format!("type = \"diffuse\"\ntexture = \"{file}\""));
    let scene = write(&d, "missing.toml", textured("nothere.png"));
    expect_render_error(
        &scene,
        &out,
        &[],
        &[],
        &at(&scene, Some(1)),
        &format!("texture {}: no such file", d.join("nothere.png").display()),
    );
    write(&d, "fake.png", "this is not a PNG");
    let scene = write(&d, "corrupt.toml", textured("fake.png"));
    expect_render_error(
        &scene,
        &out,
        &[],
        &[],
        &at(&scene, Some(1)),
        &format!("texture {}: ", d.join("fake.png").display()),
    );
    let scene =
        write(&d, "background.toml", format!("[background]\ntype = \"image\"\nfile = \"nothere.jpg\"\n{SPHERE_OK}"));
    expect_render_error(&scene, &out, &[], &[], &at(&scene, Some(1)), "nothere.jpg: no such file");
    // Truncated files are errors, not partly grey textures: a JPEG cut in half (the decoder
    // alone would fill the rest with grey) and a PNG cut short.
    let jpeg = std::fs::read(common::scene_path("earthmap.jpg")).unwrap();
    std::fs::write(d.join("cut.jpg"), &jpeg[..jpeg.len() / 2]).unwrap();
    let scene = write(&d, "cut-jpeg.toml", textured("cut.jpg"));
    let needle = format!(
        "texture {}: truncated or damaged JPEG: the file ends inside the compressed data",
        d.join("cut.jpg").display()
    );
    expect_render_error(&scene, &out, &[], &[], &at(&scene, Some(1)), &needle);
    let png_out = d.join("whole.png");
    let o = ember(&[
        "render",
        s(&common::scene_path("spheres.toml")),
        "-o",
        s(&png_out),
        "--width",
        "64",
        "--height",
        "48",
        "--spp",
        "1",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let png = std::fs::read(&png_out).unwrap();
    std::fs::remove_file(&png_out).unwrap();
    std::fs::write(d.join("cut.png"), &png[..png.len() * 2 / 3]).unwrap();
    let scene = write(&d, "cut-png.toml", textured("cut.png"));
    expect_render_error(
        &scene,
        &out,
        &[],
        &[],
        &at(&scene, Some(1)),
        &format!("texture {}: ", d.join("cut.png").display()),
    );
}

#[test]
fn strict_refuses_a_scene_without_light() {
    let d = common::fresh_dir("cli-errors", "dark");
    let scene = write(&d, "dark.toml", SPHERE_OK);
    let out = d.join("out.png");
    let needle = "nothing in the scene emits light: the image will be black; add a light, an emissive material or a \
                  [background]; --strict refuses a black image, so";
    expect_render_error(&scene, &out, &["--strict", "--spp", "1"], &[], &at(&scene, None), needle);
}

#[test]
fn missing_mesh_file() {
    expect_scene_error("missing-obj", "[[meshes]]\nfile = \"nothere.obj\"\n", Some(2), "nothere.obj: no such file");
}

#[test]
fn bad_flags() {
    let d = common::fresh_dir("cli-errors", "flags");
    let out = d.join("o.png");
    let scene = common::scene_path("spheres.toml");
    for (args, needle) in [
        (&["--spp", "0"][..], "--spp"),
        (&["--width", "0"], "--width"),
        (&["--width", "20000"], "--width"),
        (&["--height", "-3"], "unexpected argument '-3'"),
        (&["--threads", "0"], "--threads"),
        (&["--accel", "octree"], "--accel"),
        (&["--estimator", "magic"], "--estimator"),
        (&["--bvh-quality", "best"], "unknown BVH quality \"best\" (expected low, medium or high)"),
        (&["--rr-depth", "banana"], "--rr-depth: expected a number, \"off\" or \"auto\", found \"banana\""),
        (&["--seed", "x"], "--seed"),
        (&["--fov", "0"], "expected a field of view in degrees between 0 and 180 (exclusive), found \"0\""),
        (&["--fov", "180"], "between 0 and 180 (exclusive), found \"180\""),
        (&["--camera-position", "1,2"], "expected three finite numbers x,y,z (e.g. 0,1.5,-4), found \"1,2\""),
        (&["--up", "0,nan,1"], "expected three finite numbers x,y,z"),
        (&["--look-at", "-1e16,0,0"], "coordinates must be between -1e15 and 1e15, found -1e16"),
        (&["--filter", "tent"], "unknown pixel filter \"tent\" (expected box or gaussian)"),
        (&["--tonemap", "filmic"], "unknown tone curve \"filmic\" (expected clamp, aces or neutral)"),
        (&["--exposure", "100"], "exposure must be a number of stops between -64 and 64, found 100"),
        (&["--exposure", "bright"], "expected a number of stops (e.g. 1.5 or -2), found \"bright\""),
        (&["--orbit", "30"], "expected AZIMUTH,ELEVATION[,DISTANCE] in degrees"),
        (&["--orbit", "30,100"], "the elevation must be between -90 and 90 degrees, found 100"),
        (&["--orbit", "30,10", "--camera-position", "1,2,3"], "cannot be used with"),
        (&["--ortho", "0"], "expected the view's width in world units, a positive number, found \"0\""),
        (&["--ortho", "2", "--fov", "30"], "cannot be used with"),
        (&["--clamp", "0"], "expected a positive radiance (e.g. 10), found \"0\""),
        (&["--preview-every", "0s"], "must be positive"),
        (&["--preview-every", "1s", "--shard", "0/2"], "cannot be used with"),
    ] {
        expect_render_error(&scene, &out, args, &[], "error: ", needle);
    }
    // Each part is valid, but the camera would look at itself: from the scene's look_at, or
    // from both given.
    for args in [&["--camera-position", "0,1,0"][..], &["--vp", "1,1,1", "--vi", "1,1,1"]] {
        let needle = "the camera position and the point it looks at are the same point";
        expect_render_error(&scene, &out, args, &[], &at(&scene, None), needle);
    }
}

#[test]
fn memory_limits() {
    let d = common::fresh_dir("cli-errors", "memory");
    let out = d.join("out.png");
    let scene = write(&d, "scene.toml", SPHERE_OK);
    // The film.
    expect_render_error(
        &scene,
        &out,
        &["--width", "16384", "--height", "16384"],
        &[("EMBER_MEMORY_LIMIT", "2G")],
        &at(&scene, None),
        "image 16384x16384 needs ~31.1 GB of film memory, more than the 2.0 GB limit (set by EMBER_MEMORY_LIMIT)",
    );
    // A mesh, refused while loading (before tobj allocates anything).
    let teapot = common::scene_path("teapot.obj");
    expect_render_error(
        &teapot,
        &out,
        &[],
        &[("EMBER_MEMORY_LIMIT", "1M")],
        &at(&teapot, None),
        "mesh of 3644 vertices and 6320 triangles needs ~1.5 MB to load, with the 7.4 kB already loaded, more than \
         the 1.0 MB limit",
    );
    let o = ember_env(&["info", s(&teapot)], &[("EMBER_MEMORY_LIMIT", "1M")]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("needs ~1.5 MB to load"), "{}", stderr(&o));
    // A texture, refused from its header before decoding.
    std::fs::copy(common::scene_path("earthmap.jpg"), d.join("earth.jpg")).unwrap();
    let textured = write(
        &d,
        "textured.toml",
        SPHERE_OK.replace("type = \"diffuse\"", "type = \"diffuse\"\ntexture = \"earth.jpg\""),
    );
    expect_render_error(
        &textured,
        &out,
        &[],
        &[("EMBER_MEMORY_LIMIT", "10M")],
        &at(&textured, Some(1)),
        "1024x512 image needs ~12.2 MB to load, with the 7.6 kB already loaded, more than the 10.0 MB limit",
    );
    // The scene file itself: parsing 2,000 spheres' TOML takes ~48 bytes per byte of it.
    let mut many = String::from("[materials.m]\ntype = \"diffuse\"\n");
    for i in 0..2000 {
        many += &format!("[[spheres]]\ncenter = [{}.0, 0.0, 0.0]\nradius = 0.4\nmaterial = \"m\"\n", i);
    }
    let many = write(&d, "many.toml", many);
    expect_render_error(
        &many,
        &out,
        &["--width", "16", "--height", "16"],
        &[("EMBER_MEMORY_LIMIT", "300k")],
        &at(&many, None),
        "scene file of 134.9 kB needs ~6.5 MB to load, more than the 300.0 kB limit",
    );
    // An unreadable limit.
    expect_render_error(
        &scene,
        &out,
        &[],
        &[("EMBER_MEMORY_LIMIT", "lots")],
        "error: EMBER_MEMORY_LIMIT=\"lots\": ",
        "not a size",
    );
    // The same scenes render under a sufficient limit.
    let o = ember_env(
        &["render", s(&many), "-o", s(&out), "--width", "8", "--height", "8", "--spp", "1"],
        &[("EMBER_MEMORY_LIMIT", "7M")],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(out.is_file());
}

#[test]
fn mtl_problems_are_located_errors() {
    let d = common::fresh_dir("cli-errors", "mtl");
    let mtl = d.join("m.mtl");
    let obj = write(&d, "t.obj", format!("mtllib m.mtl\nusemtl red\n{TRIANGLE_OBJ}"));
    for (text, needle) in [
        ("newmtl red\nKd 1 0\n", "Kd needs 3 numbers, found 2"),
        ("newmtl red\nKd nan inf -1\n", "Kd: \"nan\" is not a finite number"),
        ("newmtl red\nKd 0.5 0.5 -1\n", "Kd: \"-1\" is negative"),
    ] {
        std::fs::write(&mtl, text).unwrap();
        expect_render_error(&obj, &d.join("out.png"), &[], &[], &at(&mtl, Some(2)), needle);
    }
    // A library that is missing is a warning: the meshes get the default material.
    std::fs::remove_file(&mtl).unwrap();
    let out = d.join("out.png");
    let o = ember(&["render", s(&obj), "-o", s(&out), "--width", "8", "--height", "8", "--spp", "1"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(e.contains(&format!("warning: {}: no such file; using default materials", mtl.display())), "{e}");
    assert!(out.is_file());
}

#[test]
fn progressive_render_flags() {
    let d = common::fresh_dir("cli-errors", "progressive");
    let out = d.join("out.png");
    let scene = write(&d, "scene.toml", SPHERE_OK);
    for (args, needle) in [
        (
            &["--target-error", "0"][..],
            "invalid value '0' for '--target-error <TARGET_ERROR>': expected a relative error between 0 and 1",
        ),
        (&["--target-error", "1.5"], "expected a relative error between 0 and 1 (e.g. 0.01), found \"1.5\""),
        (&["--target-error", "small"], "found \"small\""),
        (&["--checkpoint-every", "5x"], "unknown unit \"x\" in \"5x\" (use s, m or h)"),
        (&["--checkpoint-every", "0s"], "duration \"0s\" must be positive"),
        // The unit is the letters at the end: 1e-12s is seconds, too few of them.
        (&["--checkpoint-every", "1e-12s"], "duration \"1e-12s\" is too short: at least 0.001s"),
        (&["--checkpoint-every", "1.2.3s"], "expected a duration such as 60s or 5m, found \"1.2.3s\""),
    ] {
        expect_render_error(&scene, &out, args, &[], "error: ", needle);
    }
}

#[test]
fn damaged_checkpoint() {
    let d = common::fresh_dir("cli-errors", "checkpoint");
    let out = d.join("out.png");
    let scene = write(&d, "scene.toml", SPHERE_OK);
    let ckpt = d.join("out.png.checkpoint");
    let args = ["--resume", "--width", "8", "--height", "8", "--spp", "1"];
    std::fs::write(&ckpt, "not a checkpoint").unwrap();
    expect_render_error(&scene, &out, &args, &[], &at(&ckpt, None), "not a valid ember checkpoint (wrong header)");
    let mut truncated = b"EMBERCK\x01".to_vec();
    truncated.extend_from_slice(&[7; 20]);
    std::fs::write(&ckpt, truncated).unwrap();
    expect_render_error(
        &scene,
        &out,
        &args,
        &[],
        &at(&ckpt, None),
        "not a valid ember checkpoint (28 bytes, where a checkpoint of this render has ",
    );
    // The right size, one bit flipped.
    let key = common::cli_checkpoint_key(&scene, 8, 8, 1, 0);
    let accum = ember::film::Accumulator::new(8, 8);
    let c = ember::film::Checkpoint {
        scene: key.scene,
        settings: key.settings,
        nonfinite: 0,
        elapsed: Default::default(),
        accum,
    };
    let mut bytes = c.to_bytes();
    // In the pixels (most of the file), not in the header, settings or sizes, whose length
    // grows with the settings' words.
    let middle = bytes.len() / 2;
    bytes[middle] ^= 1;
    std::fs::write(&ckpt, bytes).unwrap();
    expect_render_error(
        &scene,
        &out,
        &args,
        &[],
        &at(&ckpt, None),
        "not a valid ember checkpoint (checksum mismatch: truncated or damaged)",
    );
    std::fs::remove_file(&ckpt).unwrap();
    expect_render_error(&scene, &out, &args, &[], &at(&ckpt, None), "no checkpoint to resume from");
}

#[test]
fn converge_errors() {
    let d = common::fresh_dir("cli-errors", "converge");
    let file = write(&d, "taken", "a file, not a folder");
    let scene = write(&d, "scene.toml", SPHERE_OK);
    let o = ember(&[
        "converge",
        s(&scene),
        "--out",
        s(&file),
        "--width",
        "4",
        "--height",
        "4",
        "--max-spp",
        "1",
        "--variants",
        "nee-mis",
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).starts_with(&format!("{}cannot create folder", at(&file, None))), "{}", stderr(&o));
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "a file, not a folder");
    let bad = write(&d, "bad.toml", "[materials.m\n");
    let out = d.join("study");
    let o = ember(&["converge", s(&bad), "--out", s(&out)]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).starts_with(&format!("{}unclosed table", at(&bad, Some(1)))), "{}", stderr(&o));
    assert!(!out.exists());
}

#[test]
fn output_that_the_scene_reads() {
    let d = common::fresh_dir("cli-errors", "input-output");
    let png = |name: &str| {
        let p = d.join(name);
        let mut bytes = std::io::Cursor::new(Vec::new());
        image::RgbImage::from_pixel(2, 2, image::Rgb([200, 100, 50]))
            .write_to(&mut bytes, image::ImageFormat::Png)
            .unwrap();
        std::fs::write(&p, bytes.into_inner()).unwrap();
        p
    };
    let tex = png("tex.png");
    let env = png("env.png");
    // Files that a render of o.png would write beside it (image formats go by content).
    let ckpt_named = png("o.png.checkpoint");
    let lock_named = png("o.png.lock");
    std::os::unix::fs::symlink(&tex, d.join("link.png")).unwrap();
    std::fs::create_dir(d.join("sub")).unwrap();
    let textured =
        |file: &str| SPHERE_OK.replace("type = \"diffuse\"", &format!("type = \"diffuse\"\ntexture = \"{file}\""));
    let scene =
        write(&d, "scene.toml", format!("[background]\ntype = \"image\"\nfile = \"env.png\"\n{}", textured("tex.png")));
    let ckpt_scene = write(&d, "ckpt.toml", textured("o.png.checkpoint"));
    let lock_scene = write(&d, "lock.toml", textured("o.png.lock"));
    for (scene, out, what, input) in [
        (&scene, d.join("tex.png"), "the image", &tex),
        (&scene, d.join("link.png"), "the image", &tex),
        (&scene, d.join("sub/../tex.png"), "the image", &tex),
        (&scene, d.join("env.png"), "the image", &env),
        (&ckpt_scene, d.join("o.png"), "the checkpoint", &ckpt_named),
        (&lock_scene, d.join("o.png"), "the lock file", &lock_named),
    ] {
        let before: Vec<(String, Vec<u8>)> =
            listing(&d).into_iter().map(|n| (n.clone(), std::fs::read(d.join(&n)).unwrap_or_default())).collect();
        let o = ember(&["render", s(scene), "-o", s(&out), "--width", "8", "--height", "8", "--spp", "1"]);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{}: {e}", out.display());
        let written = match what {
            "the image" => out.clone(),
            "the checkpoint" => ember::film::checkpoint_path(&out),
            _ => ember::output_lock::lock_path(&out),
        };
        assert_eq!(
            e.trim(),
            format!(
                "error: {}: the scene reads this file ({}); writing {what} of the render there would destroy it: \
                 choose another output",
                written.display(),
                input.display()
            )
        );
        let after: Vec<(String, Vec<u8>)> =
            listing(&d).into_iter().map(|n| (n.clone(), std::fs::read(d.join(&n)).unwrap_or_default())).collect();
        assert_eq!(after, before, "{}: files changed", out.display());
    }
    // Another name is fine.
    let o =
        ember(&["render", s(&scene), "-o", s(&d.join("render.png")), "--width", "8", "--height", "8", "--spp", "1"]);
    assert!(o.status.success(), "{}", stderr(&o));
}

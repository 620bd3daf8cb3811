//! No finite scene value reaches Embree in a form it asserts on (Embree aborts the process on a
//! ray beyond ~1.8e18): coordinates and lengths beyond ±1e15 are refused at load with the file,
//! line and allowed range, and everything within renders. A sweep of magnitudes 1e3 … 1e38,
//! and their negatives, over every place a scene gives a position or a length: every run exits
//! 0 or 2, nothing else.

mod common;

use std::path::Path;
use std::process::Command;

const LIMIT: f64 = 1e15;
const MAGNITUDES: [f64; 11] = [1e3, 1e6, 1e9, 1e12, 1e15, 1.5e15, 1e16, 1e19, 1e25, 1e30, 1e38];

const MATERIAL: &str = "[materials.m]\ntype = \"diffuse\"\n";
const LIGHT: &str = "[[lights]]\ntype = \"point\"\nposition = [0.0, 5.0, 5.0]\nintensity = [50.0, 50.0, 50.0]\n";
const SPHERE: &str = "[[spheres]]\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nmaterial = \"m\"\n";

/// A scene file with `v` at one place; whether a value of that place may be negative.
struct Place {
    name: &'static str,
    scene: fn(String) -> String,
    negative_ok: bool,
}

fn camera(position: &str, look_at: &str, extra: &str) -> String {
    format!("[camera]\nposition = {position}\nlook_at = {look_at}\n{extra}")
}

const PLACES: [Place; 12] = [
    Place {
        name: "camera position",
        scene: |v| format!("{}{MATERIAL}{LIGHT}{SPHERE}", camera(&format!("[{v}, 0.0, 5.0]"), "[0.0, 0.0, 0.0]", "")),
        negative_ok: true,
    },
    Place {
        name: "camera look_at",
        scene: |v| format!("{}{MATERIAL}{LIGHT}{SPHERE}", camera("[0.0, 0.0, 5.0]", &format!("[{v}, 0.0, 0.0]"), "")),
        negative_ok: true,
    },
    Place {
        name: "aperture",
        scene: |v| {
            let extra = format!("aperture = {v}\n");
            format!("{}{MATERIAL}{LIGHT}{SPHERE}", camera("[0.0, 0.0, 5.0]", "[0.0, 0.0, 0.0]", &extra))
        },
        negative_ok: false,
    },
    Place {
        name: "focus distance",
        scene: |v| {
            let extra = format!("aperture = 0.1\nfocus_distance = {v}\n");
            format!("{}{MATERIAL}{LIGHT}{SPHERE}", camera("[0.0, 0.0, 5.0]", "[0.0, 0.0, 0.0]", &extra))
        },
        negative_ok: false,
    },
    Place {
        name: "sphere center",
        scene: |v| {
            format!("{MATERIAL}{LIGHT}{SPHERE}[[spheres]]\ncenter = [{v}, 1.0, 0.0]\nradius = 1.0\nmaterial = \"m\"\n")
        },
        negative_ok: true,
    },
    Place {
        name: "sphere radius",
        scene: |v| format!("{MATERIAL}{LIGHT}[[spheres]]\ncenter = [0.0, 0.0, 0.0]\nradius = {v}\nmaterial = \"m\"\n"),
        negative_ok: false,
    },
    Place {
        name: "cylinder end",
        scene: |v| {
            format!(
                "{MATERIAL}{LIGHT}{SPHERE}[[cylinders]]\np0 = [0.0, 0.0, 0.0]\np1 = [{v}, 1.0, 0.0]\nradius = 0.5\nmaterial = \"m\"\n"
            )
        },
        negative_ok: true,
    },
    Place {
        name: "cylinder radius",
        scene: |v| {
            format!(
                "{MATERIAL}{LIGHT}[[cylinders]]\np0 = [0.0, 0.0, 0.0]\np1 = [0.0, 1.0, 0.0]\nradius = {v}\nmaterial = \"m\"\n"
            )
        },
        negative_ok: false,
    },
    Place {
        name: "light position",
        scene: |v| {
            format!(
                "{MATERIAL}{SPHERE}[[lights]]\ntype = \"point\"\nposition = [{v}, 5.0, 5.0]\nintensity = [1.0, 1.0, 1.0]\n"
            )
        },
        negative_ok: true,
    },
    Place {
        name: "mesh vertex",
        scene: |v| {
            let obj = format!("v 0 0 0\nv 1 0 0\nv 0 1 0\nv {v} 1 1\nf 1 2 3\nf 2 4 3\n");
            format!("#OBJ {obj}#END\n{MATERIAL}{LIGHT}{SPHERE}[[meshes]]\nfile = \"mesh.obj\"\nmaterial = \"m\"\n")
        },
        negative_ok: true,
    },
    Place {
        name: "mesh translate",
        scene: |v| {
            let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
            format!(
                "#OBJ {obj}#END\n{MATERIAL}{LIGHT}{SPHERE}[[meshes]]\nfile = \"mesh.obj\"\nmaterial = \"m\"\ntranslate = [{v}, 0.0, 0.0]\n"
            )
        },
        negative_ok: true,
    },
    Place {
        name: "mesh scale",
        scene: |v| {
            let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
            format!(
                "#OBJ {obj}#END\n{MATERIAL}{LIGHT}{SPHERE}[[meshes]]\nfile = \"mesh.obj\"\nmaterial = \"m\"\nscale = {v}\n"
            )
        },
        negative_ok: true,
    },
];

/// Writes the scene (and the OBJ file it embeds between `#OBJ ` and `#END`) into `dir` and
/// renders it: (exit code, stderr).
fn run(dir: &Path, text: &str) -> (Option<i32>, String) {
    std::fs::create_dir_all(dir).unwrap();
    let text = match text.split_once("#OBJ ").and_then(|(_, rest)| rest.split_once("#END\n")) {
        Some((obj, scene)) => {
            std::fs::write(dir.join("mesh.obj"), obj).unwrap();
            scene.to_string()
        }
        None => text.to_string(),
    };
    let scene = dir.join("scene.toml");
    std::fs::write(&scene, text).unwrap();
    let out = dir.join("out.png");
    let o = Command::new(env!("CARGO_BIN_EXE_ember"))
        .args(["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap()])
        .args(["--width", "8", "--height", "6", "--spp", "2", "--threads", "1"])
        .output()
        .unwrap();
    (o.status.code(), String::from_utf8_lossy(&o.stderr).into_owned())
}

#[test]
fn every_magnitude_renders_or_is_refused_with_its_line() {
    let root = common::fresh_dir("ranges", "sweep");
    let cases: Vec<(usize, f64)> =
        (0..PLACES.len()).flat_map(|p| MAGNITUDES.iter().flat_map(move |&m| [(p, m), (p, -m)])).collect();
    let results = std::sync::Mutex::new(Vec::new());
    let next = std::sync::atomic::AtomicUsize::new(0);
    std::thread::scope(|s| {
        for _ in 0..2 {
            s.spawn(|| {
                loop {
                    let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                    let Some(&(p, v)) = cases.get(i) else { break };
                    let text = (PLACES[p].scene)(format!("{v:e}"));
                    let (code, stderr) = run(&root.join(i.to_string()), &text);
                    results.lock().unwrap().push((p, v, code, stderr));
                }
            });
        }
    });
    let results = results.into_inner().unwrap();
    assert_eq!(results.len(), cases.len());
    for (p, v, code, stderr) in results {
        let place = &PLACES[p];
        let what = format!("{} = {v:e}", place.name);
        assert!(matches!(code, Some(0 | 2)), "{what}: exit {code:?}: {stderr}");
        let allowed = v.abs() <= LIMIT && (v >= 0.0 || place.negative_ok);
        if allowed {
            assert_eq!(code, Some(0), "{what}: refused: {stderr}");
        } else {
            assert_eq!(code, Some(2), "{what}: rendered: {stderr}");
            let error = stderr.lines().find(|l| l.starts_with("error: ")).unwrap_or("");
            // A line number, in the scene file or the mesh file.
            let located = error.contains(".toml:") || error.contains(".obj:");
            assert!(located, "{what}: no file and line in {error:?}");
            let says_why = ["1e15", "negative", "greater than 0"].iter().any(|w| error.contains(w));
            assert!(says_why, "{what}: no range in {error:?}");
        }
    }
}

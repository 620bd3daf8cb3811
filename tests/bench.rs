//! `ember bench`: a quick run writes the promised files with the promised rows and columns,
//! and every Embree strategy answers the benchmark rays as the naive loop does. No timing is
//! asserted (speed is measured, not tested).

mod common;

use common::ember;
use std::collections::{HashMap, HashSet};
use std::path::PathBuf;

fn scenes_dir() -> String {
    format!("{}/scenes", env!("CARGO_MANIFEST_DIR"))
}

/// A CSV file as (header, rows of column name → value).
fn read_csv(path: &PathBuf) -> (Vec<String>, Vec<HashMap<String, String>>) {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines = text.lines();
    let header: Vec<String> = lines.next().expect("header").split(',').map(String::from).collect();
    let rows = lines
        .map(|l| {
            let cells: Vec<&str> = l.split(',').collect();
            assert_eq!(cells.len(), header.len(), "row {l:?}");
            header.iter().cloned().zip(cells.into_iter().map(String::from)).collect()
        })
        .collect();
    (header, rows)
}

fn num(row: &HashMap<String, String>, col: &str) -> f64 {
    row[col].parse().unwrap_or_else(|_| panic!("{col} = {:?} is not a number", row[col]))
}

#[test]
fn quick_run_writes_the_matrix_plot_and_render_table() {
    let out = common::fresh_path("bench", "quick");
    let o = ember(&["bench", "--quick", "--out", out.to_str().unwrap(), "--scenes-dir", &scenes_dir()]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}\n{}", stdout, String::from_utf8_lossy(&o.stderr));
    // The header names the Embree in use (3.13 by default, 4.x with --features embree4).
    let version = ember::embree::Device::new().unwrap().version();
    assert!(stdout.contains(&format!("Embree {version}")), "{stdout}");

    let (header, rows) = read_csv(&out.join("bench.csv"));
    for col in [
        "scene",
        "strategy",
        "triangles",
        "build_ms",
        "rays",
        "ray_count",
        "mrays_per_s",
        "ns_per_ray",
        "naive_ray_count",
        "speedup_vs_naive",
        "checked",
        "mismatches",
        "mismatches_at_edges",
    ] {
        assert!(header.iter().any(|h| h == col), "bench.csv lacks {col}: {header:?}");
    }
    // Every strategy × workload of the quick set, once each.
    let triangles = [("teapot", 6320), ("blob-1k", 972), ("blob-10k", 10_092), ("shapes-100", 0)];
    let mut expected = HashSet::new();
    for (scene, _) in triangles {
        let mut strategies =
            vec!["naive", "embree-low", "embree-medium", "embree-high", "embree-robust", "embree-packet8"];
        if scene == "shapes-100" {
            strategies.push("embree-tess");
        }
        for s in strategies {
            for k in ["coherent", "incoherent", "occlusion"] {
                expected.insert((scene.to_string(), s.to_string(), k.to_string()));
            }
        }
    }
    let got: Vec<(String, String, String)> =
        rows.iter().map(|r| (r["scene"].clone(), r["strategy"].clone(), r["rays"].clone())).collect();
    assert_eq!(got.len(), expected.len(), "{got:?}");
    assert_eq!(got.iter().cloned().collect::<HashSet<_>>(), expected);

    for r in &rows {
        let what = format!("{} {} {}", r["scene"], r["strategy"], r["rays"]);
        let tris = triangles.iter().find(|(s, _)| *s == r["scene"]).unwrap().1;
        assert_eq!(num(r, "triangles") as usize, tris, "{what}");
        assert!(num(r, "ray_count") > 0.0 && num(r, "mrays_per_s") > 0.0, "{what}");
        if r["strategy"] == "naive" {
            assert_eq!(num(r, "speedup_vs_naive"), 1.0, "{what}");
            assert_eq!(r["ray_count"], r["naive_ray_count"], "{what}");
        } else {
            assert!(!r["build_ms"].is_empty(), "{what}");
            // Embree answers the naive loop's subsample as the naive loop does, apart from
            // rays through triangle edges or grazing curved surfaces.
            assert!(num(r, "checked") > 0.0, "{what}");
            assert_eq!(r["mismatches"], r["mismatches_at_edges"], "{what}: a mismatch away from any edge");
        }
    }
    // Hits are the same whatever the build quality (same rays, same geometry), up to edge rays.
    for scene in ["teapot", "blob-1k", "blob-10k"] {
        for k in ["coherent", "incoherent", "occlusion"] {
            let hits: Vec<f64> = rows
                .iter()
                .filter(|r| r["scene"] == scene && r["rays"] == k && r["strategy"].starts_with("embree"))
                .map(|r| num(r, "hits"))
                .collect();
            let (lo, hi) = hits.iter().fold((f64::MAX, 0.0f64), |(a, b), &h| (a.min(h), b.max(h)));
            assert!(hi - lo <= 0.001 * hi + 2.0, "{scene} {k}: hits {hits:?}");
        }
    }

    let png = image::open(out.join("scaling.png")).expect("scaling.png is an image");
    assert_eq!((png.width(), png.height()), (900, 600));

    let (header, rows) = read_csv(&out.join("render.csv"));
    for col in [
        "scene",
        "rays",
        "closest_queries",
        "occlusion_queries",
        "samples_per_s_1t",
        "samples_per_s_2t",
        "thread_scaling",
        "path_tracer_percent_of_embree",
    ] {
        assert!(header.iter().any(|h| h == col), "render.csv lacks {col}: {header:?}");
    }
    assert_eq!(rows.iter().map(|r| r["scene"].as_str()).collect::<Vec<_>>(), ["cornell.toml", "teapot.toml"]);
    // Without --bvh-quality, each scene gets the BVH `ember render` builds for it: low for the
    // 34-triangle box, medium for the 6,320-triangle teapot; robust.
    let builds: Vec<(&str, &str)> =
        rows.iter().map(|r| (r["bvh_quality"].as_str(), r["bvh_robust"].as_str())).collect();
    assert_eq!(builds, [("low", "true"), ("medium", "true")]);
    for r in &rows {
        // Every ray the path tracer counted was recorded and replayed.
        assert_eq!(num(r, "rays"), num(r, "closest_queries") + num(r, "occlusion_queries"));
        assert!(num(r, "occlusion_queries") > 0.0 && num(r, "path_tracer_percent_of_embree") > 0.0);
    }
    std::fs::remove_dir_all(&out).unwrap();
}

#[test]
fn specialize_table_has_every_scene_file() {
    let out = common::fresh_path("bench", "specialize");
    let o = ember(&["bench", "--quick", "--specialize", "--out", out.to_str().unwrap(), "--scenes-dir", &scenes_dir()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (_, rows) = read_csv(&out.join("specialize.csv"));
    let mut want: Vec<String> = std::fs::read_dir(scenes_dir())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".toml") || n.ends_with(".obj"))
        .collect();
    want.sort();
    assert_eq!(rows.iter().map(|r| r["scene"].clone()).collect::<Vec<_>>(), want);
    for r in &rows {
        assert!(num(r, "general_us_per_sample") > 0.0 && num(r, "specialized_us_per_sample") > 0.0);
        // The speedup is the median of the pairs' ratios: within their range.
        assert!(num(r, "pairs") >= 1.0);
        assert!(num(r, "speedup_min") <= num(r, "speedup") && num(r, "speedup") <= num(r, "speedup_max"), "{r:?}");
        assert_eq!(r["identical_image"], "true");
    }
    assert!(!out.join("bench.csv").exists(), "--specialize runs only its own table");
    std::fs::remove_dir_all(&out).unwrap();
}

/// `ember bench --quick --render` with `args`, into a fresh folder `name` (removed after):
/// what it printed and the rows of its render.csv.
fn quick_render_section(name: &str, args: &[&str]) -> (String, Vec<HashMap<String, String>>) {
    let out = common::fresh_path("bench", name);
    let scenes = scenes_dir();
    let mut argv = vec!["bench", "--quick", "--render", "--out", out.to_str().unwrap(), "--scenes-dir", &scenes];
    argv.extend_from_slice(args);
    let o = ember(&argv);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (_, rows) = read_csv(&out.join("render.csv"));
    std::fs::remove_dir_all(&out).unwrap();
    (String::from_utf8_lossy(&o.stdout).into_owned(), rows)
}

#[test]
fn render_section_takes_the_bvh_build_of_ember_render() {
    let (text, rows) = quick_render_section("render-bvh", &["--no-robust", "--bvh-quality", "low"]);
    assert!(
        text.contains("Russian roulette, low BVH, scalar path loop)"),
        "the table says which build it measured: {text}"
    );
    assert_eq!(rows.len(), 2);
    assert!(rows.iter().all(|r| r["bvh_quality"] == "low" && r["bvh_robust"] == "false"), "{rows:?}");
    // The build is a setting of the render section only.
    let out = common::fresh_path("bench", "render-bvh-only");
    let o = ember(&["bench", "--quick", "--no-robust", "--out", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--render"), "{}", String::from_utf8_lossy(&o.stderr));
}

#[test]
fn render_section_runs_the_path_loop_it_is_given() {
    // The wavefront loop traces the scalar loop's paths: the same rays, recorded and replayed.
    let rays_of = |path_loop: &str| {
        let (text, rows) = quick_render_section(&format!("render-{path_loop}"), &["--path-loop", path_loop]);
        assert!(text.contains(&format!("{path_loop} path loop)")), "the table says which loop it measured: {text}");
        assert!(rows.iter().all(|r| r["path_loop"] == path_loop), "{rows:?}");
        rows.iter().map(|r| (r["scene"].clone(), num(r, "rays"), num(r, "occlusion_queries"))).collect::<Vec<_>>()
    };
    assert_eq!(rays_of("wavefront"), rays_of("scalar"));
}

#[test]
fn bad_bench_input_is_exit_2_and_names_the_problem() {
    let o = ember(&["bench", "--scene", "nosuch", "--out", "/tmp/never-used"]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.starts_with("error: --scene: unknown scene \"nosuch\""), "{err}");

    let out = common::fresh_path("bench", "missing");
    let o = ember(&["bench", "--scene", "no/such/model.obj", "--out", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert_eq!(String::from_utf8_lossy(&o.stderr).trim(), "error: no/such/model.obj: no such file");
    assert!(!out.join("bench.csv").exists());

    let file = std::env::temp_dir().join(format!("ember-bench-file-{}", std::process::id()));
    std::fs::write(&file, "x").unwrap();
    let o = ember(&["bench", "--quick", "--out", file.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("not a folder"));
    std::fs::remove_file(&file).unwrap();
    let _ = std::fs::remove_dir_all(&out);
}

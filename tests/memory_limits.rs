//! The memory limit holds in total and up front: the scene file, every mesh and MTL file, the
//! textures (decoded) and the film are counted together before each allocates. Each case is
//! refused (exit 2, the estimate in the message) with the process's peak memory under the
//! limit plus a small constant, and what fits renders within the limit.
//!
//! Peak memory is the child's maximum resident set size (`getrusage(RUSAGE_CHILDREN)`), read
//! in a fresh copy of this test binary that runs one `ember` and nothing else.

mod common;

use std::io::Write;
use std::path::Path;
use std::process::Command;

/// Above the limit, what the process may hold besides what the budget counts: the binary,
/// Embree's and TBB's libraries and their first allocations (measured: 9.5 MB for a tiny
/// render).
const BASELINE: u64 = 40_000_000;

/// What one measured `ember` run did.
struct Run {
    code: Option<i32>,
    stderr: String,
    peak_rss: u64,
}

const MEASURE_ARGS: &str = "EMBER_TEST_MEASURE_ARGS";

/// Runs `ember ARGS` with `EMBER_MEMORY_LIMIT=limit` and measures its peak memory.
fn measured(args: &[&str], limit: &str) -> Run {
    let exe = std::env::current_exe().unwrap();
    let o = Command::new(exe)
        .args(["--exact", "measure_one_child", "--ignored", "--nocapture", "--test-threads=1"])
        .env(MEASURE_ARGS, args.join("\u{1f}"))
        .env("EMBER_MEMORY_LIMIT", limit)
        .output()
        .unwrap();
    let out = String::from_utf8_lossy(&o.stdout);
    let field = |key: &str| {
        // The harness prints the test's name on the line of its first output.
        let line = out.lines().find_map(|l| l.find(key).map(|i| &l[i + key.len()..]));
        let line = line.unwrap_or_else(|| panic!("no {key} in {out}"));
        line.trim().to_string()
    };
    let code = field("EXIT=").parse().ok();
    let peak_rss = field("MAXRSS_KB=").parse::<u64>().unwrap() * 1024;
    let stderr = std::fs::read_to_string(field("STDERR_FILE=")).unwrap();
    Run { code, stderr, peak_rss }
}

/// Not a test of its own: [`measured`] runs it in a fresh process, where it runs `ember` once
/// and reports the child's exit code, stderr and peak resident set size.
#[test]
#[ignore = "run by the other tests of this file in a fresh process"]
fn measure_one_child() {
    let args = std::env::var(MEASURE_ARGS).expect("only run by measured()");
    let args: Vec<&str> = args.split('\u{1f}').collect();
    let o = Command::new(env!("CARGO_BIN_EXE_ember")).args(&args).output().unwrap();
    let usage = nix::sys::resource::getrusage(nix::sys::resource::UsageWho::RUSAGE_CHILDREN).unwrap();
    let stderr_file = std::env::temp_dir().join(format!("ember-measure-{}.txt", std::process::id()));
    std::fs::write(&stderr_file, &o.stderr).unwrap();
    println!("EXIT={}", o.status.code().map_or("signal".to_string(), |c| c.to_string()));
    println!("MAXRSS_KB={}", usage.max_rss());
    println!("STDERR_FILE={}", stderr_file.display());
}

fn parse_limit(limit: &str) -> u64 {
    ember::memory::parse_size(limit).unwrap().unwrap()
}

/// `args` are refused below `limit`: exit 2, `needle` in the error, no output, and peak memory
/// under the limit plus [`BASELINE`].
fn refused(what: &str, args: &[&str], limit: &str, needle: &str, out: &Path) {
    let r = measured(args, limit);
    println!("{what}: exit {:?}, peak {:.1} MB: {}", r.code, r.peak_rss as f64 / 1e6, r.stderr.trim());
    assert_eq!(r.code, Some(2), "{what}: {}", r.stderr);
    assert!(r.stderr.contains(needle), "{what}: expected {needle:?} in {}", r.stderr);
    assert!(r.peak_rss <= parse_limit(limit) + BASELINE, "{what}: peak {} bytes under a {limit} limit", r.peak_rss);
    assert!(!out.exists(), "{what}: output written");
}

/// A grid mesh of about `2 n²` triangles as OBJ text.
fn grid_obj(n: usize) -> String {
    let mut s = String::with_capacity(n * n * 40);
    for y in 0..=n {
        for x in 0..=n {
            s += &format!("v {x} {y} {}\n", (x * y) % 7);
        }
    }
    for y in 0..n {
        for x in 0..n {
            let i = y * (n + 1) + x + 1;
            s += &format!("f {} {} {} {}\n", i, i + 1, i + n + 2, i + n + 1);
        }
    }
    s
}

#[test]
fn every_part_of_a_load_counts_against_one_limit() {
    let d = common::fresh_dir("memory", "limits");
    let out = d.join("out.png");
    let o = out.to_str().unwrap();
    let small = ["--width", "8", "--height", "8", "--spp", "1"];

    // A 1 GB MTL file (sparse: no disk used) behind a 3-triangle OBJ, under 100 MB.
    let mtl = std::fs::File::create(d.join("big.mtl")).unwrap();
    mtl.set_len(1 << 30).unwrap();
    let obj = d.join("small.obj");
    std::fs::write(&obj, "mtllib big.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\nf 1 3 4\n").unwrap();
    let args = [&["render", obj.to_str().unwrap(), "-o", o][..], &small].concat();
    refused("1 GB MTL", &args, "100M", "big.mtl of 1.1 GB needs ~4.3 GB to load", &out);

    // Forty meshes of one 80,000-triangle mesh, under 250 MB: refused at the mesh that would
    // not fit beside the ones loaded (each keeps its data and its share of the BVH).
    std::fs::write(d.join("grid.obj"), grid_obj(200)).unwrap();
    let mut toml = String::from("[materials.m]\ntype = \"diffuse\"\n[[lights]]\ntype = \"point\"\n");
    toml += "position = [0.0, 0.0, 50.0]\nintensity = [100.0, 100.0, 100.0]\n";
    for i in 0..40 {
        toml += &format!("[[meshes]]\nfile = \"grid.obj\"\nmaterial = \"m\"\ntranslate = [{i}.0, 0.0, 0.0]\n");
    }
    let forty = d.join("forty.toml");
    std::fs::write(&forty, &toml).unwrap();
    let args = [&["render", forty.to_str().unwrap(), "-o", o][..], &small].concat();
    refused("forty meshes", &args, "250M", "already loaded, more than the 250.0 MB limit", &out);
    // Four of them fit, and the render stays within the limit.
    let four: String = toml.split("[[meshes]]").take(5).collect::<Vec<_>>().join("[[meshes]]");
    let four_path = d.join("four.toml");
    std::fs::write(&four_path, four).unwrap();
    let r = measured(&[&["render", four_path.to_str().unwrap(), "-o", o][..], &small].concat(), "250M");
    println!("four meshes: exit {:?}, peak {:.1} MB", r.code, r.peak_rss as f64 / 1e6);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    assert!(r.peak_rss <= parse_limit("250M"), "four meshes: peak {} bytes", r.peak_rss);
    std::fs::remove_file(&out).unwrap();

    // The scene file itself: 200,000 spheres of TOML (14 MB) under 30 MB.
    let mut f = std::io::BufWriter::new(std::fs::File::create(d.join("spheres.toml")).unwrap());
    f.write_all(b"[materials.m]\ntype = \"diffuse\"\n").unwrap();
    for i in 0..200_000 {
        write!(f, "[[spheres]]\ncenter = [{}.5, {}.25, 0.125]\nradius = 0.01\nmaterial = \"m\"\n", i % 1000, i / 1000)
            .unwrap();
    }
    drop(f);
    let spheres = d.join("spheres.toml");
    let args = [&["render", spheres.to_str().unwrap(), "-o", o][..], &small].concat();
    refused("200,000 spheres", &args, "30M", "needs ~", &out);

    // A texture, by its decoded size, and the film.
    std::fs::copy(common::scene_path("earthmap.jpg"), d.join("earth.jpg")).unwrap();
    let textured = d.join("textured.toml");
    std::fs::write(
        &textured,
        "[materials.m]\ntype = \"diffuse\"\ntexture = \"earth.jpg\"\n[[spheres]]\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nmaterial = \"m\"\n",
    )
    .unwrap();
    let args = [&["render", textured.to_str().unwrap(), "-o", o][..], &small].concat();
    refused("texture", &args, "10M", "1024x512 image needs ~12.2 MB to load", &out);
    let args = ["render", textured.to_str().unwrap(), "-o", o, "--width", "16384", "--height", "16384"];
    refused("film", &args, "2G", "image 16384x16384 needs ~31.1 GB of film memory", &out);
}

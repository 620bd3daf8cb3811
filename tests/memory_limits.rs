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

/// Every large allocation is counted before it is made, wherever it hides: one PLY face of
/// ten million indices (ASCII and binary), the auxiliary images and the denoiser's buffers, a
/// glTF texture copied for materials of other base colours, glTF buffers that name one large
/// file. Each is refused (or, for the buffers, read only as far as counted) with the process's
/// peak memory under the limit plus [`BASELINE`].
#[test]
fn hidden_large_allocations_are_counted_first() {
    let d = common::fresh_dir("memory", "hidden");
    let out = d.join("out.png");
    let o = out.to_str().unwrap();
    let small = ["--width", "8", "--height", "8", "--spp", "1"];
    let head = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\n\
                property list uint int vertex_indices\nend_header\n";
    // ASCII: one line of 10,000,000 indices (20 MB).
    let mut ply = format!("ply\nformat ascii 1.0\n{head}0 0 0\n1 0 0\n0 1 0\n10000000").into_bytes();
    for i in 0..10_000_000u32 {
        ply.extend_from_slice([b" 0", b" 1", b" 2"][(i % 3) as usize]);
    }
    ply.push(b'\n');
    std::fs::write(d.join("face.ply"), &ply).unwrap();
    let face_ply = d.join("face.ply");
    let args = [&["render", face_ply.to_str().unwrap(), "-o", o][..], &small].concat();
    refused("ASCII PLY face", &args, "100M", "a face of 10000000 values needs ~640.0 MB to load", &out);
    // Binary: the same face, its count a uint, 40 MB of indices.
    let mut ply = format!("ply\nformat binary_little_endian 1.0\n{head}").into_bytes();
    for v in [[0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
        ply.extend(v.iter().flat_map(|c| c.to_le_bytes()));
    }
    ply.extend(10_000_000u32.to_le_bytes());
    ply.extend((0..10_000_000i32).flat_map(|i| (i % 3).to_le_bytes()));
    std::fs::write(d.join("binary.ply"), &ply).unwrap();
    let binary_ply = d.join("binary.ply");
    let args = [&["render", binary_ply.to_str().unwrap(), "-o", o][..], &small].concat();
    refused("binary PLY face", &args, "100M", "a face of 10000000 values needs ~640.0 MB to load", &out);

    // A mesh whose every triangle emits (a lit panel of 180,000 triangles): each is a light to
    // sample, with its record and its share of the light tree (~88 MB estimated, ~50 MB
    // measured), counted before they are built.
    std::fs::write(d.join("glow.mtl"), "newmtl glow\nKd 0 0 0\nKe 1 1 1\n").unwrap();
    std::fs::write(d.join("glow.obj"), format!("mtllib glow.mtl\nusemtl glow\n{}", grid_obj(300))).unwrap();
    let glow = d.join("glow.obj");
    let args = [&["render", glow.to_str().unwrap(), "-o", o][..], &small].concat();
    refused("emitting mesh", &args, "80M", "the lights of 180000 emitting triangles and spheres needs ~", &out);

    // The auxiliary images (--aux) and the denoiser (--denoise) of a 1000x1000 render: counted
    // with the film before rendering.
    let spheres = common::scene_path("spheres.toml");
    let exr = d.join("out.exr");
    let big = ["--width", "1000", "--height", "1000", "--spp", "1"];
    let args = [&["render", spheres.to_str().unwrap(), "-o", exr.to_str().unwrap(), "--aux"][..], &big].concat();
    refused("--aux", &args, "180M", "auxiliary images, adaptive plan and denoiser buffers needs ~", &exr);
    let args = [&["render", spheres.to_str().unwrap(), "-o", o, "--denoise"][..], &big].concat();
    refused("--denoise", &args, "300M", "needs ~", &out);

    // A 2048x2048 texture (a 12 kB PNG) as the base colour of 20 materials of different base
    // colour factors: decoded once (22 MB with its mipmaps) and shared, the factors applied
    // at lookup, so 20 materials fit where 20 copies (450 MB) would not.
    image::RgbImage::from_pixel(2048, 2048, image::Rgb([200, 100, 50])).save(d.join("tex.png")).unwrap();
    let materials: Vec<String> = (0..20)
        .map(|i| {
            format!(
                r#"{{"pbrMetallicRoughness": {{"baseColorTexture": {{"index": 0}}, "baseColorFactor": [0.5, 0.5, {}, 1]}}}}"#,
                i as f32 / 20.0
            )
        })
        .collect();
    let primitives: Vec<String> =
        (0..20).map(|i| format!(r#"{{"attributes": {{"POSITION": 0, "TEXCOORD_0": 1}}, "material": {i}}}"#)).collect();
    let mut buf: Vec<u8> =
        [0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0].iter().flat_map(|c| c.to_le_bytes()).collect();
    buf.extend([0f32, 0.0, 1.0, 0.0, 0.0, 1.0].iter().flat_map(|c| c.to_le_bytes()));
    std::fs::write(d.join("tri.bin"), &buf).unwrap();
    let gltf = format!(
        r#"{{"asset": {{"version": "2.0"}}, "scenes": [{{"nodes": [0]}}], "nodes": [{{"mesh": 0}}],
        "meshes": [{{"primitives": [{}]}}], "materials": [{}],
        "textures": [{{"source": 0}}], "images": [{{"uri": "tex.png"}}],
        "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}},
                      {{"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC2"}}],
        "bufferViews": [{{"buffer": 0, "byteLength": 36}}, {{"buffer": 0, "byteOffset": 36, "byteLength": 24}}],
        "buffers": [{{"byteLength": 60, "uri": "tri.bin"}}]}}"#,
        primitives.join(", "),
        materials.join(", ")
    );
    std::fs::write(d.join("shared.gltf"), gltf).unwrap();
    let shared_gltf = d.join("shared.gltf");
    let args = [&["render", shared_gltf.to_str().unwrap(), "-o", o][..], &small].concat();
    let r = measured(&args, "150M");
    println!("shared texture: exit {:?}, peak {:.1} MB", r.code, r.peak_rss as f64 / 1e6);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    assert!(r.peak_rss <= parse_limit("150M"), "shared texture: peak {} bytes", r.peak_rss);
    std::fs::remove_file(&out).unwrap();

    // 30 buffers of 60 bytes, each naming one 100 MB file (a triangle, then zeros): only what
    // they use is read, once.
    let f = std::fs::File::create(d.join("large.bin")).unwrap();
    std::io::Write::write_all(&mut &f, &buf).unwrap();
    f.set_len(100_000_000).unwrap();
    let buffers: Vec<&str> = (0..30).map(|_| r#"{"byteLength": 60, "uri": "large.bin"}"#).collect();
    let gltf = format!(
        r#"{{"asset": {{"version": "2.0"}}, "scenes": [{{"nodes": [0]}}], "nodes": [{{"mesh": 0}}],
        "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}}}]}}],
        "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}}],
        "bufferViews": [{{"buffer": 29, "byteLength": 36}}],
        "buffers": [{}]}}"#,
        buffers.join(", ")
    );
    std::fs::write(d.join("buffers.gltf"), gltf).unwrap();
    let buffers_gltf = d.join("buffers.gltf");
    let args = [&["render", buffers_gltf.to_str().unwrap(), "-o", o][..], &small].concat();
    let r = measured(&args, "100M");
    println!("30 buffers of one file: exit {:?}, peak {:.1} MB", r.code, r.peak_rss as f64 / 1e6);
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    assert!(r.peak_rss <= parse_limit("100M"), "30 buffers of one file: peak {} bytes", r.peak_rss);
    std::fs::remove_dir_all(&d).unwrap();
}

/// A file that says it holds nothing and holds gigabytes (`/proc/self/pagemap`) is read no
/// further than its size says, as a texture, an environment or a mesh; and a PNG whose header
/// claims a huge image is refused with ember's own estimate.
#[test]
fn special_files_and_lying_headers_are_refused_before_reading() {
    use image::ImageEncoder;
    let d = common::fresh_dir("memory", "special");
    let out = d.join("out.png");
    let o = out.to_str().unwrap();
    let sphere = "[[spheres]]\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\nmaterial = \"m\"\n\
                  [[lights]]\ntype = \"point\"\nposition = [0.0, 3.0, 3.0]\nintensity = [9.0, 9.0, 9.0]\n";
    let cases = [
        ("texture", format!("[materials.m]\ntype = \"diffuse\"\ntexture = \"/proc/self/pagemap\"\n{sphere}")),
        (
            "environment",
            format!(
                "[materials.m]\ntype = \"diffuse\"\n[background]\ntype = \"image\"\nfile = \"/proc/self/pagemap\"\n{sphere}"
            ),
        ),
    ];
    for (what, toml) in cases {
        let scene = d.join(format!("{what}.toml"));
        std::fs::write(&scene, toml).unwrap();
        let start = std::time::Instant::now();
        let r = measured(&[&["render", scene.to_str().unwrap(), "-o", o][..], &["--spp", "1"]].concat(), "1G");
        assert!(start.elapsed() < std::time::Duration::from_secs(30), "{what}: read for {:?}", start.elapsed());
        assert_eq!(r.code, Some(2), "{what}: {}", r.stderr);
        assert!(r.stderr.contains("/proc/self/pagemap: cannot read"), "{what}: {}", r.stderr);
        assert!(r.peak_rss <= BASELINE * 2, "{what}: peak {} bytes", r.peak_rss);
    }
    // A mesh that is a link to it.
    std::os::unix::fs::symlink("/proc/self/pagemap", d.join("pagemap.ply")).unwrap();
    let r = measured(&["render", d.join("pagemap.ply").to_str().unwrap(), "-o", o, "--spp", "1"], "1G");
    assert_eq!(r.code, Some(2), "{}", r.stderr);
    // A PNG header of 100000x100000 pixels: ember's estimate, not the decoder's refusal.
    let mut png = Vec::new();
    image::codecs::png::PngEncoder::new(&mut png).write_image(&[0; 3], 1, 1, image::ExtendedColorType::Rgb8).unwrap();
    png[16..24].copy_from_slice(&[0, 1, 0x86, 0xA0, 0, 1, 0x86, 0xA0]); // IHDR width, height
    let crc = crc32(&png[12..29]);
    png[29..33].copy_from_slice(&crc.to_be_bytes());
    std::fs::write(d.join("huge.png"), &png).unwrap();
    let scene = d.join("huge.toml");
    std::fs::write(&scene, format!("[materials.m]\ntype = \"diffuse\"\ntexture = \"huge.png\"\n{sphere}")).unwrap();
    let args = ["render", scene.to_str().unwrap(), "-o", o, "--spp", "1"];
    refused("huge PNG header", &args, "1G", "100000x100000 image needs ~230.0 GB to load", &out);
    // 2147483647² RGB: the png crate's byte count overflows and it refuses in its own words;
    // ember still gives its estimate.
    png[16..24].copy_from_slice(&[0x7f, 0xff, 0xff, 0xff, 0x7f, 0xff, 0xff, 0xff]);
    let crc = crc32(&png[12..29]);
    png[29..33].copy_from_slice(&crc.to_be_bytes());
    std::fs::write(d.join("huge.png"), &png).unwrap();
    refused("overflowing PNG header", &args, "1G", "2147483647x2147483647 image needs ~", &out);
    std::fs::remove_dir_all(&d).unwrap();
}

/// CRC-32 (IEEE), as PNG chunks carry.
fn crc32(bytes: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in bytes {
        c ^= b as u32;
        for _ in 0..8 {
            c = if c & 1 != 0 { 0xEDB8_8320 ^ (c >> 1) } else { c >> 1 };
        }
    }
    !c
}

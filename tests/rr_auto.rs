//! The Russian-roulette start chosen from the scene (`--rr-depth auto`, the default): what it
//! is for the sample scenes, that the specialised and the general kernel use the same start
//! (bit-identical images), that an explicit choice wins, and that the kernel line says which.

mod common;

use common::ember;
use ember::film::Film;
use ember::integrator::{KernelChoice, RenderSettings, RrDepth, roulette};
use ember::scene::Scene;

/// Two diffuse spheres of albedo 0.5 on a floor of albedo 0.4 under a sky: light bounces
/// between them, and 0.5³ = 0.125 > 1/10 ≥ 0.5⁴, so roulette starts at depth 4.
const DIM: &str = r#"
[camera]
position = [0, 1, 5]
look_at = [0, 0.5, 0]
fov = 45
[background]
type = "constant"
color = [1, 1, 1]
[materials.dim]
type = "diffuse"
color = [0.5, 0.4, 0.3]
[materials.floor]
type = "diffuse"
color = [0.4, 0.4, 0.4]
[[spheres]]
center = [-0.6, 0.5, 0]
radius = 0.5
material = "dim"
[[spheres]]
center = [0.6, 0.5, 0]
radius = 0.5
material = "dim"
[[quads]]
corner = [-5, 0, -5]
edge1 = [0, 0, 10]
edge2 = [10, 0, 0]
material = "floor"
"#;

fn scene(name: &str, text: &str) -> Scene {
    Scene::load(&common::write_scene("rr-auto", name, text)).unwrap_or_else(|e| panic!("{e}"))
}

fn small(rr_depth: RrDepth) -> RenderSettings {
    RenderSettings { width: 40, height: 30, spp: 4, max_depth: 8, rr_depth, seed: 3, ..Default::default() }
}

fn bits(f: &Film) -> Vec<[u32; 3]> {
    f.pixels.iter().map(|p| p.to_array().map(f32::to_bits)).collect()
}

#[test]
fn sample_scenes_start_roulette_where_their_albedo_says() {
    // (scene, largest albedo in use, automatic start at the scene's own max_depth)
    let cases: [(&str, f32, Option<u32>); 9] = [
        // Checker ground up to 0.75 (the plastic teapot: 0.04 + 0.96 · 0.62 ≈ 0.64): it would
        // start at 9, past max_depth 8.
        ("teapot.toml", 0.75, None),
        // The Cornell box's white walls have Kd 1: paths never lose throughput.
        ("cornell.toml", 1.0, None),
        ("cornell-area.toml", 1.0, None),
        // Clear glass (and a 0.95 mirror).
        ("spheres.toml", 1.0, None),
        // Gold metal 0.95 would start at 14, past max_depth 6.
        ("dof.toml", 0.95, None),
        // The glTF gold's base colour has red 1: a metal of albedo 1.
        ("gltf-sky.toml", 1.0, None),
        // A bare mesh's clay (largest channel 0.75) on the studio ground (0.5): 0.75⁸ = 0.1001,
        // so it would start at 9, past the default max_depth 8.
        ("teapot.obj", 0.75, None),
        ("cornell_box.obj", 1.0, None),
        ("bunny.obj", 0.75, None),
    ];
    for (name, albedo, start) in cases {
        let scene = Scene::load(&common::scene_path(name)).unwrap();
        let e = scene.effects();
        assert!((e.albedo - albedo).abs() < 1e-6, "{name}: albedo {}", e.albedo);
        let max_depth = scene.render.max_depth.unwrap_or(RenderSettings::default().max_depth);
        assert_eq!(roulette::auto_start(&e, max_depth), start, "{name}");
    }
}

#[test]
fn the_automatic_start_is_the_same_for_the_specialised_and_the_general_kernel() {
    let dim = scene("dim.toml", DIM);
    assert_eq!(roulette::auto_start(&dim.effects(), 8), Some(4));
    let (spec, s) = common::render_embree(&dim, &small(RrDepth::Auto));
    let (general, g) = common::render_embree(&dim, &RenderSettings { specialize: false, ..small(RrDepth::Auto) });
    assert_eq!(g.plan.kernel, KernelChoice::GENERAL);
    assert_ne!(s.plan.kernel, KernelChoice::GENERAL);
    assert_eq!((s.plan.roulette_start, g.plan.roulette_start), (Some(4), Some(4)));
    assert!(bits(&spec) == bits(&general), "the specialised kernel's image differs from the general kernel's");
    assert_eq!(s.rays, g.rays);
    assert!(spec.mean().max_element() > 0.05);

    // It is the explicit start 4, and roulette does run: without it the image differs.
    let (explicit, _) = common::render_embree(&dim, &small(RrDepth::After(4)));
    assert!(bits(&explicit) == bits(&spec));
    let (off, o) = common::render_embree(&dim, &small(RrDepth::Off));
    assert_eq!(o.plan.roulette_start, None);
    assert!(bits(&off) != bits(&spec));
    assert!(o.rays > s.rays, "roulette ends paths early: {} rays without, {} with", o.rays, s.rays);
}

#[test]
fn a_scene_that_needs_only_direct_light_has_no_roulette_in_either_kernel() {
    // One dark sphere: path depth 1 (light scatters once), so roulette, which would start at
    // depth 1, is off — also in the general kernel, which runs to depth 8.
    let one = r#"
[camera]
position = [0, 0, 4]
look_at = [0, 0, 0]
fov = 40
[background]
type = "constant"
color = [1, 1, 1]
[materials.dark]
type = "diffuse"
color = [0.3, 0.3, 0.3]
[[spheres]]
center = [0, 0, 0]
radius = 1
material = "dark"
"#;
    let scene = scene("one-dark.toml", one);
    let e = scene.effects();
    assert!(!e.indirect, "{e}");
    assert_eq!(roulette::auto_start(&e, 8), None);
    let (spec, s) = common::render_embree(&scene, &small(RrDepth::Auto));
    let (general, g) = common::render_embree(&scene, &RenderSettings { specialize: false, ..small(RrDepth::Auto) });
    assert_eq!((s.plan.path_depth, g.plan.path_depth), (1, 8));
    // (Roulette from depth 1 in the general kernel alone would change the weight of the sky
    // found after the first bounce: the images would differ.)
    assert!(bits(&spec) == bits(&general), "the specialised kernel's image differs from the general kernel's");
    assert_eq!((s.plan.roulette_start, g.plan.roulette_start), (None, None));
}

#[test]
fn an_explicit_choice_wins_over_the_scene() {
    let dim = scene("dim-explicit.toml", DIM);
    let (_, s) = common::render_embree(&dim, &small(RrDepth::After(5)));
    assert_eq!(s.plan.roulette_start, Some(5));
    let (_, s) = common::render_embree(&dim, &small(RrDepth::Off));
    assert_eq!(s.plan.roulette_start, None);
    // The scene file's own value wins over auto, and the command line over the scene file.
    let with_file_value = scene("dim-file.toml", &format!("[render]\nrr_depth = 6\n{DIM}"));
    assert_eq!(with_file_value.render.rr_depth, Some(RrDepth::After(6)));
    let off = scene("dim-file-off.toml", &format!("[render]\nrr_depth = \"off\"\n{DIM}"));
    assert_eq!(off.render.rr_depth, Some(RrDepth::Off));
    let auto = scene("dim-file-auto.toml", &format!("[render]\nrr_depth = \"auto\"\n{DIM}"));
    assert_eq!(auto.render.rr_depth, Some(RrDepth::Auto));
    let bad =
        Scene::load(&common::write_scene("rr-auto", "dim-bad.toml", &format!("[render]\nrr_depth = \"never\"\n{DIM}")));
    let msg = bad.unwrap_err().to_string();
    assert!(msg.contains("expected a number of bounces, \"off\" or \"auto\", found \"never\""), "{msg}");
}

/// The `kernel:` line a render of `scene` prints with `extra` arguments, on the scalar path
/// loop (whose line ends with the roulette; `tests/path_loops.rs` checks the loop's words).
fn kernel_line(scene: &std::path::Path, extra: &[&str]) -> String {
    let out = common::fresh_dir("rr-auto", &format!("line-{}", extra.join("_"))).join("out.exr");
    let args =
        ["render", scene.to_str().unwrap(), "-o", out.to_str().unwrap(), "--width", "8", "--height", "6", "--spp", "1"];
    let o = ember(&[&args[..], &["--path-loop", "scalar"], extra].concat());
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{err}");
    err.lines().find(|l| l.starts_with("kernel:")).unwrap_or_else(|| panic!("no kernel line in {err}")).to_string()
}

#[test]
fn the_kernel_line_states_where_roulette_starts_and_why() {
    let dim = common::write_scene("rr-auto", "dim-cli.toml", DIM);
    let auto = "; path depth 8 (--max-depth); russian roulette from depth 4 (scene albedo ≤ 0.50)";
    assert!(kernel_line(&dim, &[]).ends_with(auto), "{}", kernel_line(&dim, &[]));
    assert!(kernel_line(&dim, &["--rr-depth", "auto"]).ends_with(auto));
    assert!(kernel_line(&dim, &["--no-specialize"]).ends_with(auto), "the general kernel uses the same start");
    assert!(kernel_line(&dim, &["--rr-depth", "3"]).ends_with("; russian roulette from depth 3 (--rr-depth 3)"));
    assert!(kernel_line(&dim, &["--rr-depth", "off"]).ends_with("; russian roulette off (--rr-depth off)"));
    assert!(kernel_line(&dim, &["--max-depth", "2"]).ends_with(
        "; path depth 2 (--max-depth); russian roulette off (scene albedo ≤ 0.50: it would start at depth 4, the path depth is 2)"
    ));

    let cornell = common::scene_path("cornell-area.toml");
    assert!(
        kernel_line(&cornell, &[])
            .ends_with("; russian roulette off (scene albedo 1.00: throughput never falls to 1/10)"),
        "{}",
        kernel_line(&cornell, &[])
    );

    // `ember info` prints the same line, with the scene's own settings.
    let o = ember(&["info", common::scene_path("teapot.toml").to_str().unwrap()]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success());
    assert!(
        out.lines().any(|l| l.starts_with("kernel:")
            && l.ends_with(
                "; russian roulette off (scene albedo ≤ 0.75: it would start at depth 9, the path depth is 8)"
            )),
        "{out}"
    );
}

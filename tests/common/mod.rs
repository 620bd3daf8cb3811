//! Shared helpers for the integration tests.
#![allow(dead_code)]

use ember::accel::EmbreeAccel;
use ember::embree::{BuildOptions, Device};
use ember::film::Film;
use ember::geometry::{Cylinder, Geometry, Sphere};
use ember::integrator::{RenderSettings, RenderStats, render};
use ember::sampler::Rng;
use ember::scene::Scene;
use glam::Vec3;
use std::path::PathBuf;
use std::process::{Command, Output};
use std::sync::Arc;

/// Runs the `ember` binary with `args` and waits for it.
pub fn ember(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_ember")).args(args).output().expect("ember runs")
}

/// Renders `scene` through Embree (default build) on a new device.
pub fn render_embree(scene: &Scene, settings: &RenderSettings) -> (Film, RenderStats) {
    let device = Device::new().unwrap();
    let accel = EmbreeAccel::new(&device, &scene.geometry, BuildOptions::default()).unwrap();
    render(scene, &accel, settings).unwrap()
}

/// The image through the naive all-primitive loop: pure Rust, so its bits are the same on every
/// x86-64 CPU (Embree's hits differ in the last bits between its AVX2 and AVX-512 kernels).
/// Tests that pin an image's bits render with it.
#[allow(dead_code)]
pub fn render_naive(scene: &Scene, settings: &RenderSettings) -> (Film, RenderStats) {
    render(scene, &ember::accel::NaiveAccel::new(&scene.geometry), settings).unwrap()
}

/// A folder path for one test, `ember-<group>-<name>-<pid>` in the temp dir, with whatever an
/// earlier run left there removed: it does not exist yet.
pub fn fresh_path(group: &str, name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("ember-{group}-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// [`fresh_path`], created empty.
pub fn fresh_dir(group: &str, name: &str) -> PathBuf {
    let d = fresh_path(group, name);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Writes a scene file `name` into a folder shared by the tests of `group` in this process,
/// beside copies of the assets sample scenes refer to (teapot, Cornell box, earth texture).
pub fn write_scene(group: &str, name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("ember-{group}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // Tests of one binary run in parallel and share this folder: every file appears whole, by
    // a rename, so that no test reads another's half-written scene or half-copied asset.
    let put = |dst: &std::path::Path, write: &dyn Fn(&std::path::Path)| {
        static NEXT: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
        let n = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let tmp = dir.join(format!(".partial-{n}"));
        write(&tmp);
        std::fs::rename(&tmp, dst).unwrap();
    };
    for asset in ["teapot.obj", "cornell_box.obj", "cornell_box.mtl", "earthmap.jpg"] {
        let dst = dir.join(asset);
        if !dst.exists() {
            put(&dst, &|tmp| {
                std::fs::copy(scene_path(asset), tmp).unwrap();
            });
        }
    }
    let p = dir.join(name);
    put(&p, &|tmp| std::fs::write(tmp, text).unwrap());
    p
}

/// A 4 × 4 emitter of radiance 3e38 half a unit above a floor: next-event estimation
/// overflows f32 (samples become infinite) and so do pixel sums.
pub const OVERFLOW_SCENE: &str = "[camera]\nposition = [0.0, 0.3, 3.0]\nlook_at = [0.0, 0.0, 0.0]\n\
    [materials.floor]\ntype = \"diffuse\"\n[materials.hot]\ntype = \"emissive\"\nemission = [3.0e38, 3.0e38, 3.0e38]\n\
    [[quads]]\ncorner = [-2.0, 0.0, -2.0]\nedge1 = [0.0, 0.0, 4.0]\nedge2 = [4.0, 0.0, 0.0]\nmaterial = \"floor\"\n\
    [[quads]]\ncorner = [-2.0, 0.5, -2.0]\nedge1 = [4.0, 0.0, 0.0]\nedge2 = [0.0, 0.0, 4.0]\nmaterial = \"hot\"\n";

/// The mean of an image's pixels over its three channels.
pub fn image_mean(pixels: &[Vec3]) -> f64 {
    pixels.iter().map(|p| (p.x + p.y + p.z) as f64 / 3.0).sum::<f64>() / pixels.len() as f64
}

/// Path of a file in `scenes/`.
pub fn scene_path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("scenes").join(name)
}

/// The teapot (6,320 triangles) plus 12 spheres and 8 cylinders of assorted sizes and axes
/// around and inside it.
pub fn teapot_spheres_cylinders() -> Vec<Geometry> {
    let obj = ember::scene::mesh_file::load(&scene_path("teapot.obj"), &ember::memory::LoadBudget::unlimited())
        .expect("teapot loads");
    let mut geometry: Vec<Geometry> = obj.meshes.into_iter().map(|m| Geometry::Mesh(Arc::new(m.mesh))).collect();
    let mut rng = Rng::new(42, 0);
    let mut v = |lo: f32, hi: f32| lo + (hi - lo) * rng.next_f32();
    let spheres: Vec<Sphere> =
        (0..12).map(|_| Sphere::new(Vec3::new(v(-4.0, 4.0), v(-1.0, 4.0), v(-3.0, 3.0)), v(0.05, 1.0))).collect();
    let cylinders: Vec<Cylinder> = (0..8)
        .map(|_| {
            let p0 = Vec3::new(v(-4.0, 4.0), v(-1.0, 4.0), v(-3.0, 3.0));
            let p1 = p0 + Vec3::new(v(-2.0, 2.0), v(-2.0, 2.0), v(-2.0, 2.0));
            Cylinder::new(p0, p1, v(0.02, 0.5))
        })
        .collect();
    geometry.push(Geometry::Spheres(spheres.into()));
    geometry.push(Geometry::Cylinders(cylinders.into()));
    geometry
}

/// Uniform unit vector.
pub fn unit_vector(rng: &mut Rng) -> Vec3 {
    let z = 1.0 - 2.0 * rng.next_f32();
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * std::f32::consts::PI * rng.next_f32();
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// The checkpoint key of `ember render SCENE --width W --height H --spp N --seed S` with the
/// default Embree accelerator: what the command line computes.
pub fn cli_checkpoint_key(
    scene: &std::path::Path,
    width: u32,
    height: u32,
    spp: u32,
    seed: u64,
) -> ember::film::CheckpointKey {
    let scene = Scene::load(scene).unwrap();
    // Adaptive unless the spp is at most one packet, as `ember render` decides.
    let adaptive = ember::integrator::adaptive::by_default(spp);
    let settings = RenderSettings { width, height, spp, seed, adaptive, ..RenderSettings::from_scene(&scene.render) };
    // As `ember render` builds it.
    let accel = ember::accel::AccelKind::Embree.image_key(ember::accel::build_options_for(&scene.geometry));
    ember::integrator::RenderPlan::new(&scene, &settings).checkpoint_key(scene.fingerprint(), &accel)
}

/// An `ember` process started with stderr piped.
pub struct Running {
    pub child: std::process::Child,
    stderr: std::io::BufReader<std::process::ChildStderr>,
    /// What it printed to stderr so far.
    pub seen: String,
}

impl Running {
    /// Wraps a started `child` whose stderr was piped (and taken as `stderr`).
    pub fn from_child(child: std::process::Child, stderr: std::process::ChildStderr) -> Running {
        Running { child, stderr: std::io::BufReader::new(stderr), seen: String::new() }
    }

    /// Starts `c` (stderr piped) and waits until it prints a line starting with `kernel:`:
    /// it is rendering then.
    pub fn start_rendering(c: &mut Command) -> Running {
        let mut child = c.stderr(std::process::Stdio::piped()).spawn().unwrap();
        let stderr = std::io::BufReader::new(child.stderr.take().unwrap());
        let mut r = Running { child, stderr, seen: String::new() };
        r.wait_for_line("kernel:");
        r
    }

    /// Reads stderr until a line starting with `start` (panics at the end of it).
    pub fn wait_for_line(&mut self, start: &str) {
        use std::io::BufRead;
        loop {
            let mut line = String::new();
            let n = self.stderr.read_line(&mut line).unwrap();
            self.seen.push_str(&line);
            assert!(n > 0, "no line starting with {start:?} in: {}", self.seen);
            if line.trim_start_matches('\n').starts_with(start) {
                return;
            }
        }
    }

    /// Sends `signal` (a name for kill: TERM, INT, KILL).
    pub fn signal(&self, signal: &str) {
        let status = Command::new("kill").arg(format!("-{signal}")).arg(self.child.id().to_string()).status().unwrap();
        assert!(status.success());
    }

    /// Waits for the process; its exit status and all it printed to stderr.
    pub fn finish(mut self) -> (std::process::ExitStatus, String) {
        std::io::Read::read_to_string(&mut self.stderr, &mut self.seen).unwrap();
        let status = self.child.wait().unwrap();
        (status, self.seen)
    }
}

/// relMSE of `film` against `reference` (per channel, over the reference² + 0.01, as
/// `ember converge` measures it).
pub fn rel_mse(film: &Film, reference: &Film) -> f64 {
    let sum: f64 = (film.pixels.iter().zip(&reference.pixels))
        .flat_map(|(a, r)| (0..3).map(move |c| ((a[c] - r[c]) as f64).powi(2) / ((r[c] as f64).powi(2) + 0.01)))
        .sum();
    sum / (3 * reference.pixels.len()) as f64
}

/// A closed room (4 × 3 × 4, walls 0.7) lit through a window in its -x wall by a white sky
/// and a small bright "sun" quad outside, whose light falls through the window onto the floor.
pub fn window_room(group: &str) -> Scene {
    let quad = |c: [f32; 3], e1: [f32; 3], e2: [f32; 3], m: &str| {
        format!("[[quads]]\ncorner = {c:?}\nedge1 = {e1:?}\nedge2 = {e2:?}\nmaterial = \"{m}\"\n")
    };
    let mut text = String::from(
        "[camera]\nposition = [1.7, 1.6, 1.7]\nlook_at = [-0.8, 0.9, -0.8]\nfov = 70\n\
         [background]\ntype = \"constant\"\ncolor = [1.0, 1.0, 1.0]\n\
         [materials.wall]\ntype = \"diffuse\"\ncolor = [0.7, 0.7, 0.7]\n\
         [materials.sun]\ntype = \"emissive\"\nemission = [500.0, 500.0, 500.0]\n",
    );
    let (w, h) = (2.0, 3.0);
    for q in [
        quad([-w, 0.0, -w], [0.0, 0.0, 2.0 * w], [2.0 * w, 0.0, 0.0], "wall"),
        quad([-w, h, -w], [2.0 * w, 0.0, 0.0], [0.0, 0.0, 2.0 * w], "wall"),
        quad([-w, 0.0, -w], [2.0 * w, 0.0, 0.0], [0.0, h, 0.0], "wall"),
        quad([-w, 0.0, w], [0.0, h, 0.0], [2.0 * w, 0.0, 0.0], "wall"),
        quad([w, 0.0, -w], [0.0, 0.0, 2.0 * w], [0.0, h, 0.0], "wall"),
        // The -x wall around a window 1.6 wide and 1.2 high.
        quad([-w, 0.0, -w], [0.0, 0.9, 0.0], [0.0, 0.0, 2.0 * w], "wall"),
        quad([-w, 2.1, -w], [0.0, 0.9, 0.0], [0.0, 0.0, 2.0 * w], "wall"),
        quad([-w, 0.9, -w], [0.0, 1.2, 0.0], [0.0, 0.0, 1.2], "wall"),
        quad([-w, 0.9, 0.8], [0.0, 1.2, 0.0], [0.0, 0.0, 1.2], "wall"),
        quad([-5.0, 4.0, -0.5], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], "sun"),
    ] {
        text += &q;
    }
    Scene::load(&write_scene(group, "room.toml", &text)).unwrap_or_else(|e| panic!("{e}"))
}

/// [`window_room`] at 48², depth 6, `spp` samples in every pixel.
pub fn window_room_settings(spp: u32, seed: u64) -> RenderSettings {
    RenderSettings { width: 48, height: 48, spp, seed, max_depth: 6, adaptive: false, ..RenderSettings::default() }
}

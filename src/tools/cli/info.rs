use crate::accel::EmbreeAccel;
use crate::embree::{BuildOptions, Device};
use crate::integrator::RenderPlan;
use crate::memory::{LoadBudget, MemoryLimit};
use crate::scene::Scene;
use crate::settings::RenderSettings;
use crate::tools::{out, say};
use clap::Args;
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct InfoArgs {
    /// Scene file (.toml) or mesh (.obj, .ply, .gltf, .glb).
    pub scene: PathBuf,
    /// Let a model read the files it names (a glTF's buffers and images, an OBJ's MTL
    /// libraries) from outside its own folder, as `ember render --allow-external-files`.
    #[arg(long)]
    pub allow_external_files: bool,
}

pub fn run(args: InfoArgs) -> anyhow::Result<()> {
    let limit = MemoryLimit::from_env().map_err(anyhow::Error::msg)?;
    let scene = Scene::load_within(
        &args.scene,
        &LoadBudget::for_accel(limit, true).with_external_files(args.allow_external_files),
    )?;
    for w in &scene.warnings {
        say!("warning: {w}");
    }
    // The model's counts and bounds; a bare mesh's studio ground has a line of its own.
    let ground_triangles = scene.ground.map_or(0, |g| scene.geometry[g].len());
    let (tris, spheres, cylinders) = scene.primitive_counts();
    let tris = tris - ground_triangles;
    let b = scene.subject_bounds();
    let device = Device::new()?;
    // Warm-up: the first commit in a process also starts Embree's threads.
    drop(EmbreeAccel::new(&device, &[], BuildOptions::default())?);
    // The plan `ember render` would make of this scene, and its build.
    let plan = RenderPlan::new(&scene, &RenderSettings::from_scene(&scene.render));
    let accel = EmbreeAccel::new(&device, &scene.geometry, plan.bvh)?;
    out!("scene:      {}", args.scene.display());
    out!("geometries: {}", scene.geometry.len() - scene.ground.is_some() as usize);
    out!("triangles:  {tris}");
    let mut meshes: Vec<&std::sync::Arc<crate::geometry::TriMesh>> = scene
        .geometry
        .iter()
        .filter_map(|g| if let crate::geometry::Geometry::Instance(i) = g { Some(&i.mesh) } else { None })
        .collect();
    if !meshes.is_empty() {
        let placed = meshes.len();
        meshes.sort_by_key(|m| std::sync::Arc::as_ptr(m));
        meshes.dedup_by(|a, b| std::sync::Arc::ptr_eq(a, b));
        let held: usize = meshes.iter().map(|m| m.triangle_count()).sum();
        out!(
            "instances:  {placed} of {} mesh{} used more than once, held once ({held} triangles)",
            meshes.len(),
            if meshes.len() == 1 { "" } else { "es" }
        );
    }
    out!("spheres:    {spheres}");
    out!("cylinders:  {cylinders}");
    out!(
        "bounds:     ({:.4}, {:.4}, {:.4}) .. ({:.4}, {:.4}, {:.4})",
        b.min.x,
        b.min.y,
        b.min.z,
        b.max.x,
        b.max.y,
        b.max.z
    );
    if scene.ground.is_some() {
        out!(
            "studio:     a sky and a ground plane under the model ({ground_triangles} triangles more): nothing in the file lights it"
        );
    }
    out!(
        "embree:     {} ({} bindings, {}; {} kernels)",
        device.version(),
        device.backend(),
        device.ray_hit_layout(),
        device.kernels()
    );
    out!("{}", plan.effects);
    out!("{plan}");
    out!("lights:     {}", scene.light_set(crate::settings::LightTreeMode::Auto).describe());
    out!(
        "bvh build:  {:.2} ms ({} quality, as ember render builds it); Embree holds {}",
        accel.build_time().as_secs_f64() * 1e3,
        plan.bvh.quality,
        crate::memory::format_bytes(device.memory_in_use())
    );
    let settings = RenderSettings::from_scene(&scene.render);
    out!("{}", camera_lines(&scene, settings.width as f32 / settings.height as f32, None).trim_end());
    Ok(())
}

/// What camera renders `scene` in an image of aspect `aspect`, ending with the `[camera]` table
/// of a scene file that gives the same: the scene's, the automatic one that frames it, or
/// (`given`: the flags that changed it) one made on the command line.
pub(super) fn camera_lines(scene: &Scene, aspect: f32, given: Option<&str>) -> String {
    let spec = scene.camera_spec(aspect);
    let centre = scene.subject_bounds().center();
    // Where it is seen from, as --orbit would say, when it looks at the scene's centre.
    let orbit = (spec.look_at == centre).then(|| {
        let (azimuth, elevation) = crate::camera::orbit_angles(spec.position - centre);
        let d = (spec.position - centre).length();
        format!(" (--orbit {azimuth:.1},{elevation:.1},{d:.4} around the scene's centre)")
    });
    let whose = match (given, scene.camera.is_some()) {
        (Some(flags), _) => format!("camera: set by {flags}{}", orbit.unwrap_or_default()),
        (None, true) => "camera: the scene's".to_string(),
        (None, false) => {
            format!("camera: automatic, framing the scene for a {aspect:.3}:1 image{}", orbit.unwrap_or_default())
        }
    };
    format!("{whose}; as a scene file's lines:\n{}", spec.to_toml())
}

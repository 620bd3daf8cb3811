use crate::accel::{Accel, AccelKind, EmbreeAccel, NaiveAccel};
use crate::camera::Camera;
use crate::embree::{BuildOptions, Device};
use crate::film::{Film, ImageFormat};
use crate::scene::Scene;
use anyhow::Context;
use clap::Args;
use glam::Vec2;
use rayon::prelude::*;
use std::path::PathBuf;
use std::time::Instant;

#[derive(Args, Debug)]
pub struct RenderArgs {
    /// Scene file (.toml) or mesh (.obj).
    pub scene: PathBuf,
    /// Output image (.png or .exr).
    #[arg(short, long)]
    pub output: PathBuf,
    #[arg(long, default_value_t = 640)]
    pub width: u32,
    #[arg(long, default_value_t = 480)]
    pub height: u32,
    /// Intersection strategy.
    #[arg(long, default_value = "embree")]
    pub accel: AccelKind,
}

pub fn run(args: RenderArgs) -> anyhow::Result<()> {
    ImageFormat::from_path(&args.output)?;
    let scene = Scene::load(&args.scene)?;
    for w in &scene.warnings {
        eprintln!("warning: {w}");
    }
    let device;
    let accel: Box<dyn Accel> = match args.accel {
        AccelKind::Embree => {
            device = Device::new()?;
            Box::new(EmbreeAccel::new(&device, &scene.geometry, BuildOptions::default())?)
        }
        AccelKind::Naive => Box::new(NaiveAccel::new(&scene.geometry)),
    };
    let camera = Camera::framing(&scene.bounds(), 40.0, args.width as f32 / args.height as f32);
    let start = Instant::now();
    let (w, h) = (args.width, args.height);
    let pixels = (0..w * h)
        .into_par_iter()
        .map(|i| {
            let film = Vec2::new(((i % w) as f32 + 0.5) / w as f32, ((i / w) as f32 + 0.5) / h as f32);
            let ray = camera.ray(film, Vec2::ZERO);
            Ok(match accel.intersect(&ray, 0.0, f32::INFINITY)? {
                // Eye-light shading of the geometric normal: a preview, not a physical render.
                Some(hit) => glam::Vec3::splat(0.1 + 0.8 * hit.ng.normalize().dot(ray.d).abs()),
                None => glam::Vec3::new(0.05, 0.05, 0.08),
            })
        })
        .collect::<Result<Vec<_>, crate::accel::AccelError>>()?;
    let film = Film { width: w, height: h, pixels };
    film.save(&args.output).with_context(|| "writing the image")?;
    eprintln!("rendered {}x{} in {:.2} s -> {}", w, h, start.elapsed().as_secs_f64(), args.output.display());
    Ok(())
}

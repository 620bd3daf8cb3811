//! `ember render`'s arguments, and the settings they give with a scene's own.

use crate::accel::AccelKind;
use crate::embree::{BuildQuality, Kernels};
use crate::film::{AuxMode, Look, PixelFilter, Tonemap, check_exposure};
use crate::integrator::adaptive;
use crate::scene::format::{MAX_COORDINATE, MAX_IMAGE_SIDE};
use crate::scene::{CameraOverride, Orbit, Scene};
use crate::settings::{
    Caustics, Estimator, Guiding, LightTreeMode, LightVertices, LightVisibility, PathLoop, RenderSettings, RrDepth,
    SamplerKind, Shard,
};
use clap::Args;
use glam::Vec3;
use std::path::PathBuf;
use std::time::Duration;

#[derive(Args, Debug)]
pub struct RenderArgs {
    /// Scene file (.toml) or mesh (.obj, .ply, .gltf, .glb).
    pub scene: PathBuf,
    /// Output image: .png (8-bit sRGB) or .exr (linear float); with --shard, a .shard file.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Samples per pixel [scene's render.spp, else 64]. Above 8 the render is adaptive: it
    /// takes about the time of N samples in every pixel, and spends them where the image is
    /// noisy (see --uniform).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..))]
    pub spp: Option<u32>,
    /// Image width in pixels [scene's render.width, else 640].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=MAX_IMAGE_SIDE as i64))]
    pub width: Option<u32>,
    /// Image height in pixels [scene's render.height, else 480].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=MAX_IMAGE_SIDE as i64))]
    pub height: Option<u32>,
    /// Maximum bounces: 0 = emitters only, 1 = direct light [scene's render.max_depth, else 8].
    #[arg(long)]
    pub max_depth: Option<u32>,
    /// Russian roulette after this many bounces; "off" disables it; "auto" chooses from the
    /// scene's albedo [scene's render.rr_depth, else auto].
    #[arg(long)]
    pub rr_depth: Option<String>,
    /// Connect each path vertex to a light vertex (a surface point lit by a point light or an
    /// area light, sampled from the light) and weigh it by MIS against next-event estimation:
    /// auto, on or off. Auto turns it on where every light is a point light inside the
    /// scene's surfaces (a lamp in a room), and for area lights where most bounces of a pass
    /// of paths before the render stay in the scene (a room lit through its window), where it
    /// lowers the noise of light that bounces off lit surfaces; unbiased either way [scene's
    /// render.light_vertices, else auto].
    #[arg(long)]
    pub light_vertices: Option<LightVertices>,
    /// Trace paths from the lights for the caustics (light that reaches a surface the camera
    /// sees through mirrors and glass only, which paths from the camera find only by chance):
    /// auto (where the scene has mirrors or glass beside diffuse surfaces, lit by area or point
    /// lights) or off; unbiased either way [scene's render.caustics, else auto].
    #[arg(long)]
    pub caustics: Option<Caustics>,
    /// How next-event estimation chooses among many lights: auto (a light tree, by each
    /// light's importance at the shading point, where there are more than a few groups of
    /// lights or an emitting mesh of many triangles) or off (by power); unbiased either way.
    #[arg(long, default_value = "auto")]
    pub light_tree: LightTreeMode,
    /// Where light seen through mirrors or glass lands on a diffuse surface (the floor under a
    /// glass object, seen through it), sample the next direction toward where that light came
    /// from as well as by the surface's BSDF: auto (wherever caustic light paths run, which
    /// find those places) or off; unbiased either way.
    #[arg(long, default_value = "auto")]
    pub guiding: Guiding,
    /// Weigh the choice among a few groups of lights (a lamp and the sky) by how often each
    /// group's light samples got through near the shading point, learned by a short pass
    /// before the render (a room lit through a window: the sky is mostly behind its walls):
    /// auto or off (by importance alone); unbiased either way.
    #[arg(long, default_value = "auto")]
    pub light_visibility: LightVisibility,
    /// Worker threads [all cores].
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..=1024))]
    pub threads: Option<u32>,
    /// Random seed [scene's render.seed, else 0].
    #[arg(long)]
    pub seed: Option<u64>,
    /// Intersection strategy: embree or naive.
    #[arg(long, default_value = "embree")]
    pub accel: AccelKind,
    /// Embree BVH build quality: low, medium or high (`ember bench` measures each) [low for a
    /// scene of at most 1,000 triangles and no spheres or cylinders, else medium].
    #[arg(long)]
    pub bvh_quality: Option<BuildQuality>,
    /// Build the Embree BVH without RTC_SCENE_FLAG_ROBUST, as Embree's own tutorials do:
    /// faster, but a ray passing exactly through an edge shared by two triangles can miss both
    /// (hard case axis-parallel-rays).
    #[arg(long)]
    pub no_robust: bool,
    /// Embree's kernel set: sse4.2, avx, avx2 or avx512 [the widest this CPU runs]. The sets
    /// round hit points differently in the last bits, so shards and checkpoints of different
    /// sets are refused: give every machine of a mixed cluster the widest set they all run.
    #[arg(long, value_parser = parse_kernels)]
    pub embree_kernels: Option<Kernels>,
    /// Adaptive sampling: stop sampling a pixel once its estimated relative error is below
    /// this (e.g. 0.01); --spp is then the most a pixel gets [scene's render.spp, else 1024].
    /// With --denoise, sampling stops on the noisy image's estimated error: that image meets
    /// the target (its estimate of it), and the denoised one is made from it, with no error
    /// bound of its own (it is usually closer, but biased).
    #[arg(long, value_parser = parse_target_error)]
    pub target_error: Option<f32>,
    /// Sample clamp, as Cycles': a sample whose largest channel is above X is scaled down to
    /// X, its hue kept. It removes fireflies (rare, very bright samples) at the price of
    /// bias: the image is darker where light is concentrated (caustics, small bright lights
    /// seen through a bounce). The summary says how many samples it scaled. Try 10–100 times
    /// the image's brightest ordinary pixel [no clamp].
    #[arg(long, value_name = "X", value_parser = parse_clamp)]
    pub clamp: Option<f32>,
    /// Every pixel takes --spp samples. Without it (above 8 spp) sampling is adaptive: a
    /// quarter of --spp in every pixel, the rest where the first samples of each pixel's
    /// neighbours are noisy, for about the time --spp everywhere would take (at most 16×
    /// --spp in one pixel); unbiased, as no pixel decides from its own samples. A shard
    /// renders it in two stages (--first-round, then --plan-from).
    #[arg(long, conflicts_with = "target_error")]
    pub uniform: bool,
    /// Denoise the image with Intel Open Image Denoise, given the albedo and normal of the first
    /// non-specular surface each path reaches [scene's render.denoise, else off]. A PNG gets
    /// the denoised image; an EXR gets it as its main layer, with the noisy image, albedo,
    /// normal and sample count as layers.
    #[arg(long)]
    pub denoise: bool,
    /// How the denoiser uses the albedo and normal images: prefilter (denoised first, OIDN's
    /// advice for final frames), noisy (as they are), clean (as noise-free), or color (not
    /// given: colour only).
    #[arg(long, default_value = "prefilter")]
    pub denoise_aux: AuxMode,
    /// Write the albedo, normal and sample count layers to an .exr output without denoising
    /// (for a denoiser or compositor later).
    #[arg(long)]
    pub aux: bool,
    /// Continue the interrupted render whose checkpoint is next to the output
    /// (<output>.checkpoint); scene and settings must be the same.
    #[arg(long)]
    pub resume: bool,
    /// Also write the checkpoint periodically, e.g. 60s or 5m (it is always written when the
    /// render is interrupted by Ctrl-C or SIGTERM).
    #[arg(long)]
    pub checkpoint_every: Option<CliDuration>,
    /// Rewrite the output image every DURATION (e.g. 5s) with the render so far (black where
    /// no sample has landed yet; not denoised), so an image viewer that reloads shows it
    /// converging. Each preview replaces the file atomically, as the final image does; an
    /// interrupted render leaves its last preview there. The final image is the same.
    #[arg(long, value_name = "DURATION", conflicts_with = "shard")]
    pub preview_every: Option<CliDuration>,
    /// Run the general kernel instead of the one specialised to the scene's effects.
    #[arg(long)]
    pub no_specialize: bool,
    /// Estimator: nee-mis, nee, bsdf or bsdf-uniform.
    #[arg(long, default_value = "nee-mis")]
    pub estimator: Estimator,
    /// Where samples get their numbers: sobol (an Owen-scrambled Sobol sequence per pixel)
    /// or independent [scene's render.sampler, else sobol].
    #[arg(long)]
    pub sampler: Option<SamplerKind>,
    /// How paths are advanced: scalar (one at a time), wavefront (a tile's paths in a batch,
    /// stage by stage; without glossy or glass materials or light vertices, vertices shaded
    /// eight at a time) or auto (wavefront where it shades in lanes, else scalar). The image
    /// is the same, bit for bit.
    #[arg(long, default_value = "auto")]
    pub path_loop: PathLoop,
    /// Fail (exit 2, no image written) if any sample was NaN or infinite, or if nothing in the
    /// scene emits light (the image would be black).
    #[arg(long)]
    pub strict: bool,
    /// Exposure in stops for PNG output: linear values are multiplied by 2^EV before the tone
    /// curve (EXR output stays linear and unscaled) [scene's render.exposure, else 0].
    #[arg(long, value_name = "EV", allow_negative_numbers = true, value_parser = parse_exposure)]
    pub exposure: Option<f32>,
    /// Tone curve for PNG output: clamp (values above 1 clipped), aces (Narkowicz's ACES fit)
    /// or neutral (Khronos PBR Neutral) [scene's render.tonemap, else clamp].
    #[arg(long)]
    pub tonemap: Option<Tonemap>,
    /// Pixel reconstruction filter: box (uniform over the pixel) or gaussian (σ 0.5 pixel,
    /// radius 1.5: smoother edges, slightly softer), by filter importance sampling
    /// [scene's render.filter, else box].
    #[arg(long)]
    pub filter: Option<PixelFilter>,
    /// Camera position x,y,z, over the scene's [camera] (or the camera that frames a scene or
    /// mesh without one); the aliases are those of Embree's tutorials.
    #[arg(long, value_name = "X,Y,Z", visible_alias = "vp", allow_hyphen_values = true, value_parser = parse_point)]
    pub camera_position: Option<Vec3>,
    /// The point the camera looks at, x,y,z.
    #[arg(long, value_name = "X,Y,Z", visible_alias = "vi", allow_hyphen_values = true, value_parser = parse_point)]
    pub look_at: Option<Vec3>,
    /// The camera's up direction, x,y,z.
    #[arg(long, value_name = "X,Y,Z", visible_alias = "vu", allow_hyphen_values = true, value_parser = parse_direction)]
    pub up: Option<Vec3>,
    /// Vertical field of view in degrees, between 0 and 180 (exclusive).
    #[arg(long, value_name = "DEG", value_parser = parse_fov)]
    pub fov: Option<f32>,
    /// Let a model read the files it names (a glTF's buffers and images, an OBJ's MTL
    /// libraries) from outside its own folder. Without it only files in the model's folder
    /// (or below it) are read, after resolving `..` and links; absolute names and files of
    /// /proc, /sys and /dev never are.
    #[arg(long)]
    pub allow_external_files: bool,
    /// Orbit the centre of the scene's bounds, looking at it: azimuth in degrees about +Y
    /// (0 looks along −Z, 90 along −X), elevation in degrees above the horizontal (90 looks
    /// straight down), and the distance from the centre [as far as frames the scene, as the
    /// automatic camera does].
    #[arg(long, value_name = "AZIMUTH,ELEVATION[,DISTANCE]", allow_hyphen_values = true, value_parser = parse_orbit,
          conflicts_with_all = ["camera_position", "look_at"])]
    pub orbit: Option<Orbit>,
    /// An orthographic camera whose view is WIDTH wide (world units; the height follows the
    /// image's aspect), from the scene's camera position and direction (or --orbit's, or the
    /// automatic camera's).
    #[arg(long, value_name = "WIDTH", value_parser = parse_ortho, conflicts_with = "fov")]
    pub ortho: Option<f32>,
    /// Light the scene with an equirectangular (latitude-longitude) environment image: any
    /// .hdr or .exr (linear radiance) or 8-bit .png or .jpg (sRGB), as from Poly Haven. It
    /// replaces the scene's background; a bare mesh loses its studio ground.
    #[arg(long, value_name = "FILE")]
    pub env: Option<PathBuf>,
    /// Turn the environment DEG degrees about the up axis (+Y).
    #[arg(long, value_name = "DEG", requires = "env", allow_hyphen_values = true, value_parser = parse_env_rotate)]
    pub env_rotate: Option<f32>,
    /// Scale the environment's radiance by S [1].
    #[arg(long, value_name = "S", requires = "env", value_parser = parse_env_strength)]
    pub env_strength: Option<f32>,
    /// Render only shard K of N (0-based) of the image, to a shard file (-o NAME.shard) that
    /// `ember merge` puts together with the others; "auto" takes K and N from Slurm
    /// (SLURM_ARRAY_TASK_ID, SLURM_ARRAY_TASK_COUNT), "auto/N" K from Slurm or a Kubernetes
    /// Indexed Job (JOB_COMPLETION_INDEX). With --aux or --denoise the shard keeps the albedo
    /// and normal sums, and the merge writes their layers (and, for --denoise, denoises). An
    /// adaptive render (the default above 8 spp) takes two stages: --first-round, then
    /// --plan-from; a uniform one may take them too, or one.
    #[arg(long, value_name = "K/N|auto|auto/N")]
    pub shard: Option<String>,
    /// Stage 1 of a shard: render what needs no other shard (an adaptive render's first
    /// round; a uniform render's every sample) to a first-round shard file, which stage 2
    /// (--plan-from) reads.
    #[arg(long, requires = "shard", conflicts_with = "plan_from")]
    pub first_round: bool,
    /// Stage 2 of a shard: the first-round files of all N shards (stage 1's outputs, any
    /// order), from which an adaptive render plans the rest of the image as a whole render
    /// would; the shard then finishes its own pixels. Put it last (it takes every file that
    /// follows).
    #[arg(long, requires = "shard", num_args = 1.., value_name = "FIRST_ROUND_FILES")]
    pub plan_from: Vec<PathBuf>,
}

/// Three comma-separated finite numbers.
fn parse_vec3(s: &str) -> Result<Vec3, String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let numbers: Option<Vec<f32>> = parts.iter().map(|p| p.parse::<f32>().ok().filter(|v| v.is_finite())).collect();
    match numbers {
        Some(v) if v.len() == 3 => Ok(Vec3::new(v[0], v[1], v[2])),
        _ => Err(format!("expected three finite numbers x,y,z (e.g. 0,1.5,-4), found {s:?}")),
    }
}

/// A point: as in a scene file, each coordinate within ±MAX_COORDINATE.
fn parse_point(s: &str) -> Result<Vec3, String> {
    let v = parse_vec3(s)?;
    match v.to_array().into_iter().find(|c| c.abs() > MAX_COORDINATE) {
        Some(c) => Err(format!("coordinates must be between -{MAX_COORDINATE:e} and {MAX_COORDINATE:e}, found {c:e}")),
        None => Ok(v),
    }
}

/// A direction: as a scene file's `up`, three finite numbers.
fn parse_direction(s: &str) -> Result<Vec3, String> {
    parse_vec3(s)
}

/// A vertical field of view: as in a scene file, 0 < fov < 180 degrees.
fn parse_fov(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(v) if v > 0.0 && v < 180.0 => Ok(v),
        _ => Err(format!("expected a field of view in degrees between 0 and 180 (exclusive), found {s:?}")),
    }
}

/// `AZIMUTH,ELEVATION[,DISTANCE]`: finite angles in degrees, the elevation within ±90, and a
/// positive distance.
fn parse_orbit(s: &str) -> Result<Orbit, String> {
    let numbers: Option<Vec<f32>> =
        s.split(',').map(|p| p.trim().parse::<f32>().ok().filter(|v| v.is_finite())).collect();
    let bad = || format!("expected AZIMUTH,ELEVATION[,DISTANCE] in degrees (e.g. 30,20 or 30,20,5), found {s:?}");
    let v = numbers.filter(|v| (2..=3).contains(&v.len())).ok_or_else(bad)?;
    if v[1].abs() > 90.0 {
        return Err(format!("the elevation must be between -90 and 90 degrees, found {}", v[1]));
    }
    let distance = v.get(2).copied();
    if let Some(d) = distance
        && !(d > 0.0 && d <= MAX_COORDINATE)
    {
        return Err(format!("the distance must be positive and at most {MAX_COORDINATE:e}, found {d}"));
    }
    Ok(Orbit { azimuth: v[0], elevation: v[1], distance })
}

/// An environment's turn about +Y: finite degrees.
fn parse_env_rotate(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(format!("expected an angle in degrees (e.g. 90 or -45), found {s:?}")),
    }
}

/// An environment's radiance scale: positive and finite.
fn parse_env_strength(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(v) if v > 0.0 && v.is_finite() => Ok(v),
        _ => Err(format!("expected a positive scale of the radiance (e.g. 0.5 or 2), found {s:?}")),
    }
}

/// An orthographic view's width: a positive length.
fn parse_ortho(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(v) if v > 0.0 && v <= MAX_COORDINATE => Ok(v),
        _ => Err(format!("expected the view's width in world units, a positive number, found {s:?}")),
    }
}

/// The camera parts given on the command line.
pub(super) fn camera_override(args: &RenderArgs) -> CameraOverride {
    CameraOverride {
        position: args.camera_position,
        look_at: args.look_at,
        up: args.up,
        fov: args.fov,
        orbit: args.orbit,
        ortho: args.ortho,
    }
}

/// `--exposure` of `ember render` and `ember merge`: a number of stops in the allowed range.
pub(crate) fn parse_exposure(s: &str) -> Result<f32, String> {
    let v: f32 = s.trim().parse().map_err(|_| format!("expected a number of stops (e.g. 1.5 or -2), found {s:?}"))?;
    check_exposure(v)
}

/// The look of 8-bit output: the command line, then the scene file, then the default.
pub(super) fn look(args: &RenderArgs, scene: &Scene) -> Look {
    Look {
        exposure: args.exposure.or(scene.render.exposure).unwrap_or(0.0),
        tonemap: args.tonemap.or(scene.render.tonemap).unwrap_or_default(),
    }
}

/// The shard `--shard` asks for: `K/N`, or K (and N) from the job engine's environment.
pub(super) fn shard(arg: &str, env: &dyn Fn(&str) -> Option<String>) -> anyhow::Result<Shard> {
    let index_from_env = || -> anyhow::Result<u32> {
        let (name, value) =
            ["SLURM_ARRAY_TASK_ID", "JOB_COMPLETION_INDEX"].iter().find_map(|n| env(n).map(|v| (*n, v))).ok_or_else(
                || anyhow::anyhow!("--shard {arg}: neither SLURM_ARRAY_TASK_ID nor JOB_COMPLETION_INDEX is set"),
            )?;
        value.trim().parse().map_err(|_| anyhow::anyhow!("--shard {arg}: {name}={value:?} is not a shard index"))
    };
    let (index, count) = match arg.split_once('/') {
        _ if arg == "auto" => {
            let count = env("SLURM_ARRAY_TASK_COUNT").ok_or_else(|| {
                anyhow::anyhow!("--shard auto: SLURM_ARRAY_TASK_COUNT is not set (give the count: --shard auto/N)")
            })?;
            let count = count
                .trim()
                .parse::<u32>()
                .map_err(|_| anyhow::anyhow!("--shard auto: SLURM_ARRAY_TASK_COUNT={count:?} is not a count"))?;
            (index_from_env()?, count)
        }
        Some(("auto", n)) => {
            let count = n.parse::<u32>().map_err(|_| anyhow::anyhow!("--shard {arg}: {n:?} is not a count"))?;
            (index_from_env()?, count)
        }
        _ => return arg.parse::<Shard>().map_err(|e| anyhow::anyhow!("--shard: {e}")),
    };
    format!("{index}/{count}").parse::<Shard>().map_err(|e| anyhow::anyhow!("--shard {arg}: {e}"))
}

fn parse_clamp(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(v) if v > 0.0 && v.is_finite() => Ok(v),
        _ => Err(format!("expected a positive radiance (e.g. 10), found {s:?}")),
    }
}

fn parse_kernels(s: &str) -> Result<Kernels, String> {
    let names = || Kernels::ALL.map(Kernels::name).join(", ");
    let k = Kernels::from_name(s).ok_or_else(|| format!("expected one of {}, found {s:?}", names()))?;
    if !k.runs_here() {
        return Err(format!("this CPU cannot run Embree's {k} kernels (the widest it runs: {})", Kernels::widest()));
    }
    Ok(k)
}

fn parse_target_error(s: &str) -> Result<f32, String> {
    match s.parse::<f32>() {
        Ok(e) if e > 0.0 && e < 1.0 => Ok(e),
        _ => Err(format!("expected a relative error between 0 and 1 (e.g. 0.01), found {s:?}")),
    }
}

/// Whether the render is denoised: `--denoise`, or the scene's `[render] denoise = true`.
pub(super) fn denoise(args: &RenderArgs, scene: &Scene) -> bool {
    args.denoise || scene.render.denoise == Some(true)
}

/// Settings from the command line, then the scene file, then built-in defaults.
pub(super) fn settings(args: &RenderArgs, scene: &Scene) -> anyhow::Result<RenderSettings> {
    let s = RenderSettings::from_scene(&scene.render);
    let rr_depth = match args.rr_depth.as_deref() {
        Some(v) => v.parse::<RrDepth>().map_err(|e| anyhow::anyhow!("--rr-depth: {e}"))?,
        None => s.rr_depth,
    };
    let spp = args.spp.or(scene.render.spp).unwrap_or(if args.target_error.is_some() { 1024 } else { s.spp });
    Ok(RenderSettings {
        width: args.width.unwrap_or(s.width),
        height: args.height.unwrap_or(s.height),
        spp,
        max_depth: args.max_depth.unwrap_or(s.max_depth),
        rr_depth,
        seed: args.seed.unwrap_or(s.seed),
        threads: args.threads.map(|t| t as usize),
        estimator: args.estimator,
        specialize: !args.no_specialize,
        target_error: args.target_error,
        adaptive: !args.uniform && args.target_error.is_none() && adaptive::by_default(spp),
        aux: s.aux || args.denoise || args.aux,
        filter: args.filter.unwrap_or(s.filter),
        sampler: args.sampler.unwrap_or(s.sampler),
        light_vertices: args.light_vertices.unwrap_or(s.light_vertices),
        caustics: args.caustics.unwrap_or(s.caustics),
        light_tree: args.light_tree,
        guiding: args.guiding,
        light_visibility: args.light_visibility,
        shard: args.shard.as_deref().map(|a| shard(a, &|name| std::env::var(name).ok())).transpose()?,
        clamp: args.clamp,
        path_loop: args.path_loop,
        bvh_quality: args.bvh_quality,
        robust: !args.no_robust,
        embree_kernels: args.embree_kernels,
    })
}

/// The shortest duration taken: a millisecond (a checkpoint after every pixel, or a duration
/// that rounds to nothing, is not what anyone means).
const MIN_DURATION_SECS: f64 = 0.001;

/// A duration on the command line: `90`, `90s`, `1.5m`, `2h`, `1e-3s`.
#[derive(Clone, Copy, Debug)]
pub struct CliDuration(pub Duration);

impl std::str::FromStr for CliDuration {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        // The unit is the letters at the end (`1e-3s`: the number is `1e-3`).
        let s = s.trim();
        let (num, unit) = s.split_at(s.trim_end_matches(|c: char| c.is_ascii_alphabetic()).len());
        let scale = match unit {
            "" | "s" => 1.0,
            "m" | "min" => 60.0,
            "h" => 3600.0,
            _ => return Err(format!("unknown unit {unit:?} in {s:?} (use s, m or h)")),
        };
        let v: f64 = num.trim().parse().map_err(|_| format!("expected a duration such as 60s or 5m, found {s:?}"))?;
        let secs = v * scale;
        if !(secs > 0.0 && secs < 1e9) {
            return Err(format!("duration {s:?} must be positive and less than 1e9 s"));
        }
        if secs < MIN_DURATION_SECS {
            return Err(format!("duration {s:?} is too short: at least {MIN_DURATION_SECS}s"));
        }
        Ok(CliDuration(Duration::from_secs_f64(secs)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn env<'a>(vars: &'a [(&'a str, &'a str)]) -> impl Fn(&str) -> Option<String> + 'a {
        move |name| vars.iter().find(|(n, _)| *n == name).map(|(_, v)| v.to_string())
    }

    #[test]
    fn orbits_parse_with_or_without_a_distance() {
        assert_eq!(parse_orbit("30,-20").unwrap(), Orbit { azimuth: 30.0, elevation: -20.0, distance: None });
        assert_eq!(
            parse_orbit(" -45, 90, 2.5").unwrap(),
            Orbit { azimuth: -45.0, elevation: 90.0, distance: Some(2.5) }
        );
        for (bad, why) in [
            ("30", "expected AZIMUTH,ELEVATION"),
            ("1,2,3,4", "expected AZIMUTH,ELEVATION"),
            ("a,b", "expected AZIMUTH,ELEVATION"),
            ("0,91", "between -90 and 90"),
            ("0,0,0", "positive"),
            ("0,0,-1", "positive"),
        ] {
            let e = parse_orbit(bad).unwrap_err();
            assert!(e.contains(why), "{bad}: {e}");
        }
    }

    #[test]
    fn the_shard_comes_from_the_flag_or_the_job_engine() {
        let none = env(&[]);
        assert_eq!(shard("2/4", &none).unwrap(), Shard { index: 2, count: 4 });
        let slurm = env(&[("SLURM_ARRAY_TASK_ID", "3"), ("SLURM_ARRAY_TASK_COUNT", "5")]);
        assert_eq!(shard("auto", &slurm).unwrap(), Shard { index: 3, count: 5 });
        assert_eq!(shard("auto/8", &slurm).unwrap(), Shard { index: 3, count: 8 });
        let k8s = env(&[("JOB_COMPLETION_INDEX", "6")]);
        assert_eq!(shard("auto/7", &k8s).unwrap(), Shard { index: 6, count: 7 });
        for (arg, vars, needle) in [
            ("auto", &k8s as &dyn Fn(&str) -> Option<String>, "SLURM_ARRAY_TASK_COUNT is not set"),
            ("auto/4", &none, "neither SLURM_ARRAY_TASK_ID nor JOB_COMPLETION_INDEX is set"),
            ("auto/7", &env(&[("JOB_COMPLETION_INDEX", "7")]), "expected K/N with 0 <= K < N"),
            ("auto/x", &k8s, "\"x\" is not a count"),
            ("4/4", &none, "expected K/N"),
        ] {
            let e = shard(arg, vars).unwrap_err().to_string();
            assert!(e.contains(needle), "{arg}: {e}");
        }
    }
}

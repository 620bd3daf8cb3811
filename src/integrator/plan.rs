//! The render plan: what a render of a given scene with given settings runs, worked out once.
//!
//! The settings are requests ([`RenderSettings`]); the plan holds what is in force for this
//! scene: the kernel (specialised to the scene's [`Effects`], or the general one), the path
//! depth (the user's `max_depth`, or less where the scene cannot use more), and the depth from
//! which Russian roulette runs — each with how it was decided, which is what its
//! [`Display`](fmt::Display) prints (`ember render` and `ember info` show that line). The
//! render loop, the checkpoint key and the summary read the plan; nothing else works these
//! out again.

use super::kernel::KernelChoice;
use super::roulette::{auto_start, throughput_depth};
use crate::accel::build_options_with;
use crate::embree::BuildOptions;
use crate::film::CheckpointKey;
use crate::geometry::Geometry;
use crate::scene::{DepthLimit, Effects, Scene};
use crate::settings::{Estimator, LightVertices, PathLoop, RenderSettings, RrDepth};
use std::fmt;

/// What a render runs. See the module documentation.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderPlan {
    /// The requests the plan was made from.
    pub settings: RenderSettings,
    /// What the scene analysis found.
    pub effects: Effects,
    /// The kernel that runs.
    pub kernel: KernelChoice,
    /// The most bounces a path takes: the user's `max_depth`, or less where the scene cannot
    /// use more and the kernel is specialised.
    pub path_depth: u32,
    /// The depth the scene can use (at most `max_depth`), whichever kernel runs: the
    /// automatic roulette start is judged against it.
    pub scene_depth: u32,
    /// Russian roulette runs after this many bounces (`None`: never).
    pub roulette_start: Option<u32>,
    /// Paths connect to light vertices (`super::light_vertex`).
    pub light_vertices: bool,
    /// Light paths carry the caustics (`super::caustic`).
    pub caustics: bool,
    /// Diffuse vertices sample toward caustic light too (`super::guide`).
    pub guiding: bool,
    /// Where lights are chosen among a few groups by importance, the choice is weighed by
    /// where light samples get through (`super::visibility`).
    pub light_visibility: bool,
    /// How the Embree BVH is built: the requested quality, else the one the geometry calls for
    /// ([`crate::accel::build_quality_for`]), robust unless told otherwise.
    pub bvh: BuildOptions,
}

/// Samples every pixel takes before its error estimate is trusted (rounds with a target error).
const MIN_ADAPTIVE_SPP: u32 = 16;

impl RenderPlan {
    /// How many rounds of samples the render takes: one (uniform), two (adaptive: the first
    /// round everywhere, then the plan's), or with a target error the first round and the
    /// doublings from it up to `spp`.
    pub fn rounds(&self) -> u32 {
        let settings = &self.settings;
        if settings.adaptive {
            return 2;
        }
        match settings.target_error {
            None => 1,
            Some(_) => {
                let min = MIN_ADAPTIVE_SPP.min(settings.spp).max(1);
                // Doublings from `min` until `spp` is reached, plus the first round.
                1 + (settings.spp.div_ceil(min)).next_power_of_two().trailing_zeros()
            }
        }
    }

    /// How many samples pixel state `p` should have at the end of round `round`, or `None` if it
    /// takes no part in that round.
    pub(crate) fn round_target(&self, round: u32, p: &crate::film::PixelState, allocated: Option<u32>) -> Option<u32> {
        let settings = &self.settings;
        if settings.adaptive {
            let target = if round == 0 { super::adaptive::first_round_spp(settings.spp) } else { allocated? };
            return (p.count < target).then_some(target);
        }
        let Some(e) = settings.target_error else {
            return (round == 0 && p.count < settings.spp).then_some(settings.spp);
        };
        let min = MIN_ADAPTIVE_SPP.min(settings.spp);
        let target_of = |r: u32| min.saturating_mul(1u32.checked_shl(r).unwrap_or(u32::MAX)).min(settings.spp);
        let target = target_of(round);
        // A pixel with more samples than the last round's target was stopped inside this round
        // (by a signal): it was taking part, decided at the round's start, so it goes on; its
        // error estimate now would decide on other samples. (Never so in a render not stopped.)
        let inside = round > 0 && p.count > target_of(round - 1);
        let needs = p.count < min || inside || p.relative_error() > e as f64;
        (p.count < target && needs).then_some(target)
    }

    /// The plan for `scene` rendered with `settings` (analyses the scene).
    pub fn new(scene: &Scene, settings: &RenderSettings) -> RenderPlan {
        RenderPlan::for_effects(scene.effects(), &scene.geometry, settings)
    }

    /// The plan for a scene with `effects` and `geometry` rendered with `settings`.
    pub fn for_effects(effects: Effects, geometry: &[Geometry], settings: &RenderSettings) -> RenderPlan {
        let max_depth = settings.max_depth;
        let scene_depth = effects.depth_limit().apply(max_depth);
        let (kernel, path_depth) = if settings.specialize {
            (KernelChoice::for_effects(&effects), scene_depth)
        } else {
            (KernelChoice::GENERAL, max_depth)
        };
        // An estimator setting, not a kernel switch: the same whether specialised or not.
        let roulette_start = match settings.rr_depth {
            RrDepth::Auto => auto_start(&effects, max_depth),
            RrDepth::After(n) => Some(n),
            RrDepth::Off => None,
        };
        let light_vertices = light_vertices_apply(&effects, settings, scene_depth).is_ok();
        let caustics = caustics_apply(&effects, settings, scene_depth).is_ok();
        let guiding = guiding_apply(caustics, light_vertices, settings).is_ok();
        // Point lights' vertices weigh their connections by the choice by importance alone.
        let light_visibility = settings.light_visibility == crate::settings::LightVisibility::Auto
            && !(light_vertices && effects.point_lights);
        RenderPlan {
            settings: settings.clone(),
            effects,
            kernel,
            path_depth,
            scene_depth,
            roulette_start,
            light_vertices,
            caustics,
            guiding,
            light_visibility,
            bvh: BuildOptions {
                kernels: settings.embree_kernels.unwrap_or_else(crate::embree::Kernels::widest),
                ..build_options_with(geometry, settings.bvh_quality, settings.robust)
            },
        }
    }

    /// The most samples one pixel takes: `spp`, or in an adaptive render its cap.
    pub fn max_pixel_spp(&self) -> u32 {
        let s = &self.settings;
        if s.adaptive { super::adaptive::max_spp(s.spp) } else { s.spp }
    }

    /// What a checkpoint of this render must match: the scene's fingerprint
    /// ([`Scene::fingerprint`]), the image size and spp, and everything else that changes the
    /// image as `key=value` words — the requests that matter (the pixel filter among them), the
    /// roulette start in force and
    /// the accelerator with its build options (`accel`: [`crate::accel::Accel::image_key`]);
    /// the thread count and kernel choice do not change the image — and, for a shard, which
    /// one. A render that takes the auxiliary images adds `aux=albedo+normal` (not an image
    /// setting, but its checkpoint holds their sums too). A checkpoint records this and resumes
    /// only against the same.
    pub fn checkpoint_key(&self, scene_fingerprint: u64, accel: &str) -> CheckpointKey {
        let s = &self.settings;
        let mut settings = self.image_key(accel);
        if let Some(shard) = s.shard {
            settings += &format!(" shard={shard}");
        }
        if s.aux {
            settings.push_str(" aux=albedo+normal");
        }
        let spp = self.max_pixel_spp();
        CheckpointKey {
            scene: scene_fingerprint,
            settings,
            width: s.width,
            height: s.height,
            spp,
            aux: s.aux,
            adaptive: s.adaptive,
            light: self.caustics,
        }
    }

    /// The settings that change the image (all but the shard), as `key=value` words; `accel`
    /// names the accelerator and its build. The shards of one image all have these.
    pub fn image_key(&self, accel: &str) -> String {
        let s = &self.settings;
        let rr = self.roulette_start.map_or("off".to_string(), |d| d.to_string());
        let te = s.target_error.map_or("none".to_string(), |e| e.to_string());
        format!(
            "width={} height={} spp={} max-depth={} rr-depth={rr} seed={} estimator={} sampler={} target-error={te} filter={} {accel}",
            s.width, s.height, s.spp, s.max_depth, s.seed, s.estimator, s.sampler, s.filter
        ) + if s.adaptive { " adaptive=relmse-5x5" } else { "" }
            + if self.light_vertices { " light-vertices=pool-by-depth" } else { "" }
            + if self.caustics { " caustics=light-paths" } else { "" }
            + if self.guiding { " guiding=caustic-cones" } else { "" }
            + &s.clamp.map_or(String::new(), |c| format!(" clamp={c}"))
            + if s.light_tree == crate::settings::LightTreeMode::Off { " light-tree=off" } else { "" }
            + if s.light_visibility == crate::settings::LightVisibility::Off { " light-visibility=off" } else { "" }
    }

    /// The most rays one sample traces: its camera ray, and at each of its at most
    /// `path_depth + 1` vertices a shadow ray, a connection to a light vertex, the next ray
    /// and a ray of the auxiliary images' (with room to spare). Bounds what a checkpoint or a
    /// first round may say a pixel's samples traced.
    pub fn max_rays_per_sample(&self) -> u64 {
        4 * (self.path_depth as u64 + 2)
    }

    /// Whether light vertices, if the pass before the render finds the scene enclosed, come
    /// from area lights (no point light: `light_vertices_apply`).
    pub fn light_vertices_from_surfaces(&self) -> bool {
        self.light_vertices && !self.effects.point_lights
    }

    /// Whether the wavefront loop (asked for, or chosen by `--path-loop auto`) shades this
    /// render's vertices eight at a time (`super::lanes`) where no light vertices run: the
    /// kernel has neither glossy nor glass materials (so no caustic guiding either) and
    /// next-event estimation runs with MIS or alone (not the uniform-hemisphere estimator).
    pub fn lane_shading(&self) -> bool {
        self.settings.path_loop != PathLoop::Scalar
            && !self.kernel.glossy
            && !self.kernel.glass
            && self.settings.estimator != Estimator::BsdfUniform
    }

    /// Whether anything in the scene emits light; without light every sample is exactly zero
    /// and the specialised render traces no ray.
    pub fn traces_nothing(&self) -> bool {
        self.settings.specialize && !self.effects.lit
    }

    fn depth_text(&self) -> String {
        let (used, max_depth) = (self.path_depth, self.settings.max_depth);
        if used == max_depth {
            return format!("{used} (--max-depth)");
        }
        match self.effects.depth_limit() {
            DepthLimit::EmittersOnly => {
                format!("{used} (nothing scatters light: emitters only; --max-depth {max_depth})")
            }
            DepthLimit::DirectOnly => {
                format!("{used} (direct light only: nothing can bounce light onward; --max-depth {max_depth})")
            }
            DepthLimit::Unbounded => format!("{used}"),
        }
    }

    fn roulette_text(&self) -> String {
        let albedo = self.effects.albedo;
        match (self.settings.rr_depth, self.roulette_start) {
            (RrDepth::Off, _) => "russian roulette off (--rr-depth off)".to_string(),
            (RrDepth::After(n), _) => format!("russian roulette from depth {n} (--rr-depth {n})"),
            (RrDepth::Auto, Some(k)) => format!("russian roulette from depth {k} (scene albedo ≤ {albedo:.2})"),
            (RrDepth::Auto, None) => {
                let why = match throughput_depth(albedo) {
                    _ if !self.effects.scattering => "nothing scatters light".to_string(),
                    None => format!(
                        "scene albedo {albedo:.2}: throughput never falls to 1/{:.0}",
                        1.0 / super::roulette::RR_THROUGHPUT
                    ),
                    Some(k) => format!(
                        "scene albedo ≤ {albedo:.2}: it would start at depth {k}, the path depth is {}",
                        self.scene_depth
                    ),
                };
                format!("russian roulette off ({why})")
            }
        }
    }
}

/// Why light vertices from area lights may run: the render decides after its first pass.
const BY_THE_PASS: &str = "from the area lights if most bounces of a pass of paths stay in the scene";

/// Whether a render connects paths to light vertices (`Ok`, with why; from area lights, if
/// the pass before the render finds the scene enclosed) or not (`Err`, why not).
fn light_vertices_apply(effects: &Effects, s: &RenderSettings, scene_depth: u32) -> Result<&'static str, &'static str> {
    let asked = match s.light_vertices {
        LightVertices::Off => return Err("--light-vertices off"),
        LightVertices::On => "--light-vertices on",
        LightVertices::Auto => "every light is a point light inside the scene",
    };
    let points = effects.point_lights && !(effects.emissive || effects.sky || effects.environment);
    let surfaces = effects.area_lights && !effects.point_lights;
    if !(points || surfaces) {
        Err("not every light is a point light or an area light")
    } else if s.estimator != Estimator::NeeMis {
        Err("only with --estimator nee-mis")
    } else if scene_depth < 2 {
        Err("no light bounces")
    } else if surfaces && caustics_apply(effects, s, scene_depth).is_ok() {
        Err("area lights with caustic light paths")
    } else if s.light_vertices == LightVertices::Auto && surfaces {
        Ok(BY_THE_PASS)
    } else if s.light_vertices == LightVertices::Auto && !effects.enclosed_point_lights {
        Err("a point light is outside the scene's surfaces")
    } else {
        Ok(asked)
    }
}

/// Whether light paths carry a render's caustics (`Ok`, with why) or not (`Err`, why not).
fn caustics_apply(effects: &Effects, s: &RenderSettings, scene_depth: u32) -> Result<&'static str, &'static str> {
    if s.caustics == crate::settings::Caustics::Off {
        Err("--caustics off")
    } else if !(effects.mirror || effects.glass) {
        Err("no mirror or glass")
    } else if !effects.specular_material {
        Err("no material is a mirror or glass all over")
    } else if !effects.diffuse {
        Err("no diffuse surface to land on")
    } else if !(effects.area_lights || effects.point_lights) {
        Err("no area or point light")
    } else if s.estimator != Estimator::NeeMis {
        Err("only with --estimator nee-mis")
    } else if scene_depth < 2 {
        Err("no light bounces")
    } else if effects.orthographic {
        Err("an orthographic camera")
    } else {
        Ok("mirrors or glass, lit by area or point lights")
    }
}

/// Whether diffuse vertices sample toward caustic light (`Ok`, with why) or not (`Err`, why
/// not), given whether caustic light paths and light vertices run.
fn guiding_apply(caustics: bool, light_vertices: bool, s: &RenderSettings) -> Result<&'static str, &'static str> {
    if !caustics {
        Err("no caustic light paths")
    } else if s.guiding == crate::settings::Guiding::Off {
        Err("--guiding off")
    } else if light_vertices {
        Err("with light vertices")
    } else {
        Ok("toward where the light paths landed")
    }
}

/// `kernel: …; path depth N (why); russian roulette …` (and `; wavefront path loop` if so),
/// then, where there are point or area lights, `light vertices: on|off (why)`, and where the
/// scene has mirrors or glass, `caustic light paths: on|off (why)` and, where they run,
/// `caustic guiding: on|off (why)`, each on a line of its own.
impl fmt::Display for RenderPlan {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "kernel: {}; path depth {}; {}", self.kernel, self.depth_text(), self.roulette_text())?;
        let light_vertices = light_vertices_apply(&self.effects, &self.settings, self.scene_depth);
        let lanes = self.lane_shading() && (!self.light_vertices || light_vertices == Ok(BY_THE_PASS));
        let unless = if self.light_vertices { " if no light vertices run" } else { "" };
        match self.settings.path_loop {
            PathLoop::Scalar => {}
            PathLoop::Wavefront if lanes => {
                write!(f, "; wavefront path loop (Lambertian vertices 8 at a time{unless})")?
            }
            PathLoop::Wavefront => write!(f, "; wavefront path loop")?,
            PathLoop::Auto if lanes => write!(f, "; wavefront path loop (Lambertian vertices 8 at a time){unless}")?,
            PathLoop::Auto => {}
        }
        if self.effects.point_lights || self.effects.area_lights {
            match light_vertices {
                Ok(BY_THE_PASS) => write!(f, "\nlight vertices: {BY_THE_PASS}")?,
                Ok(why) => write!(f, "\nlight vertices: on ({why})")?,
                Err(why) => write!(f, "\nlight vertices: off ({why})")?,
            }
        }
        if self.effects.mirror || self.effects.glass {
            match caustics_apply(&self.effects, &self.settings, self.scene_depth) {
                Ok(why) => write!(f, "\ncaustic light paths: on ({why})")?,
                Err(why) => write!(f, "\ncaustic light paths: off ({why})")?,
            }
            if self.caustics {
                match guiding_apply(self.caustics, self.light_vertices, &self.settings) {
                    Ok(why) => write!(f, "\ncaustic guiding: on ({why})")?,
                    Err(why) => write!(f, "\ncaustic guiding: off ({why})")?,
                }
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scattering(albedo: f32) -> Effects {
        Effects { scattering: true, indirect: true, lit: true, albedo, ..Effects::default() }
    }

    fn plan(e: Effects, rr_depth: RrDepth, specialize: bool) -> RenderPlan {
        RenderPlan::for_effects(e, &[], &RenderSettings { rr_depth, specialize, ..RenderSettings::default() })
    }

    #[test]
    fn the_plan_decides_the_bvh_build_from_the_geometry_and_the_request() {
        use crate::embree::BuildQuality;
        let build = |geometry: &[Geometry], bvh_quality, robust| {
            let settings = RenderSettings { bvh_quality, robust, ..RenderSettings::default() };
            RenderPlan::for_effects(scattering(0.5), geometry, &settings).bvh
        };
        // Unasked, the quality the geometry calls for (low for a small scene), robust.
        let small = build(&[], None, true);
        assert_eq!((small.quality, small.robust, small.compact), (BuildQuality::Low, true, false));
        // A sphere is user geometry: medium.
        let sphere = Geometry::Spheres(vec![crate::geometry::Sphere::new(glam::Vec3::ZERO, 1.0)].into());
        assert_eq!(build(&[sphere], None, true).quality, BuildQuality::Medium);
        // Asked for, as `ember render --bvh-quality high --no-robust`.
        let asked = build(&[], Some(BuildQuality::High), false);
        assert_eq!((asked.quality, asked.robust), (BuildQuality::High, false));
    }

    #[test]
    fn the_users_choice_wins() {
        let dark = scattering(0.2);
        assert_eq!(plan(dark, RrDepth::Auto, true).roulette_start, Some(2));
        assert_eq!(plan(dark, RrDepth::After(3), true).roulette_start, Some(3));
        assert_eq!(plan(dark, RrDepth::Off, true).roulette_start, None);
        let white = scattering(1.0);
        assert_eq!(plan(white, RrDepth::Auto, true).roulette_start, None);
        assert_eq!(plan(white, RrDepth::After(2), true).roulette_start, Some(2));
    }

    #[test]
    fn the_general_kernel_runs_to_the_users_depth_with_the_scenes_roulette() {
        let direct = Effects { indirect: false, ..scattering(0.2) };
        let spec = plan(direct, RrDepth::Auto, true);
        let general = plan(direct, RrDepth::Auto, false);
        assert_eq!((spec.path_depth, general.path_depth), (1, 8));
        assert_eq!((spec.scene_depth, general.scene_depth), (1, 1));
        assert_eq!((spec.roulette_start, general.roulette_start), (None, None));
        assert_eq!(general.kernel, KernelChoice::GENERAL);
        assert_eq!(
            spec.to_string(),
            "kernel: lens off, textures off, glossy off, glass off, hit lights off; path depth 1 (direct light \
             only: nothing can bounce light onward; --max-depth 8); russian roulette off (scene albedo ≤ 0.20: it \
             would start at depth 2, the path depth is 1); wavefront path loop (Lambertian vertices 8 at a time)"
        );
        assert_eq!(
            plan(scattering(0.5), RrDepth::Auto, true).to_string(),
            "kernel: lens off, textures off, glossy off, glass off, hit lights off; path depth 8 (--max-depth); \
             russian roulette from depth 4 (scene albedo ≤ 0.50); wavefront path loop (Lambertian vertices 8 at a \
             time)"
        );
    }

    #[test]
    fn the_checkpoint_key_names_the_roulette_start_in_force() {
        let key = plan(scattering(0.5), RrDepth::Auto, true).checkpoint_key(7, "accel=naive");
        assert_eq!(
            key.settings,
            "width=640 height=480 spp=64 max-depth=8 rr-depth=4 seed=0 estimator=nee-mis sampler=sobol target-error=none \
             filter=box accel=naive"
        );
        assert_eq!((key.scene, key.width, key.height, key.spp), (7, 640, 480, 64));
        // The kernel does not change the image, so it is not in the key.
        assert_eq!(plan(scattering(0.5), RrDepth::After(4), false).checkpoint_key(7, "accel=naive"), key);
        // The pixel filter does.
        let gaussian = RenderSettings { filter: crate::film::PixelFilter::Gaussian, ..RenderSettings::default() };
        let other = RenderPlan::for_effects(scattering(0.75), &[], &gaussian).checkpoint_key(7, "accel=naive");
        assert!(other.settings.contains(" filter=gaussian "), "{}", other.settings);
        // So does a sample clamp.
        let clamped = RenderSettings { clamp: Some(10.0), ..RenderSettings::default() };
        let other = RenderPlan::for_effects(scattering(0.75), &[], &clamped).checkpoint_key(7, "accel=naive");
        assert!(other.settings.ends_with(" clamp=10"), "{}", other.settings);
    }
}

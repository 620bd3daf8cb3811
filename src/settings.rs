//! What the user asks of a render: [`RenderSettings`], from the command line over a scene
//! file's `[render]` suggestions ([`RenderDefaults`]) over built-in defaults. These are
//! requests; what a render of a given scene actually runs (the path depth in force, where
//! Russian roulette starts, which kernel) is worked out once from them and the scene, in
//! [`crate::integrator::RenderPlan`].

pub use crate::sampler::SamplerKind;
use std::fmt;
use std::str::FromStr;

/// Which estimator of the rendering equation to use.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Estimator {
    /// Next-event estimation and BSDF sampling combined by MIS (the default).
    #[default]
    NeeMis,
    /// Next-event estimation only; emission found by BSDF sampling is ignored (except after
    /// specular bounces).
    NeeOnly,
    /// BSDF sampling only (point lights then contribute nothing).
    BsdfOnly,
    /// BSDF sampling only, with diffuse surfaces sampled uniformly over the hemisphere
    /// instead of by cosine (the seed paper's estimator; other BSDFs use their own sampling).
    BsdfUniform,
}

impl Estimator {
    pub const ALL: [Estimator; 4] =
        [Estimator::NeeMis, Estimator::NeeOnly, Estimator::BsdfOnly, Estimator::BsdfUniform];

    /// The name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            Estimator::NeeMis => "nee-mis",
            Estimator::NeeOnly => "nee",
            Estimator::BsdfOnly => "bsdf",
            Estimator::BsdfUniform => "bsdf-uniform",
        }
    }
}

crate::choice::named_choice!(Estimator, "estimator");

/// When Russian roulette should start, as asked for (`--rr-depth`, `[render] rr_depth`). The
/// start in force for a scene is [`crate::integrator::RenderPlan::roulette_start`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum RrDepth {
    /// Chosen from the scene (see `crate::integrator::roulette`).
    #[default]
    Auto,
    /// After this many bounces.
    After(u32),
    /// Never.
    Off,
}

impl FromStr for RrDepth {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "auto" => Ok(RrDepth::Auto),
            "off" => Ok(RrDepth::Off),
            _ => s
                .parse()
                .map(RrDepth::After)
                .map_err(|_| format!("expected a number, \"off\" or \"auto\", found {s:?}")),
        }
    }
}

/// `auto`, `off` or the number, as on the command line.
impl fmt::Display for RrDepth {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RrDepth::Auto => f.write_str("auto"),
            RrDepth::After(n) => write!(f, "{n}"),
            RrDepth::Off => f.write_str("off"),
        }
    }
}

/// Whether paths connect to light vertices (`--light-vertices`): surface points lit by a point
/// light, sampled from the light, weighed by MIS against next-event estimation after a bounce
/// (see `crate::integrator::light_vertex`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LightVertices {
    /// Where every light is a point light inside the scene's surfaces.
    #[default]
    Auto,
    /// Wherever every light is a point light.
    On,
    Off,
}

impl FromStr for LightVertices {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "auto" => Ok(LightVertices::Auto),
            "on" => Ok(LightVertices::On),
            "off" => Ok(LightVertices::Off),
            _ => Err(format!("expected \"auto\", \"on\" or \"off\", found {s:?}")),
        }
    }
}

/// Whether light paths from the lights carry the caustics (`--caustics`): light that reaches
/// a surface seen by the camera through mirrors and glass only, which paths from the camera find
/// only by chance (see `crate::integrator::caustic`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Caustics {
    /// Where a material is a mirror or glass all over, some surface is diffuse, and lights emit
    /// from a place (area and point lights), seen by a perspective camera.
    #[default]
    Auto,
    Off,
}

impl Caustics {
    pub const ALL: [Caustics; 2] = [Caustics::Auto, Caustics::Off];

    /// The name on the command line and in scene files.
    pub fn name(self) -> &'static str {
        match self {
            Caustics::Auto => "auto",
            Caustics::Off => "off",
        }
    }
}

crate::choice::named_choice!(Caustics, "caustics setting");

impl fmt::Display for LightVertices {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            LightVertices::Auto => "auto",
            LightVertices::On => "on",
            LightVertices::Off => "off",
        })
    }
}

/// How next-event estimation chooses among many lights (`--light-tree`): by a light tree,
/// the lights' importance at each shading point (`crate::light`'s `tree`), or by power.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LightTreeMode {
    /// A tree where there are more than a few groups of lights or an emitting mesh of many
    /// triangles.
    #[default]
    Auto,
    /// Never: such sets are chosen by power.
    Off,
}

impl FromStr for LightTreeMode {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "auto" => Ok(LightTreeMode::Auto),
            "off" => Ok(LightTreeMode::Off),
            _ => Err(format!("expected \"auto\" or \"off\", found {s:?}")),
        }
    }
}

impl fmt::Display for LightTreeMode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            LightTreeMode::Auto => "auto",
            LightTreeMode::Off => "off",
        })
    }
}

/// Whether diffuse vertices also sample toward where caustic light comes from (`--guiding`;
/// `crate::integrator`'s `guide`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Guiding {
    /// Wherever caustic light paths run (and light vertices do not).
    #[default]
    Auto,
    /// BSDF sampling only.
    Off,
}

impl Guiding {
    pub const ALL: [Guiding; 2] = [Guiding::Auto, Guiding::Off];

    /// The name on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            Guiding::Auto => "auto",
            Guiding::Off => "off",
        }
    }
}

crate::choice::named_choice!(Guiding, "guiding setting");

/// Whether next-event estimation weighs the choice of a light group by how often its samples
/// got through near the shading point (`--light-visibility`; `crate::light::visibility`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LightVisibility {
    /// Wherever lights are chosen among a few groups by importance (and light vertices do not
    /// run).
    #[default]
    Auto,
    /// By importance alone.
    Off,
}

impl LightVisibility {
    pub const ALL: [LightVisibility; 2] = [LightVisibility::Auto, LightVisibility::Off];

    /// The name on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            LightVisibility::Auto => "auto",
            LightVisibility::Off => "off",
        }
    }
}

crate::choice::named_choice!(LightVisibility, "light visibility setting");

/// How the render loop advances its paths (`--path-loop`). Both compute the same image, bit
/// for bit; they differ in speed (docs/performance.md, "Path loops").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PathLoop {
    /// The wavefront loop where it shades the render's vertices in lanes
    /// ([`crate::integrator::RenderPlan::lane_shading`], and no light vertices run), the scalar
    /// loop elsewhere: each where it measures faster.
    #[default]
    Auto,
    /// One path at a time, from its camera ray to its end (`crate::integrator`'s kernels).
    Scalar,
    /// A tile's paths in a batch, advanced stage by stage (`crate::integrator`'s wavefront
    /// loop).
    Wavefront,
}

impl PathLoop {
    pub const ALL: [PathLoop; 3] = [PathLoop::Auto, PathLoop::Scalar, PathLoop::Wavefront];

    /// The name on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            PathLoop::Auto => "auto",
            PathLoop::Scalar => "scalar",
            PathLoop::Wavefront => "wavefront",
        }
    }
}

crate::choice::named_choice!(PathLoop, "path loop");

/// Side of the square tiles an image is rendered in (the last row and column may be cut).
pub const TILE: u32 = 16;

/// One of `count` parts of an image rendered apart (on other machines) and merged after
/// (`ember merge`): shard `index` renders the tiles (tx, ty) with `(tx + ty) % count ==
/// index`, diagonal stripes that spread every part of the image over all shards. Each pixel's
/// samples are the ones a whole render takes, so the merged image is the same bit for bit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    pub index: u32,
    pub count: u32,
}

impl Shard {
    /// Whether this shard renders tile (`tx`, `ty`).
    #[inline]
    pub fn owns_tile(&self, tx: u32, ty: u32) -> bool {
        (tx as u64 + ty as u64) % self.count as u64 == self.index as u64
    }

    /// Whether this shard renders pixel (`x`, `y`).
    #[inline]
    pub fn owns_pixel(&self, x: u32, y: u32) -> bool {
        self.owns_tile(x / TILE, y / TILE)
    }

    /// How many pixels of a `width` x `height` image this shard renders (without going over
    /// them: tile by tile).
    pub fn pixel_count(&self, width: u32, height: u32) -> u64 {
        let side = |t: u32, size: u32| (size - t * TILE).min(TILE) as u64;
        (0..height.div_ceil(TILE))
            .flat_map(|ty| (0..width.div_ceil(TILE)).map(move |tx| (tx, ty)))
            .filter(|&(tx, ty)| self.owns_tile(tx, ty))
            .map(|(tx, ty)| side(tx, width) * side(ty, height))
            .sum()
    }

    /// The pixels (row-major indices, increasing) this shard renders of a `width` x `height`
    /// image.
    pub fn pixels(&self, width: u32, height: u32) -> impl Iterator<Item = usize> + '_ {
        (0..height).flat_map(move |y| {
            (0..width).filter(move |&x| self.owns_pixel(x, y)).map(move |x| y as usize * width as usize + x as usize)
        })
    }
}

/// The most shards an image is split into: the diagonals of tiles of the largest image
/// (16384 × 16384: 1024 × 1024 tiles, 2047 diagonals). More shards would render nothing (each
/// takes whole diagonals), and a merge reads every shard's file.
pub const MAX_SHARDS: u32 = 2 * crate::scene::format::MAX_IMAGE_SIDE.div_ceil(TILE) - 1;

impl FromStr for Shard {
    type Err = String;
    /// `K/N`, 0 ≤ K < N ≤ [`MAX_SHARDS`].
    fn from_str(s: &str) -> Result<Self, String> {
        let bad = || format!("expected K/N with 0 <= K < N (e.g. 0/4), found {s:?}");
        let (k, n) = s.split_once('/').ok_or_else(bad)?;
        let (index, count): (u64, u64) = (k.trim().parse().map_err(|_| bad())?, n.trim().parse().map_err(|_| bad())?);
        if count == 0 || index >= count {
            return Err(bad());
        }
        Shard::new(index, count)
    }
}

impl Shard {
    /// Shard `index` of `count`, or why there is no such shard: `count` is above
    /// [`MAX_SHARDS`] (or `index` not below `count`).
    pub fn new(index: u64, count: u64) -> Result<Shard, String> {
        if count > MAX_SHARDS as u64 {
            return Err(format!(
                "{count} shards: at most {MAX_SHARDS} (the tile diagonals of the largest image, \
                 {side}x{side}; more shards would render nothing)",
                side = crate::scene::format::MAX_IMAGE_SIDE
            ));
        }
        if index >= count {
            return Err(format!("shard {index} of {count}: the index must be below the count"));
        }
        Ok(Shard { index: index as u32, count: count as u32 })
    }
}

/// `K/N`
impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// How to render, as asked for.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    /// The most bounces a path may take (0 shows emitters only, 1 is direct lighting); the
    /// render uses fewer where the scene cannot use them ([`crate::integrator::RenderPlan`]).
    pub max_depth: u32,
    /// When Russian roulette should start.
    pub rr_depth: RrDepth,
    pub seed: u64,
    /// Worker threads (`None`: all cores).
    pub threads: Option<usize>,
    pub estimator: Estimator,
    /// Run the kernel specialised to the scene's effects (`false`: the general kernel).
    pub specialize: bool,
    /// Adaptive sampling: a pixel stops taking samples once the estimated relative standard
    /// error of its mean falls below this (see [`crate::film::PixelState::relative_error`]);
    /// `spp` is then the most any pixel gets.
    pub target_error: Option<f32>,
    /// Adaptive sampling at a fixed budget: `spp` is the mean over the image, and samples go
    /// where the image is noisy ([`crate::integrator::adaptive`]). Not with a shard.
    pub adaptive: bool,
    /// Also accumulate the auxiliary images a denoiser uses: the albedo and shading normal of
    /// the first non-specular surface each camera path reaches (`--denoise`, `--aux`). They
    /// never change the image: the path and its random numbers are the same either way.
    pub aux: bool,
    /// Where a pixel's samples land: the pixel reconstruction filter, sampled.
    pub filter: crate::film::PixelFilter,
    /// Render only this part of the image (`None`: all of it).
    pub shard: Option<Shard>,
    /// Where the samples get their numbers.
    pub sampler: SamplerKind,
    /// Whether paths connect to light vertices.
    pub light_vertices: LightVertices,
    /// Whether light paths carry the caustics.
    pub caustics: Caustics,
    /// Whether many lights are chosen through a light tree.
    pub light_tree: LightTreeMode,
    /// Whether diffuse vertices sample toward caustic light too.
    pub guiding: Guiding,
    /// Whether the light choice is weighed by where light samples get through.
    pub light_visibility: LightVisibility,
    /// A sample clamp, as Cycles' (`--clamp`): a sample whose largest channel is above this is
    /// scaled down to it, its hue kept ([`clamp_sample`]). Biased: it removes fireflies by
    /// removing energy. `None`: no clamp.
    pub clamp: Option<f32>,
    /// How paths are advanced (the image does not depend on it).
    pub path_loop: PathLoop,
    /// The Embree BVH's build quality (`--bvh-quality`; `None`: the one the scene's geometry
    /// calls for, [`crate::accel::build_quality_for`]) and whether it is built robust
    /// (`RTC_SCENE_FLAG_ROBUST`; `--no-robust` clears it). The plan decides the build
    /// ([`crate::integrator::RenderPlan::bvh`]).
    pub bvh_quality: Option<crate::embree::BuildQuality>,
    pub robust: bool,
    /// Embree's kernel set (`--embree-kernels`; `None`: the widest the CPU runs).
    pub embree_kernels: Option<crate::embree::Kernels>,
}

/// Sample `v` under clamp `limit`: scaled by `limit / max channel` where its largest channel
/// exceeds `limit`, so the hue stays; otherwise unchanged. The second value says whether it
/// was scaled.
#[inline]
pub fn clamp_sample(v: glam::Vec3, limit: f32) -> (glam::Vec3, bool) {
    let m = v.max_element();
    if m > limit { (v * (limit / m), true) } else { (v, false) }
}

impl RenderSettings {
    /// The defaults with a scene file's `[render]` values over them.
    pub fn from_scene(r: &RenderDefaults) -> RenderSettings {
        let d = RenderSettings::default();
        RenderSettings {
            width: r.width.unwrap_or(d.width),
            height: r.height.unwrap_or(d.height),
            spp: r.spp.unwrap_or(d.spp),
            max_depth: r.max_depth.unwrap_or(d.max_depth),
            rr_depth: r.rr_depth.unwrap_or(d.rr_depth),
            seed: r.seed.unwrap_or(d.seed),
            aux: r.denoise.unwrap_or(d.aux),
            filter: r.filter.unwrap_or(d.filter),
            sampler: r.sampler.unwrap_or(d.sampler),
            light_vertices: r.light_vertices.unwrap_or(d.light_vertices),
            caustics: r.caustics.unwrap_or(d.caustics),
            ..d
        }
    }
}

impl RenderSettings {
    /// (width, height)
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            width: 640,
            height: 480,
            spp: 64,
            max_depth: 8,
            rr_depth: RrDepth::Auto,
            seed: 0,
            threads: None,
            estimator: Estimator::NeeMis,
            specialize: true,
            target_error: None,
            adaptive: false,
            aux: false,
            filter: crate::film::PixelFilter::Box,
            shard: None,
            sampler: SamplerKind::default(),
            light_vertices: LightVertices::Auto,
            caustics: Caustics::Auto,
            light_tree: LightTreeMode::Auto,
            guiding: Guiding::Auto,
            light_visibility: LightVisibility::Auto,
            clamp: None,
            path_loop: PathLoop::Auto,
            bvh_quality: None,
            robust: true,
            embree_kernels: None,
        }
    }
}

/// Render settings a scene file may suggest (the command line overrides them).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RenderDefaults {
    pub width: Option<u32>,
    pub height: Option<u32>,
    pub spp: Option<u32>,
    pub max_depth: Option<u32>,
    pub rr_depth: Option<RrDepth>,
    pub seed: Option<u64>,
    /// Denoise the image (which needs the auxiliary images).
    pub denoise: Option<bool>,
    /// The look of 8-bit output (not a render setting: the image rendered is the same).
    pub exposure: Option<f32>,
    pub tonemap: Option<crate::film::Tonemap>,
    pub filter: Option<crate::film::PixelFilter>,
    pub sampler: Option<SamplerKind>,
    pub light_vertices: Option<LightVertices>,
    pub caustics: Option<Caustics>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rr_depth_parses_and_prints_as_on_the_command_line() {
        for (s, v) in
            [("auto", RrDepth::Auto), ("off", RrDepth::Off), ("0", RrDepth::After(0)), ("7", RrDepth::After(7))]
        {
            assert_eq!(s.parse::<RrDepth>(), Ok(v));
            assert_eq!(v.to_string(), s);
        }
        assert_eq!("banana".parse::<RrDepth>(), Err("expected a number, \"off\" or \"auto\", found \"banana\"".into()));
        assert!("-1".parse::<RrDepth>().is_err());
    }

    #[test]
    fn a_clamped_sample_keeps_its_hue_and_a_small_one_is_untouched() {
        let (v, scaled) = clamp_sample(glam::Vec3::new(40.0, 20.0, 10.0), 10.0);
        assert!(scaled);
        assert_eq!(v, glam::Vec3::new(10.0, 5.0, 2.5));
        let small = glam::Vec3::new(9.0, 10.0, 0.5);
        assert_eq!(clamp_sample(small, 10.0), (small, false));
    }

    #[test]
    fn shards_parse_and_cover_every_tile_once() {
        assert_eq!("2/7".parse::<Shard>(), Ok(Shard { index: 2, count: 7 }));
        assert_eq!(Shard { index: 2, count: 7 }.to_string(), "2/7");
        for bad in ["7/7", "1/0", "x/2", "3", "-1/2", "1/2/3"] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
        for count in [1, 2, 3, 7] {
            let shards: Vec<Shard> = (0..count).map(|index| Shard { index, count }).collect();
            for ty in 0..9 {
                for tx in 0..13 {
                    assert_eq!(shards.iter().filter(|s| s.owns_tile(tx, ty)).count(), 1);
                }
            }
            let (w, h) = (37, 21);
            let mut all: Vec<usize> = shards.iter().flat_map(|s| s.pixels(w, h)).collect();
            all.sort();
            assert_eq!(all, (0..(w * h) as usize).collect::<Vec<_>>());
            for s in &shards {
                assert_eq!(s.pixel_count(w, h), s.pixels(w, h).count() as u64, "{s}");
            }
        }
    }

    /// A count no image needs is refused before anything is made for it (a merge used to
    /// allocate a slot per shard: 64 GB for 0/4000000000).
    #[test]
    fn shard_counts_are_bounded() {
        assert_eq!(MAX_SHARDS, 2047);
        assert_eq!("2046/2047".parse::<Shard>(), Ok(Shard { index: 2046, count: 2047 }));
        let e = "0/4000000000".parse::<Shard>().unwrap_err();
        assert_eq!(
            e,
            "4000000000 shards: at most 2047 (the tile diagonals of the largest image, 16384x16384; more shards \
             would render nothing)"
        );
        assert!("0/2048".parse::<Shard>().unwrap_err().starts_with("2048 shards: at most 2047"));
        assert!("0/99999999999999999999".parse::<Shard>().is_err());
    }
}

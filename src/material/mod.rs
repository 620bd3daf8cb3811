//! Materials: the BSDFs (bidirectional scattering distribution functions).
//!
//! Everything here works in the **local shading frame**: the shading normal is +Z, and every
//! direction is unit length and points *away* from the surface (`wo` towards the viewer, `wi`
//! towards the light). Convert with [`crate::geometry::Frame`] before and after.
//!
//! A material kind is one file holding all that ember knows of it: its description as a scene
//! gives it (colours, textures, roughness: a [`MaterialModel`]), the BSDF it turns into at a
//! shading point, its albedo, the lobes the scene analysis reports, and its fingerprint:
//! - `diffuse` ([`DiffuseMaterial`]), `conductor` ([`MetalMaterial`]), `plastic`
//!   ([`PlasticMaterial`]), `dielectric` ([`GlassMaterial`]), `emissive`
//!   ([`EmissiveMaterial`]), `pbr` (glTF's metallic-roughness material, [`PbrMaterial`]);
//! - shared by them: `fresnel`, exact dielectric ([`fresnel_dielectric`]) and Schlick Fresnel
//!   reflectance; `microfacet`, the GGX distribution, Smith masking-shadowing and
//!   visible-normal sampling; `albedo`, GGX's directional albedo tabulated.
//!
//! Each kind's description implements [`MaterialModel`] and its BSDF [`BsdfModel`]: the kind
//! answers the scene analysis itself (lobes, albedo, textures, whether it scatters) and its
//! BSDF whether it is delta, transmissive or chooses between lobes. Adding a kind: its file
//! and one line in the `material_kinds!` list below (which makes both the [`MaterialKind`]
//! and the [`Bsdf`] variant and their dispatch), and where scenes describe it, its
//! `[materials]` section (`scene/format.rs`) with the arm that builds it
//! (`scene/toml_file.rs`).
//!
//! Conventions shared by all BSDFs:
//! - [`BsdfModel::eval`] is f(wo, wi) *without* the cosine factor, and only for non-delta
//!   lobes.
//! - [`BsdfModel::pdf`] is the solid-angle density with which [`BsdfModel::sample`] produces
//!   `wi` through its non-delta lobes (including the lobe-selection probability).
//! - Delta lobes follow pbrt: `f = F / |cos θi|` and `pdf` = the discrete probability of picking
//!   the lobe, so `f * |wi.z| / pdf` is the throughput multiplier.
//! - Opaque BSDFs (diffuse, conductor, plastic, glTF's) are zero when `wo` or `wi` lies below
//!   — or within [`MIN_COS`] of — the surface plane; the caller flips the frame so that
//!   `wo.z > 0`. One exception: a clear coat with its own normal (`pbr.rs`) reflects about it,
//!   bounded by its own plane, so its `wi` may lie below the shading plane (the caller keeps
//!   only directions above the geometric surface).
//! - No method returns NaN or infinity for unit-length inputs.

mod albedo;
mod conductor;
mod dielectric;
mod diffuse;
mod emissive;
mod fresnel;
mod microfacet;
mod pbr;
mod plastic;
mod sheen;

use glam::{Vec2, Vec3};

use crate::hash::Fingerprint;
use crate::texture::{TexCoords, Texture};

pub use conductor::{Conductor, MetalMaterial};
pub use dielectric::{Dielectric, GlassMaterial};
pub use diffuse::{DiffuseMaterial, Lambert, sample_cosine_hemisphere};
pub use emissive::EmissiveMaterial;
pub use fresnel::fresnel_dielectric;
pub use pbr::{AlphaMode, Clearcoat, NormalMap, PbrBsdf, PbrMaterial, Sheen};
pub use plastic::{Plastic, PlasticMaterial};

/// What a material kind answers: see the module documentation.
pub trait MaterialModel {
    /// The BSDF it turns into at a shading point.
    type Bsdf: BsdfModel;

    /// The BSDF at texture coordinates `at`. With `TEX == false` the caller knows no texture
    /// is in use, so colours are read as the constants they are, without looking at `at`.
    fn bsdf<const TEX: bool>(&self, at: &TexCoords) -> Self::Bsdf;

    /// [`MaterialModel::bsdf`] in a scene whose every surface is diffuse or purely emissive
    /// (the caller knows): the Lambertian BSDF this kind gives there (black unless diffuse).
    #[inline(always)]
    fn lambert<const TEX: bool>(&self, _at: &TexCoords) -> Lambert {
        Lambert::BLACK
    }

    /// The shading normal in the surface's tangent frame (x along the tangent, y along the
    /// bitangent, z along the interpolated normal) if the kind perturbs it (a normal map);
    /// `None` keeps the interpolated normal.
    #[inline(always)]
    fn normal_at<const TEX: bool>(&self, _at: &TexCoords) -> Option<Vec3> {
        None
    }

    /// A clear coat's own normal, in the same tangent frame as [`MaterialModel::normal_at`]'s
    /// (z along the interpolated normal, not the mapped one), if the kind has one (a coat
    /// normal map); `None`: the coat, if any, has the shading normal.
    #[inline(always)]
    fn coat_normal_at<const TEX: bool>(&self, _at: &TexCoords) -> Option<Vec3> {
        None
    }

    /// The largest fraction of light it sends on in one bounce, for the best colour channel
    /// and where its colour is brightest (a texture's largest texel), at normal incidence: a
    /// guide rather than a bound (towards grazing angles metals and coatings reflect more).
    /// Russian roulette starts from it (`crate::integrator::roulette`).
    fn albedo(&self) -> f32;

    /// Whether it can scatter light at all (not black, not purely emissive).
    fn scatters(&self) -> bool;

    /// The kinds of scattering it has, as the scene analysis reports them.
    fn lobes(&self) -> Lobes;

    /// Its textures that vary over the surface (colours, maps), each once.
    fn textures(&self) -> Vec<&Texture> {
        Vec::new()
    }

    /// Whether it perturbs the shading normal or a layer's own ([`MaterialModel::normal_at`],
    /// [`MaterialModel::coat_normal_at`]): the surface then needs tangents.
    fn has_normal_map(&self) -> bool {
        false
    }

    /// Feeds its kind and parameters to a fingerprint.
    fn fingerprint(&self, h: &mut Fingerprint);
}

/// What a BSDF at a shading point answers (see the module documentation for the
/// conventions). Each material kind's BSDF type implements it, and [`Bsdf`] dispatches to
/// them.
pub trait BsdfModel: Copy {
    /// f(wo, wi) for the non-delta part (0 for delta-only BSDFs). Not multiplied by cos.
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3;

    /// Solid-angle pdf with which [`BsdfModel::sample`] produces `wi` through its non-delta
    /// lobes, including the lobe choice (0 for a delta-only BSDF).
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32;

    /// Samples wi: `u` in [0,1)² for the direction, `uc` in [0,1) for the lobe choice (only
    /// if [`BsdfModel::chooses_lobe`]). `None` if sampling fails. Non-delta samples carry `f`
    /// and `pdf` computed by the very code of `eval` and `pdf`, so MIS weights agree exactly.
    fn sample(&self, wo: Vec3, u: Vec2, uc: f32) -> Option<BsdfSample>;

    /// Whether [`BsdfModel::sample`] uses its lobe number `uc`; a path draws it only then.
    fn chooses_lobe(&self) -> bool {
        false
    }

    /// Whether every lobe is delta (a mirror, smooth glass): next-event estimation is useless.
    fn is_delta(&self) -> bool {
        false
    }

    /// Whether light can leave on the other side of the surface (glass).
    fn is_transmissive(&self) -> bool {
        false
    }

    /// For a path traced from a light that sampled `wi` from `wo` (`wo` toward the light):
    /// the factor by which its weight differs from the sample's `f |cos| / pdf`. Paths from
    /// the camera see radiance cross a refraction unscaled (the BSDFs here leave out the
    /// 1/η² compression), so light carried the other way is scaled by (η on `wo`'s side /
    /// η on `wi`'s side)² (Veach 1997, §5.2): 1 but across a refraction.
    fn light_path_scale(&self, _wo: Vec3, _wi: Vec3) -> f32 {
        1.0
    }

    /// The albedo a denoiser is given for this surface (Open Image Denoise's guidance: the
    /// surface's colour independent of lighting and view, in [0, 1]).
    fn denoise_albedo(&self) -> Vec3;
}

/// Kinds of scattering (a material may have several).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Lobes {
    /// Lambertian (diffuse, the base of plastic).
    pub diffuse: bool,
    /// Rough microfacet reflection (rough metal, plastic).
    pub glossy: bool,
    /// A perfect mirror (metal of roughness ~0).
    pub mirror: bool,
    /// Refraction (glass).
    pub glass: bool,
}

/// The [`MaterialKind`] enum (one variant per kind, holding the kind's description) and the
/// [`Bsdf`] enum (one variant per kind, holding the BSDF the kind gives at a point), with
/// their [`MaterialModel`] and [`BsdfModel`] implementations, which hand every question to
/// the variant's own type. A kind is one line of the list below.
macro_rules! material_kinds {
    ($($(#[$doc:meta])* $variant:ident($ty:ty) => $bsdf:ty,)*) => {
        /// What a surface is made of. (A scene has a few materials, looked up by reference:
        /// the size of the largest kind costs nothing.)
        #[derive(Clone, Debug, PartialEq)]
        #[allow(clippy::large_enum_variant)]
        pub enum MaterialKind {
            $($(#[$doc])* $variant($ty),)*
        }

        /// A BSDF with its parameters resolved at a shading point (textures looked up): the
        /// one its material kind gives.
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub enum Bsdf {
            $($(#[$doc])* $variant($bsdf),)*
        }

        impl MaterialModel for MaterialKind {
            type Bsdf = Bsdf;
            #[inline(always)]
            fn bsdf<const TEX: bool>(&self, at: &TexCoords) -> Bsdf {
                match self { $(MaterialKind::$variant(m) => Bsdf::$variant(m.bsdf::<TEX>(at)),)* }
            }
            #[inline(always)]
            fn lambert<const TEX: bool>(&self, at: &TexCoords) -> Lambert {
                match self { $(MaterialKind::$variant(m) => m.lambert::<TEX>(at),)* }
            }
            #[inline(always)]
            fn normal_at<const TEX: bool>(&self, at: &TexCoords) -> Option<Vec3> {
                match self { $(MaterialKind::$variant(m) => m.normal_at::<TEX>(at),)* }
            }
            #[inline(always)]
            fn coat_normal_at<const TEX: bool>(&self, at: &TexCoords) -> Option<Vec3> {
                match self { $(MaterialKind::$variant(m) => m.coat_normal_at::<TEX>(at),)* }
            }
            fn albedo(&self) -> f32 {
                match self { $(MaterialKind::$variant(m) => m.albedo(),)* }
            }
            fn scatters(&self) -> bool {
                match self { $(MaterialKind::$variant(m) => m.scatters(),)* }
            }
            fn lobes(&self) -> Lobes {
                match self { $(MaterialKind::$variant(m) => m.lobes(),)* }
            }
            fn textures(&self) -> Vec<&Texture> {
                match self { $(MaterialKind::$variant(m) => m.textures(),)* }
            }
            fn has_normal_map(&self) -> bool {
                match self { $(MaterialKind::$variant(m) => m.has_normal_map(),)* }
            }
            fn fingerprint(&self, h: &mut Fingerprint) {
                match self { $(MaterialKind::$variant(m) => m.fingerprint(h),)* }
            }
        }

        impl BsdfModel for Bsdf {
            #[inline]
            fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
                match self { $(Bsdf::$variant(b) => b.eval(wo, wi),)* }
            }
            #[inline]
            fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
                match self { $(Bsdf::$variant(b) => b.pdf(wo, wi),)* }
            }
            #[inline]
            fn sample(&self, wo: Vec3, u: Vec2, uc: f32) -> Option<BsdfSample> {
                let s = match self { $(Bsdf::$variant(b) => b.sample(wo, u, uc),)* }?;
                debug_assert!(s.f.is_finite() && s.pdf.is_finite() && s.wi.is_finite(), "{s:?}");
                (s.pdf > 0.0).then_some(s)
            }
            #[inline(always)]
            fn chooses_lobe(&self) -> bool {
                match self { $(Bsdf::$variant(b) => b.chooses_lobe(),)* }
            }
            #[inline]
            fn is_delta(&self) -> bool {
                match self { $(Bsdf::$variant(b) => b.is_delta(),)* }
            }
            #[inline]
            fn is_transmissive(&self) -> bool {
                match self { $(Bsdf::$variant(b) => b.is_transmissive(),)* }
            }
            #[inline]
            fn light_path_scale(&self, wo: Vec3, wi: Vec3) -> f32 {
                match self { $(Bsdf::$variant(b) => b.light_path_scale(wo, wi),)* }
            }
            #[inline]
            fn denoise_albedo(&self) -> Vec3 {
                match self { $(Bsdf::$variant(b) => b.denoise_albedo(),)* }.clamp(Vec3::ZERO, Vec3::ONE)
            }
        }
    };
}

material_kinds! {
    /// Lambertian.
    Diffuse(DiffuseMaterial) => Lambert,
    /// GGX rough metal; roughness 0 is a mirror.
    Metal(MetalMaterial) => Conductor,
    /// A diffuse base under a GGX dielectric coat.
    Plastic(PlasticMaterial) => Plastic,
    /// Smooth glass.
    Glass(GlassMaterial) => Dielectric,
    /// Emits and reflects nothing.
    Emissive(EmissiveMaterial) => Lambert,
    /// glTF's metallic-roughness material: a metal and a dielectric over a diffuse base,
    /// mixed by metalness, every factor textured.
    Pbr(PbrMaterial) => PbrBsdf,
}

/// A named material; any material may also emit (`emission`, radiance from both faces,
/// which may vary over the surface).
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    pub kind: MaterialKind,
    pub emission: Texture,
}

impl Material {
    /// A diffuse material of constant colour that does not emit.
    pub fn diffuse(name: &str, color: Vec3) -> Material {
        Material {
            name: name.into(),
            kind: MaterialKind::Diffuse(DiffuseMaterial { color: Texture::Constant(color) }),
            emission: Texture::Constant(Vec3::ZERO),
        }
    }

    /// The BSDF at `at` ([`MaterialModel::bsdf`]).
    #[inline(always)]
    pub fn bsdf_at<const TEX: bool>(&self, at: &TexCoords) -> Bsdf {
        self.kind.bsdf::<TEX>(at)
    }

    /// The Lambertian BSDF of a scene whose every surface is diffuse or purely emissive
    /// ([`MaterialModel::lambert`]): the same value as [`Material::bsdf_at`] gives there,
    /// without dispatch.
    #[inline(always)]
    pub fn lambert_at<const TEX: bool>(&self, at: &TexCoords) -> Lambert {
        self.kind.lambert::<TEX>(at)
    }

    /// Whether it emits anywhere.
    /// What the inside of the material absorbs per unit length (glass with an attenuation),
    /// zero for everything else: a path that refracts into it is attenuated by the distance
    /// to its next hit.
    pub fn absorption(&self) -> Vec3 {
        match &self.kind {
            MaterialKind::Glass(g) => g.absorption,
            _ => Vec3::ZERO,
        }
    }

    pub fn is_emissive(&self) -> bool {
        self.emission.max().max_element() > 0.0
    }

    /// Where a surface of this material is not there: glTF's `alphaMode` `MASK` (below the
    /// cutoff) and `BLEND` (with probability 1 − alpha), the alpha being the base colour
    /// factor's times its map's. `None`: opaque everywhere.
    pub fn cutout(&self) -> Option<crate::geometry::Cutout> {
        let MaterialKind::Pbr(p) = &self.kind else { return None };
        let cutoff = match p.alpha_mode {
            AlphaMode::Opaque => return None,
            AlphaMode::Mask(c) => Some(c),
            AlphaMode::Blend => None,
        };
        let map = match &p.base {
            Texture::Map { map, .. } => Some(map.clone()),
            _ => None,
        };
        if map.is_none() && cutoff.map_or(p.alpha >= 1.0, |c| p.alpha >= c) {
            return None;
        }
        Some(crate::geometry::Cutout { alpha: p.alpha, map, cutoff })
    }

    /// Whether an image maps any of its properties (colour, roughness, emission, normals).
    pub fn has_texture_map(&self) -> bool {
        self.kind.has_normal_map() || self.textures().iter().any(|t| matches!(t, Texture::Map { .. }))
    }

    /// Its textures that vary over the surface, its emission's included.
    pub fn textures(&self) -> Vec<&Texture> {
        let mut t = self.kind.textures();
        t.extend(self.emission.varying());
        t
    }

    /// Feeds the material to a fingerprint.
    pub fn fingerprint(&self, h: &mut Fingerprint) {
        h.str(&self.name);
        match &self.emission {
            Texture::Constant(c) => h.v3(&[*c]),
            t => t.fingerprint(h),
        }
        self.kind.fingerprint(h);
    }
}

/// `f0 + (1 − f0) c`: the albedo of a coating reflecting `f0` over a body sending on `c` of
/// what passes it.
fn coated(f0: f32, c: f32) -> f32 {
    f0 + (1.0 - f0) * c
}

/// Directions whose |cos θ| to the normal is at most this are treated as lying in the surface
/// plane: opaque BSDFs are zero there and sampling fails. It keeps delta weights `F / |cos θ|`
/// and microfacet terms finite (1/MIN_COS = 1e9) at a negligible angular cost (~6e-8°).
pub const MIN_COS: f32 = 1e-9;

/// One direction drawn by [`BsdfModel::sample`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfSample {
    pub wi: Vec3,
    /// BSDF value f(wo, wi) (NOT multiplied by cos). For delta lobes: the weight such that
    /// `f * |wi.z| / pdf` is the correct throughput multiplier (as in pbrt: f = F/|cos|,
    /// pdf = choice probability).
    pub f: Vec3,
    /// Solid-angle pdf (for delta lobes: the discrete probability of choosing that lobe).
    /// Always > 0.
    pub pdf: f32,
    /// True if wi was chosen from a delta (specular) lobe: MIS and eval() do not apply to it.
    pub delta: bool,
}

impl Bsdf {
    /// Lambertian of albedo `albedo`.
    pub fn diffuse(albedo: Vec3) -> Bsdf {
        Bsdf::Diffuse(Lambert::new(albedo))
    }

    /// Rough metal ([`Conductor`]): reflectance `color` at normal incidence, GGX roughness.
    pub fn conductor(color: Vec3, roughness: f32) -> Bsdf {
        Bsdf::Metal(Conductor::new(color, roughness))
    }

    /// Plastic ([`Plastic`]): a `diffuse` base under a coating of roughness `roughness`.
    pub fn plastic(diffuse: Vec3, roughness: f32) -> Bsdf {
        Bsdf::Plastic(Plastic::new(diffuse, roughness))
    }

    /// Smooth glass ([`Dielectric`]) of index `ior`, transmission tinted by `tint`.
    pub fn dielectric(ior: f32, tint: Vec3) -> Bsdf {
        Bsdf::Glass(Dielectric::new(ior, tint))
    }

    /// glTF's metallic-roughness BSDF ([`PbrBsdf`]) of base colour `base`, dielectric index
    /// 1.5, without `KHR_materials_specular`.
    pub fn pbr(base: Vec3, metallic: f32, roughness: f32) -> Bsdf {
        Bsdf::Pbr(PbrBsdf::new(base, metallic, roughness, 1.5, 1.0, Vec3::ONE))
    }

    /// Gives a clear coat its own normal `n` (unit, in the shading frame, facing the viewer:
    /// [`PbrBsdf::with_coat_normal`]); nothing changes for a BSDF without a coat.
    #[inline]
    pub fn set_coat_normal(&mut self, n: Vec3) {
        if let Bsdf::Pbr(b) = self {
            *b = b.with_coat_normal(n);
        }
    }

    /// [`BsdfModel::eval`] where the caller knows every BSDF is Lambertian (kernels without
    /// glossy or glass materials): the same arithmetic, inlined without dispatch.
    #[inline(always)]
    pub fn eval_lambert(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        match self {
            Bsdf::Diffuse(l) | Bsdf::Emissive(l) => l.eval(wo, wi),
            _ => self.eval(wo, wi),
        }
    }

    /// [`BsdfModel::sample`] where the caller knows every BSDF is Lambertian, inlined likewise.
    #[inline(always)]
    pub fn sample_lambert(&self, wo: Vec3, u: Vec2, uc: f32) -> Option<BsdfSample> {
        match self {
            Bsdf::Diffuse(l) | Bsdf::Emissive(l) => l.sample(wo, u, uc).filter(|s| s.pdf > 0.0),
            _ => self.sample(wo, u, uc),
        }
    }

    /// Whether it is Lambertian (diffuse or black): the uniform-hemisphere estimator samples
    /// only those uniformly.
    pub fn is_lambertian(&self) -> bool {
        matches!(self, Bsdf::Diffuse(_) | Bsdf::Emissive(_))
    }
}

/// True if both directions are strictly above the surface (the domain of opaque BSDFs).
#[inline]
fn same_hemisphere_above(wo: Vec3, wi: Vec3) -> bool {
    wo.z > MIN_COS && wi.z > MIN_COS
}

/// Mirror reflection of `wo` about the unit normal `n` (both pointing away from the surface).
#[inline]
fn reflect(wo: Vec3, n: Vec3) -> Vec3 {
    2.0 * wo.dot(n) * n - wo
}

/// Mirror reflection about the shading normal +Z.
#[inline]
fn reflect_z(wo: Vec3) -> Vec3 {
    Vec3::new(-wo.x, -wo.y, wo.z)
}

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
//!   ([`EmissiveMaterial`]);
//! - shared by them: `fresnel`, exact dielectric ([`fresnel_dielectric`]) and Schlick Fresnel
//!   reflectance; `microfacet`, the GGX distribution, Smith masking-shadowing and
//!   visible-normal sampling.
//!
//! Adding a kind: its file, a line in the `material_kinds!` list below and a [`Bsdf`] variant
//! with its arms here, and its `[materials]` section (`scene/format.rs`) with the arm that
//! builds it (`scene/toml_file.rs`).
//!
//! Conventions shared by all BSDFs:
//! - [`Bsdf::eval`] is f(wo, wi) *without* the cosine factor, and only for non-delta lobes.
//! - [`Bsdf::pdf`] is the solid-angle density with which [`Bsdf::sample`] produces `wi`
//!   through its non-delta lobes (including the lobe-selection probability).
//! - Delta lobes follow pbrt: `f = F / |cos θi|` and `pdf` = the discrete probability of picking
//!   the lobe, so `f * |wi.z| / pdf` is the throughput multiplier.
//! - Opaque BSDFs (diffuse, conductor, plastic) are zero when `wo` or `wi` lies below — or
//!   within [`MIN_COS`] of — the surface plane; the caller flips the frame so that `wo.z > 0`.
//! - No method returns NaN or infinity for unit-length inputs.

mod conductor;
mod dielectric;
mod diffuse;
mod emissive;
mod fresnel;
mod microfacet;
mod plastic;

use glam::{Vec2, Vec3};

use crate::hash::Fingerprint;
use crate::texture::Texture;
use conductor::Conductor;
use dielectric::Dielectric;
use diffuse::Diffuse;
use plastic::Plastic;

pub use conductor::MetalMaterial;
pub use dielectric::GlassMaterial;
pub use diffuse::DiffuseMaterial;
pub use emissive::EmissiveMaterial;
pub use fresnel::fresnel_dielectric;
pub use plastic::PlasticMaterial;

/// What a material kind answers: see the module documentation.
pub trait MaterialModel {
    /// The BSDF at texture coordinates `uv`. With `TEX == false` the caller knows no texture
    /// is in use, so colours are read as the constants they are, without looking at `uv`.
    fn bsdf<const TEX: bool>(&self, uv: Vec2) -> Bsdf;

    /// [`MaterialModel::bsdf`] in a scene whose every surface is diffuse or purely emissive
    /// (the caller knows): the Lambertian BSDF this kind gives there (black unless diffuse).
    #[inline(always)]
    fn lambert<const TEX: bool>(&self, _uv: Vec2) -> Bsdf {
        Bsdf::Diffuse { albedo: Vec3::ZERO }
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

    /// The texture, if its colour varies over the surface.
    fn texture(&self) -> Option<&Texture> {
        None
    }

    /// Feeds its kind and parameters to a fingerprint.
    fn fingerprint(&self, h: &mut Fingerprint);
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

/// The [`MaterialKind`] enum, one variant per kind, and its [`MaterialModel`] implementation,
/// which hands every question to the variant's own type.
macro_rules! material_kinds {
    ($($(#[$doc:meta])* $variant:ident($ty:ty),)*) => {
        /// What a surface is made of.
        #[derive(Clone, Debug, PartialEq)]
        pub enum MaterialKind {
            $($(#[$doc])* $variant($ty),)*
        }

        impl MaterialModel for MaterialKind {
            #[inline(always)]
            fn bsdf<const TEX: bool>(&self, uv: Vec2) -> Bsdf {
                match self { $(MaterialKind::$variant(m) => m.bsdf::<TEX>(uv),)* }
            }
            #[inline(always)]
            fn lambert<const TEX: bool>(&self, uv: Vec2) -> Bsdf {
                match self { $(MaterialKind::$variant(m) => m.lambert::<TEX>(uv),)* }
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
            fn texture(&self) -> Option<&Texture> {
                match self { $(MaterialKind::$variant(m) => m.texture(),)* }
            }
            fn fingerprint(&self, h: &mut Fingerprint) {
                match self { $(MaterialKind::$variant(m) => m.fingerprint(h),)* }
            }
        }
    };
}

material_kinds! {
    /// Lambertian.
    Diffuse(DiffuseMaterial),
    /// GGX rough metal; roughness 0 is a mirror.
    Metal(MetalMaterial),
    /// A diffuse base under a GGX dielectric coat.
    Plastic(PlasticMaterial),
    /// Smooth glass.
    Glass(GlassMaterial),
    /// Emits and reflects nothing.
    Emissive(EmissiveMaterial),
}

/// A named material; any material may also emit (`emission`, radiance, both faces).
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    pub kind: MaterialKind,
    pub emission: Vec3,
}

impl Material {
    /// A diffuse material of constant colour that does not emit.
    pub fn diffuse(name: &str, color: Vec3) -> Material {
        Material {
            name: name.into(),
            kind: MaterialKind::Diffuse(DiffuseMaterial { color: Texture::Constant(color) }),
            emission: Vec3::ZERO,
        }
    }

    /// The BSDF at `uv` ([`MaterialModel::bsdf`]).
    #[inline(always)]
    pub fn bsdf_at<const TEX: bool>(&self, uv: Vec2) -> Bsdf {
        self.kind.bsdf::<TEX>(uv)
    }

    /// The Lambertian BSDF of a scene whose every surface is diffuse or purely emissive
    /// ([`MaterialModel::lambert`]): the same value as [`Material::bsdf_at`] gives there,
    /// without dispatch.
    #[inline(always)]
    pub fn lambert_at<const TEX: bool>(&self, uv: Vec2) -> Bsdf {
        self.kind.lambert::<TEX>(uv)
    }

    pub fn is_emissive(&self) -> bool {
        self.emission.max_element() > 0.0
    }

    /// The texture, if the colour varies over the surface.
    pub fn texture(&self) -> Option<&Texture> {
        self.kind.texture()
    }

    /// Feeds the material to a fingerprint.
    pub fn fingerprint(&self, h: &mut Fingerprint) {
        h.str(&self.name);
        h.v3(&[self.emission]);
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

/// A BSDF with its parameters already resolved (textures looked up by the caller).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Bsdf {
    /// Lambertian, cosine-weighted sampling.
    Diffuse { albedo: Vec3 },
    /// Rough metal: GGX (Trowbridge-Reitz) microfacet reflection with the height-correlated
    /// Smith G2 and visible-normal sampling, Schlick Fresnel with F0 = `color`,
    /// alpha = roughness². Roughness is clamped to [0, 1]; alpha below 1e-3
    /// (roughness < ~0.032) is a perfect mirror (delta).
    Conductor { color: Vec3, roughness: f32 },
    /// Glossy plastic: a GGX dielectric coating (IOR 1.5, alpha = roughness²) over a
    /// Lambertian base `diffuse`, the base weighted by (1 − F(cos θo))(1 − F(cos θi)).
    /// Roughness 0 gives a smooth coating (delta specular lobe + diffuse).
    Plastic { diffuse: Vec3, roughness: f32 },
    /// Smooth glass: exact dielectric Fresnel, reflection + refraction (both delta), total
    /// internal reflection; `tint` multiplies transmission. `wo.z > 0` means the ray arrives
    /// from outside (IOR 1), `wo.z < 0` from inside (IOR `ior`). `ior == 1` passes straight
    /// through.
    Dielectric { ior: f32, tint: Vec3 },
}

/// One direction drawn by [`Bsdf::sample`].
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
    /// f(wo, wi) for the non-delta part (0 for delta-only BSDFs). Not multiplied by cos.
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        match *self {
            Bsdf::Diffuse { albedo } => Diffuse::new(albedo).eval(wo, wi),
            Bsdf::Conductor { color, roughness } => Conductor::new(color, roughness).eval(wo, wi),
            Bsdf::Plastic { diffuse, roughness } => Plastic::new(diffuse, roughness).eval(wo, wi),
            Bsdf::Dielectric { .. } => Vec3::ZERO,
        }
    }

    /// Solid-angle pdf that [`sample`](Self::sample) would produce wi through its non-delta
    /// lobes (0 for pure delta).
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        match *self {
            Bsdf::Diffuse { albedo } => Diffuse::new(albedo).pdf(wo, wi),
            Bsdf::Conductor { color, roughness } => Conductor::new(color, roughness).pdf(wo, wi),
            Bsdf::Plastic { diffuse, roughness } => Plastic::new(diffuse, roughness).pdf(wo, wi),
            Bsdf::Dielectric { .. } => 0.0,
        }
    }

    /// Samples wi. `u` in [0,1)² for the direction, `uc` in [0,1) for the lobe choice.
    /// None if sampling fails (e.g. wo below the surface of an opaque BSDF, or a microfacet
    /// reflection that ends below the horizon).
    ///
    /// For non-delta samples, `f` and `pdf` are computed at the returned `wi` by the very code
    /// of [`eval`](Self::eval) and [`pdf`](Self::pdf), so MIS weights agree exactly.
    #[inline]
    pub fn sample(&self, wo: Vec3, u: Vec2, uc: f32) -> Option<BsdfSample> {
        let s = match *self {
            Bsdf::Diffuse { albedo } => Diffuse::new(albedo).sample(wo, u),
            Bsdf::Conductor { color, roughness } => Conductor::new(color, roughness).sample(wo, u),
            Bsdf::Plastic { diffuse, roughness } => Plastic::new(diffuse, roughness).sample(wo, u, uc),
            Bsdf::Dielectric { ior, tint } => Dielectric::new(ior, tint).sample(wo, uc),
        }?;
        debug_assert!(s.f.is_finite() && s.pdf.is_finite() && s.wi.is_finite(), "{s:?}");
        (s.pdf > 0.0).then_some(s)
    }

    /// [`Bsdf::eval`] where the caller knows every BSDF is `Diffuse` (kernels without glossy
    /// or glass materials): the same arithmetic, inlined into the caller without dispatch.
    #[inline(always)]
    pub fn eval_lambert(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        match *self {
            Bsdf::Diffuse { albedo } => Diffuse::new(albedo).eval(wo, wi),
            _ => self.eval(wo, wi),
        }
    }

    /// [`Bsdf::sample`] where the caller knows every BSDF is `Diffuse`, inlined likewise.
    #[inline(always)]
    pub fn sample_lambert(&self, wo: Vec3, u: Vec2, uc: f32) -> Option<BsdfSample> {
        match *self {
            Bsdf::Diffuse { albedo } => Diffuse::new(albedo).sample(wo, u).filter(|s| s.pdf > 0.0),
            _ => self.sample(wo, u, uc),
        }
    }

    /// True if [`Bsdf::sample`] uses its lobe number `uc` (plastic: coating or base; glass:
    /// reflection or refraction); the others ignore it, and a path does not draw it for them.
    #[inline(always)]
    pub fn chooses_lobe(&self) -> bool {
        matches!(self, Bsdf::Plastic { .. } | Bsdf::Dielectric { .. })
    }

    /// True if every lobe is delta (mirror conductor, glass): next-event estimation is useless.
    #[inline]
    pub fn is_delta(&self) -> bool {
        match *self {
            Bsdf::Diffuse { .. } | Bsdf::Plastic { .. } => false,
            Bsdf::Conductor { color, roughness } => Conductor::new(color, roughness).is_delta(),
            Bsdf::Dielectric { .. } => true,
        }
    }

    /// True if the BSDF transmits (light can leave on the other side), i.e. Dielectric.
    #[inline]
    pub fn is_transmissive(&self) -> bool {
        matches!(self, Bsdf::Dielectric { .. })
    }

    /// The albedo a denoiser is given for this surface (Open Image Denoise's guidance: the
    /// surface's colour independent of lighting and view, in [0, 1]): a diffuse colour; a
    /// metal's reflectance at normal incidence (its colour); plastic's coating reflectance at
    /// normal incidence (4 %) plus its base colour times what passes the coating; 1 for glass
    /// (used only where a path ends on it: renders follow glass and mirrors to the surface
    /// seen through them).
    #[inline]
    pub fn denoise_albedo(&self) -> Vec3 {
        match *self {
            Bsdf::Diffuse { albedo } => albedo,
            Bsdf::Conductor { color, .. } => color,
            Bsdf::Plastic { diffuse, .. } => Vec3::splat(plastic::COATING_F0) + (1.0 - plastic::COATING_F0) * diffuse,
            Bsdf::Dielectric { .. } => Vec3::ONE,
        }
        .clamp(Vec3::ZERO, Vec3::ONE)
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

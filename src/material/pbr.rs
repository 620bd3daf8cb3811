//! The glTF 2.0 metallic-roughness material (glTF files; scene files: `type = "pbr"`): a
//! metal and a dielectric layer mixed by metalness, each factor possibly textured, as the
//! glTF specification's appendix B defines it and as Blender Cycles' Principled BSDF renders
//! what Blender's glTF importer makes of it.
//!
//! - **Specular**: one GGX lobe (height-correlated Smith G2, visible-normal sampling) of
//!   α = roughness², whose Fresnel is the mix, by metalness m, of the dielectric's exact
//!   Fresnel at index `ior` (1.5 by default; `KHR_materials_ior`), scaled to
//!   `KHR_materials_specular`'s weight and colour, and the metal's Schlick Fresnel with
//!   F0 = base colour. Each part gets Turquin's multiple-scattering compensation
//!   (`albedo.rs`), so a white rough metal reflects all the light at every roughness, as
//!   Cycles' multiscatter GGX does.
//! - **Diffuse**: (1 − m) base / π under the dielectric layer, weighted by 1 − E_spec(μo),
//!   the light the specular layer does not reflect at this view (albedo scaling, as Cycles
//!   layers its Principled BSDF): a white dielectric reflects all the light, in proportions
//!   that depend on the view.
//! - **Textures**: base colour (RGBA: alpha for `MASK` and `BLEND`), metallic-roughness
//!   (B = metalness, G = roughness), normal map (tangent space, scaled in x and y by its
//!   `scale`), the coat's weight (R), roughness (G) and normal map, the sheen's colour (RGB) and
//!   roughness (A) — each times its factor. Roughness 0 is a smooth layer: a delta reflection
//!   over the diffuse base (a pure mirror where the metalness is 1).
//! - **Sheen** (`KHR_materials_sheen`, `sheen.rs`): a back-scattering fibre lobe of colour
//!   `sheen` over the specular and diffuse layers, which keep 1 − max(colour) E_sheen(μo).
//! - **Clear coat** (`KHR_materials_clearcoat`): a second dielectric GGX layer of index 1.5,
//!   weight `clearcoat` and α = clearcoat roughness², over all of the above, which it scales
//!   by 1 − the coat's directional albedo at the view (so the sum never exceeds what comes
//!   in). Its normal is the shading normal, or its own where it has a normal map
//!   (`clearcoatNormalTexture`: tangent space, the base normal map's tangent frame, scaled by
//!   its `scale`; applied to the interpolated normal, not to the base's mapped one): the coat's
//!   lobe, its albedo and its cosine are then taken about that normal, its lobe bounded by its
//!   own plane ([`PbrBsdf::with_coat_normal`]), while the layers under it keep the shading
//!   normal and its hemisphere.
//! - **Sampling**: the coat with the probability of its share of the albedo at this view,
//!   then the sheen (cosine-weighted) likewise, then the specular lobe, else the
//!   cosine-weighted base; the pdf is the mixture,
//!   so MIS weights are exact.

use std::f32::consts::FRAC_1_PI;

use glam::{Vec2, Vec3};

use super::albedo::{dielectric_albedo, ggx_albedo};
use super::diffuse::{cosine_hemisphere_pdf, sample_cosine_hemisphere};
use super::fresnel::{fresnel_dielectric, fresnel_schlick};
use super::microfacet::Ggx;
use super::sheen;
use super::{BsdfModel, BsdfSample, Lobes, MIN_COS, MaterialModel, coated, reflect, reflect_z, same_hemisphere_above};
use crate::geometry::Frame;
use crate::hash::Fingerprint;
use crate::light::luminance;
use crate::texture::{TexCoords, Texture};

/// How a surface's alpha (base colour alpha × factor) is used (glTF `alphaMode`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum AlphaMode {
    /// Alpha is ignored: the surface is opaque.
    #[default]
    Opaque,
    /// A cut-out: where alpha is below the cutoff the surface is not there.
    Mask(f32),
    /// Partly transparent: a ray passes with probability 1 − alpha (stochastic transparency).
    Blend,
}

/// A tangent-space normal map.
#[derive(Clone, Debug, PartialEq)]
pub struct NormalMap {
    /// The map (linear RGB: x, y, z each encoded as (n + 1) / 2).
    pub texture: Texture,
    /// glTF `normalTexture.scale`: multiplies the map's x and y.
    pub scale: f32,
}

impl NormalMap {
    /// The unit normal it gives at `at`, in the tangent frame (x along the tangent, y along
    /// the bitangent, z along the interpolated normal).
    #[inline(always)]
    fn at(&self, at: &TexCoords) -> Vec3 {
        let c = self.texture.eval(at) * 2.0 - Vec3::ONE;
        Vec3::new(c.x * self.scale, c.y * self.scale, c.z).normalize_or(Vec3::Z)
    }
}

/// The glTF metallic-roughness material: see the module documentation.
#[derive(Clone, Debug, PartialEq)]
pub struct PbrMaterial {
    /// Base colour (linear RGB): a map's colour times the factor.
    pub base: Texture,
    /// The alpha factor (a base colour map's alpha multiplies it).
    pub alpha: f32,
    pub alpha_mode: AlphaMode,
    /// (unused, roughness, metalness): a metallic-roughness map's (R, G, B) times
    /// (1, roughness factor, metallic factor), or those factors.
    pub metal_rough: Texture,
    pub normal: Option<NormalMap>,
    /// Index of refraction of the dielectric layer.
    pub ior: f32,
    /// `KHR_materials_specular`: the dielectric reflection's weight and the colour that tints
    /// its reflectance at normal incidence.
    pub specular: f32,
    pub specular_color: Vec3,
    /// `KHR_materials_clearcoat` (`None`: no coat).
    pub clearcoat: Option<Clearcoat>,
    /// `KHR_materials_sheen` (`None`: no sheen).
    pub sheen: Option<Sheen>,
}

/// A sheen's colour and roughness (glTF's `sheenColorFactor`, `sheenRoughnessFactor` and
/// their textures).
#[derive(Clone, Debug, PartialEq)]
pub struct Sheen {
    /// The sheen colour: a map's colour (`sheenColorTexture`, sRGB) times the factor, or the factor.
    pub color: Texture,
    /// The sheen roughness in `x`: the factor, times a map's alpha (`sheenRoughnessTexture`).
    pub roughness: Texture,
}

/// A clear coat's weight, roughness and normal (glTF's `clearcoatFactor`,
/// `clearcoatRoughnessFactor`, their textures, and `clearcoatNormalTexture`).
#[derive(Clone, Debug, PartialEq)]
pub struct Clearcoat {
    /// The coat's weight in `x`: a map's red (`clearcoatTexture`) times the factor, or the factor.
    pub factor: Texture,
    /// The coat's roughness in `y`: a map's green (`clearcoatRoughnessTexture`) times the
    /// factor, or the factor.
    pub roughness: Texture,
    /// The coat's own normal map (`clearcoatNormalTexture`, in the tangent frame of the base's
    /// normal map); `None`: the coat has the shading normal.
    pub normal: Option<NormalMap>,
}

/// The index of refraction of a clear coat (glTF: F0 = 0.04).
const COAT_IOR: f32 = 1.5;

impl PbrMaterial {
    /// A material of constant base colour, metalness and roughness, dielectric index 1.5.
    pub fn new(base: Vec3, metallic: f32, roughness: f32) -> PbrMaterial {
        PbrMaterial {
            base: Texture::Constant(base),
            alpha: 1.0,
            alpha_mode: AlphaMode::Opaque,
            metal_rough: Texture::Constant(Vec3::new(1.0, roughness, metallic)),
            normal: None,
            ior: 1.5,
            specular: 1.0,
            specular_color: Vec3::ONE,
            clearcoat: None,
            sheen: None,
        }
    }

    /// The alpha at `at`: the factor times the base colour map's alpha.
    pub fn alpha_at(&self, at: &TexCoords) -> f32 {
        match &self.base {
            Texture::Map { map, .. } => self.alpha * map.sample(at).w,
            _ => self.alpha,
        }
    }
}

impl MaterialModel for PbrMaterial {
    type Bsdf = PbrBsdf;

    #[inline(always)]
    fn bsdf<const TEX: bool>(&self, at: &TexCoords) -> PbrBsdf {
        let mr = self.metal_rough.at::<TEX>(at);
        let mut b = PbrBsdf::new(self.base.at::<TEX>(at), mr.z, mr.y, self.ior, self.specular, self.specular_color);
        if let Some(sh) = &self.sheen {
            b = b.with_sheen(sh.color.at::<TEX>(at), alpha_channel::<TEX>(&sh.roughness, at));
        }
        match &self.clearcoat {
            Some(c) => b.with_clearcoat(c.factor.at::<TEX>(at).x, c.roughness.at::<TEX>(at).y),
            None => b,
        }
    }

    #[inline(always)]
    fn normal_at<const TEX: bool>(&self, at: &TexCoords) -> Option<Vec3> {
        Some(self.normal.as_ref().filter(|_| TEX)?.at(at))
    }

    #[inline(always)]
    fn coat_normal_at<const TEX: bool>(&self, at: &TexCoords) -> Option<Vec3> {
        Some(self.clearcoat.as_ref()?.normal.as_ref().filter(|_| TEX)?.at(at))
    }

    /// A metal's colour, or the dielectric's reflectance plus its base colour times what
    /// passes it, at the brightest texel.
    fn albedo(&self) -> f32 {
        let base = self.base.max().max_element().clamp(0.0, 1.0);
        if self.metal_rough.min().z >= 1.0 {
            return base;
        }
        let f0 = self.specular * (self.specular_color * dielectric_f0(self.ior)).max_element().min(1.0);
        let mut layered = coated(f0, base).max(base);
        if let Some(sh) = &self.sheen {
            layered = coated(sh.color.max().max_element().clamp(0.0, 1.0), layered);
        }
        match &self.clearcoat {
            Some(c) => coated(c.factor.max().x.clamp(0.0, 1.0) * dielectric_f0(COAT_IOR), layered),
            None => layered,
        }
    }

    fn scatters(&self) -> bool {
        true
    }

    fn lobes(&self) -> Lobes {
        let (lo, hi) = (self.metal_rough.min(), self.metal_rough.max());
        let rough = |r: f32| !Ggx::from_roughness(r).is_smooth();
        // The coat's roughness range where it has weight.
        let coat = self
            .clearcoat
            .as_ref()
            .filter(|c| c.factor.max().x > 0.0)
            .map(|c| (c.roughness.min().y, c.roughness.max().y));
        Lobes {
            diffuse: lo.z < 1.0 && self.base.max().max_element() > 0.0,
            glossy: rough(hi.y) || coat.is_some_and(|(_, hi)| rough(hi)) || self.sheen.is_some(),
            mirror: !rough(lo.y) || coat.is_some_and(|(lo, _)| !rough(lo)),
            glass: false,
        }
    }

    fn textures(&self) -> Vec<&Texture> {
        let normal = self.normal.as_ref().map(|n| &n.texture);
        let coat = self
            .clearcoat
            .iter()
            .flat_map(|c| [&c.factor, &c.roughness].into_iter().chain(c.normal.as_ref().map(|n| &n.texture)));
        let sheen = self.sheen.iter().flat_map(|sh| [&sh.color, &sh.roughness]);
        [Some(&self.base), Some(&self.metal_rough), normal]
            .into_iter()
            .flatten()
            .chain(coat)
            .chain(sheen)
            .filter(|t| !t.is_constant())
            .collect()
    }

    fn has_normal_map(&self) -> bool {
        self.normal.is_some() || self.clearcoat.as_ref().is_some_and(|c| c.normal.is_some())
    }

    fn fingerprint(&self, h: &mut Fingerprint) {
        h.str("pbr");
        self.base.fingerprint(h);
        self.metal_rough.fingerprint(h);
        h.f32s(&[self.alpha, self.ior, self.specular]);
        h.v3(&[self.specular_color]);
        match self.alpha_mode {
            AlphaMode::Opaque => h.u32(0),
            AlphaMode::Mask(c) => {
                h.u32(1);
                h.f32s(&[c]);
            }
            AlphaMode::Blend => h.u32(2),
        }
        if let Some(n) = &self.normal {
            n.texture.fingerprint(h);
            h.f32s(&[n.scale]);
        }
        if let Some(c) = &self.clearcoat {
            h.str("clearcoat");
            c.factor.fingerprint(h);
            c.roughness.fingerprint(h);
            if let Some(n) = &c.normal {
                h.str("clearcoat normal");
                n.texture.fingerprint(h);
                h.f32s(&[n.scale]);
            }
        }
        if let Some(sh) = &self.sheen {
            h.str("sheen");
            sh.color.fingerprint(h);
            sh.roughness.fingerprint(h);
        }
    }
}

/// `x` of `t` at `at`, times its map's alpha where it is a map (glTF's sheen roughness is a
/// texture's alpha channel); without `TEX` the surface's mean.
#[inline(always)]
fn alpha_channel<const TEX: bool>(t: &Texture, at: &TexCoords) -> f32 {
    match t {
        Texture::Map { map, factor } => factor.x * if TEX { map.sample(at).w } else { map.image.mean().w },
        t => t.at::<TEX>(at).x,
    }
}

/// The probability of sampling a layer of albedo `layer` (> 0) over layers of albedo `under`,
/// which keep 1 − `layer` of the light: its share of what the two reflect.
#[inline]
fn layer_share(layer: f32, under: f32) -> f32 {
    let under = (1.0 - layer) * under;
    if under <= 0.0 { 1.0 } else { layer / (layer + under) }
}

/// The reflectance at normal incidence of a dielectric of index `ior`.
fn dielectric_f0(ior: f32) -> f32 {
    ((ior - 1.0) / (ior + 1.0)).powi(2)
}

/// The glTF material at a shading point: see the module documentation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PbrBsdf {
    base: Vec3,
    metallic: f32,
    ggx: Ggx,
    eta: f32,
    /// The dielectric's reflectance is a + b F(cos θ, η), per channel:
    /// `KHR_materials_specular`'s weight and colour (a = 0, b = 1 without them).
    spec_a: Vec3,
    spec_b: Vec3,
    /// The clear coat's weight (0: none) and distribution.
    coat: f32,
    coat_ggx: Ggx,
    /// The coat's unit normal in the shading frame: +Z (exactly) where it shares the shading
    /// normal, and then no coat frame is ever built.
    coat_normal: Vec3,
    /// The sheen's colour (zero: none), glTF roughness and lobe width.
    sheen: Vec3,
    sheen_roughness: f32,
    sheen_alpha: f32,
}

impl PbrBsdf {
    /// Base colour `base`, metalness, roughness (both clamped to [0, 1]), dielectric index
    /// `ior` and the specular weight and colour.
    pub fn new(base: Vec3, metallic: f32, roughness: f32, ior: f32, specular: f32, specular_color: Vec3) -> PbrBsdf {
        let eta = if ior.is_finite() && ior >= 1.0 { ior } else { 1.0 };
        let f0 = dielectric_f0(eta);
        // F' = w (f0' + (1 − f0') (F − f0) / (1 − f0)) with f0' = min(f0 × colour, 1): the
        // reflectance F0 is tinted, grazing reflection stays w.
        let f0t = (specular_color.max(Vec3::ZERO) * f0).min(Vec3::ONE);
        let b0 = (Vec3::ONE - f0t) / (1.0 - f0);
        let w = specular.clamp(0.0, 1.0);
        PbrBsdf {
            base: base.clamp(Vec3::ZERO, Vec3::ONE),
            metallic: if metallic.is_nan() { 0.0 } else { metallic.clamp(0.0, 1.0) },
            ggx: Ggx::from_roughness(roughness),
            eta,
            spec_a: w * (f0t - f0 * b0),
            spec_b: w * b0,
            coat: 0.0,
            coat_ggx: Ggx::from_roughness(0.0),
            coat_normal: Vec3::Z,
            sheen: Vec3::ZERO,
            sheen_roughness: 0.0,
            sheen_alpha: 1.0,
        }
    }

    /// The same with a sheen of colour `color` (clamped to [0, 1]) and roughness `roughness`.
    pub fn with_sheen(self, color: Vec3, roughness: f32) -> PbrBsdf {
        let color = if color.is_finite() { color.clamp(Vec3::ZERO, Vec3::ONE) } else { Vec3::ZERO };
        let r = if roughness.is_nan() { 0.0 } else { roughness.clamp(0.0, 1.0) };
        PbrBsdf { sheen: color, sheen_roughness: r, sheen_alpha: sheen::alpha_of(r), ..self }
    }

    /// What the sheen reflects at cos θo = `mu` (the largest channel's), and so takes from the
    /// layers under it.
    #[inline]
    fn sheen_albedo(&self, mu: f32) -> f32 {
        if self.sheen == Vec3::ZERO {
            return 0.0;
        }
        (self.sheen.max_element() * sheen::albedo(mu, self.sheen_roughness)).clamp(0.0, 1.0)
    }

    /// The probability of sampling the sheen at `wo`, against the layers under it.
    #[inline]
    fn sheen_probability(&self, wo: Vec3, sheen_albedo: f32, lost: f32) -> f32 {
        if sheen_albedo <= 0.0 {
            return 0.0;
        }
        let (s, d) = self.base_albedos(wo, lost);
        layer_share(sheen_albedo, s + d)
    }

    /// The same under a clear coat of weight `factor` and roughness `roughness` (both clamped
    /// to [0, 1]).
    pub fn with_clearcoat(self, factor: f32, roughness: f32) -> PbrBsdf {
        let coat = if factor.is_nan() { 0.0 } else { factor.clamp(0.0, 1.0) };
        PbrBsdf { coat, coat_ggx: Ggx::from_roughness(roughness), ..self }
    }

    /// The same with the coat's own normal `n` (a unit vector in the shading frame, above its
    /// plane: the caller turns it to face the viewer), from the coat's normal map; `Vec3::Z`
    /// is the shading normal itself. Without a coat, or given a normal that is not usable
    /// (not finite, zero, or below the shading plane), the BSDF is unchanged.
    pub fn with_coat_normal(self, n: Vec3) -> PbrBsdf {
        match n.try_normalize() {
            Some(n) if self.coat > 0.0 && n.z > MIN_COS => PbrBsdf { coat_normal: n, ..self },
            _ => self,
        }
    }

    /// The coat's frame (z along its normal), where its normal is not the shading normal.
    #[inline]
    fn coat_frame(&self) -> Option<Frame> {
        (self.coat_normal != Vec3::Z).then(|| Frame::from_normal(self.coat_normal))
    }

    /// [`BsdfModel::eval`] where the coat has its own normal (`frame`: the coat's frame). The
    /// layers under the coat are bounded by the shading plane; the coat's lobe by its own,
    /// and its cosine is to its own normal: f_coat(wo, wi) cos θi,coat / |cos θi|, since the
    /// caller multiplies by |cos θi| (to the shading normal). So the coat reflects its albedo
    /// at its own normal, as a smooth coat's mirror does, also toward directions just below
    /// the shading plane (the caller keeps what leaves above the geometric surface).
    fn eval_own_coat_normal(&self, frame: &Frame, wo: Vec3, wi: Vec3) -> Vec3 {
        if wo.z <= MIN_COS || wi.z.abs() <= MIN_COS {
            return Vec3::ZERO;
        }
        let (wo_c, wi_c) = (frame.to_local(wo), frame.to_local(wi));
        let coat = self.coat_eval(wo_c, wi_c) * (wi_c.z / wi.z.abs());
        if wi.z <= MIN_COS {
            return coat;
        }
        self.inner_eval(wo, wi, self.lost(wo.z)) * (1.0 - self.coat_albedo(wo_c.z)) + coat
    }

    /// [`BsdfModel::pdf`] where the coat has its own normal, bounded as
    /// [`PbrBsdf::eval_own_coat_normal`] is.
    fn pdf_own_coat_normal(&self, frame: &Frame, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= MIN_COS || wi.z.abs() <= MIN_COS {
            return 0.0;
        }
        let (wo_c, wi_c) = (frame.to_local(wo), frame.to_local(wi));
        let lost = self.lost(wo.z);
        let inner = if wi.z > MIN_COS { self.inner_pdf(wo, wi, lost) } else { 0.0 };
        let pc = self.coat_probability(wo, self.coat_albedo(wo_c.z), lost);
        pc * self.coat_pdf(wo_c, wi_c) + (1.0 - pc) * inner
    }

    /// The coat's directional albedo at cos θo = `mu` (to the coat's normal), times its
    /// weight: what it reflects, and so what it takes from the layers under it. Nothing where
    /// `wo` lies below the coat's plane (only a coat normal of its own can put it there).
    #[inline]
    fn coat_albedo(&self, mu: f32) -> f32 {
        if self.coat <= 0.0 || mu <= MIN_COS {
            return 0.0;
        }
        let e = if self.coat_ggx.is_smooth() {
            fresnel_dielectric(mu, COAT_IOR)
        } else {
            dielectric_albedo(mu, self.coat_ggx.alpha(), COAT_IOR)
        };
        (self.coat * e).clamp(0.0, 1.0)
    }

    /// The probability of sampling the coat at `wo` (in the shading frame), given its
    /// `coat_albedo` there: its share of the albedo, against the layers under it (scaled by
    /// what it leaves).
    #[inline]
    fn coat_probability(&self, wo: Vec3, coat_albedo: f32, lost: f32) -> f32 {
        if coat_albedo <= 0.0 {
            return 0.0;
        }
        let (s, d) = self.base_albedos(wo, lost);
        let sh = self.sheen_albedo(wo.z);
        layer_share(coat_albedo, sh + (1.0 - sh) * (s + d))
    }

    /// The dielectric layer's reflectance at a microfacet seen at cos θ = `c`.
    #[inline]
    fn dielectric_fresnel(&self, c: f32) -> Vec3 {
        self.spec_a + self.spec_b * fresnel_dielectric(c, self.eta)
    }

    /// (1 − E(μ)) / E(μ) for this lobe's width: what the multiple-scattering compensation
    /// adds per unit of F0 (0 for a smooth layer).
    #[inline]
    fn lost(&self, mu: f32) -> f32 {
        if self.ggx.is_smooth() {
            return 0.0;
        }
        let e = ggx_albedo(mu, self.ggx.alpha()).max(1e-3);
        (1.0 - e) / e
    }

    /// The directional albedo of the dielectric specular layer at cos θo = `mu` (per
    /// channel, compensated), with `lost` from [`PbrBsdf::lost`].
    #[inline]
    fn dielectric_albedo(&self, mu: f32, lost: f32) -> Vec3 {
        let alpha = self.ggx.alpha();
        let (e1, ed) = if self.ggx.is_smooth() {
            (1.0, fresnel_dielectric(mu, self.eta))
        } else {
            (ggx_albedo(mu, alpha), dielectric_albedo(mu, alpha, self.eta))
        };
        let f0 = self.spec_a + self.spec_b * dielectric_f0(self.eta);
        ((self.spec_a * e1 + self.spec_b * ed) * (Vec3::ONE + f0 * lost)).clamp(Vec3::ZERO, Vec3::ONE)
    }

    /// The diffuse base's weight at cos θo = `mu`: (1 − m) times what the dielectric layer
    /// leaves.
    #[inline]
    fn diffuse_weight(&self, mu: f32, lost: f32) -> Vec3 {
        (1.0 - self.metallic) * (Vec3::ONE - self.dielectric_albedo(mu, lost))
    }

    /// The luminances of the specular and diffuse albedos at `wo` (under any coat).
    #[inline]
    fn base_albedos(&self, wo: Vec3, lost: f32) -> (f32, f32) {
        let m = self.metallic;
        let spec = (1.0 - m) * self.dielectric_albedo(wo.z, lost) + m * fresnel_schlick(self.base, wo.z);
        let diffuse = self.base * self.diffuse_weight(wo.z, lost);
        (luminance(spec).max(0.0), luminance(diffuse).max(0.0))
    }

    /// The probability of sampling the specular lobe at `wo` (wo.z > 0) rather than the
    /// diffuse one: its share of the albedo there.
    #[inline]
    fn specular_probability(&self, wo: Vec3, lost: f32) -> f32 {
        let (s, d) = self.base_albedos(wo, lost);
        if d <= 0.0 {
            1.0
        } else if s <= 0.0 {
            0.0
        } else {
            s / (s + d)
        }
    }

    /// The specular lobe's reflectance at a microfacet seen at cos θ = `c`, compensated.
    #[inline]
    fn specular_fresnel(&self, c: f32, lost: f32) -> Vec3 {
        let m = self.metallic;
        let f0d = self.spec_a + self.spec_b * dielectric_f0(self.eta);
        let dielectric = self.dielectric_fresnel(c) * (Vec3::ONE + f0d * lost);
        let metal = fresnel_schlick(self.base, c) * (Vec3::ONE + self.base * lost);
        (1.0 - m) * dielectric + m * metal
    }
}

impl PbrBsdf {
    /// The layers under the coat: f(wo, wi), not scaled by what the coat leaves.
    #[inline]
    fn base_eval(&self, wo: Vec3, wi: Vec3, lost: f32) -> Vec3 {
        let diffuse = self.base * self.diffuse_weight(wo.z, lost) * FRAC_1_PI;
        if self.ggx.is_smooth() {
            return diffuse;
        }
        let Some(wm) = (wo + wi).try_normalize() else {
            return diffuse;
        };
        diffuse + self.specular_fresnel(wo.dot(wm), lost) * (self.ggx.d(wm) * self.ggx.visibility(wo, wi))
    }

    /// The pdf of sampling the layers under the coat.
    #[inline]
    fn base_pdf(&self, wo: Vec3, wi: Vec3, lost: f32) -> f32 {
        let p = self.specular_probability(wo, lost);
        let diffuse = (1.0 - p) * cosine_hemisphere_pdf(wi);
        if self.ggx.is_smooth() {
            return diffuse;
        }
        let specular = match (wo + wi).try_normalize() {
            Some(wm) => self.ggx.reflection_pdf(wo, wm),
            None => 0.0,
        };
        p * specular + diffuse
    }

    /// The layers under the coat: the sheen over the base, which keeps what it leaves.
    #[inline]
    fn inner_eval(&self, wo: Vec3, wi: Vec3, lost: f32) -> Vec3 {
        let base = self.base_eval(wo, wi, lost);
        if self.sheen == Vec3::ZERO {
            return base;
        }
        base * (1.0 - self.sheen_albedo(wo.z)) + self.sheen * sheen::eval(wo, wi, self.sheen_alpha)
    }

    #[inline]
    fn inner_pdf(&self, wo: Vec3, wi: Vec3, lost: f32) -> f32 {
        let base = self.base_pdf(wo, wi, lost);
        if self.sheen == Vec3::ZERO {
            return base;
        }
        let ps = self.sheen_probability(wo, self.sheen_albedo(wo.z), lost);
        ps * cosine_hemisphere_pdf(wi) + (1.0 - ps) * base
    }

    /// The rough coat's f(wo, wi), both in the coat's frame (0 for a smooth one: a delta
    /// reflection; 0 where either lies below the coat's plane).
    #[inline]
    fn coat_eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if self.coat <= 0.0 || self.coat_ggx.is_smooth() || !same_hemisphere_above(wo, wi) {
            return Vec3::ZERO;
        }
        let Some(wm) = (wo + wi).try_normalize() else { return Vec3::ZERO };
        let f = fresnel_dielectric(wo.dot(wm), COAT_IOR);
        Vec3::splat(self.coat * f * self.coat_ggx.d(wm) * self.coat_ggx.visibility(wo, wi))
    }

    /// The pdf of sampling the rough coat's lobe, `wo` and `wi` in the coat's frame.
    #[inline]
    fn coat_pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if self.coat_ggx.is_smooth() || !same_hemisphere_above(wo, wi) {
            return 0.0;
        }
        (wo + wi).try_normalize().map_or(0.0, |wm| self.coat_ggx.reflection_pdf(wo, wm))
    }
}

impl BsdfModel for PbrBsdf {
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if let Some(frame) = self.coat_frame() {
            return self.eval_own_coat_normal(&frame, wo, wi);
        }
        if !same_hemisphere_above(wo, wi) {
            return Vec3::ZERO;
        }
        let lost = self.lost(wo.z);
        let inner = self.inner_eval(wo, wi, lost);
        if self.coat <= 0.0 {
            return inner;
        }
        inner * (1.0 - self.coat_albedo(wo.z)) + self.coat_eval(wo, wi)
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if let Some(frame) = self.coat_frame() {
            return self.pdf_own_coat_normal(&frame, wo, wi);
        }
        if !same_hemisphere_above(wo, wi) {
            return 0.0;
        }
        let lost = self.lost(wo.z);
        let inner = self.inner_pdf(wo, wi, lost);
        if self.coat <= 0.0 {
            return inner;
        }
        let pc = self.coat_probability(wo, self.coat_albedo(wo.z), lost);
        pc * self.coat_pdf(wo, wi) + (1.0 - pc) * inner
    }

    fn sample(&self, wo: Vec3, u: Vec2, uc: f32) -> Option<BsdfSample> {
        if wo.z <= MIN_COS {
            return None;
        }
        let lost = self.lost(wo.z);
        let frame = self.coat_frame();
        let wo_c = frame.as_ref().map_or(wo, |f| f.to_local(wo));
        let coat_albedo = self.coat_albedo(wo_c.z);
        let pc = self.coat_probability(wo, coat_albedo, lost);
        let wi = if uc < pc {
            // In the coat's frame, kept where it leaves above the coat's plane (and off the
            // shading plane, whose cosine the caller multiplies by).
            if self.coat_ggx.is_smooth() {
                let wi = frame.as_ref().map_or_else(|| reflect_z(wo), |f| f.to_world(reflect_z(wo_c)));
                if wi.z.abs() <= MIN_COS {
                    return None;
                }
                let f = self.coat * fresnel_dielectric(wo_c.z, COAT_IOR) / wi.z.abs();
                return Some(BsdfSample { wi, f: Vec3::splat(f), pdf: pc, delta: true });
            }
            let wi_c = reflect(wo_c, self.coat_ggx.sample_visible_normal(wo_c, u));
            match &frame {
                None => wi_c,
                Some(f) => {
                    let wi = f.to_world(wi_c);
                    if wi_c.z <= MIN_COS || wi.z.abs() <= MIN_COS {
                        return None;
                    }
                    return Some(BsdfSample { wi, f: self.eval(wo, wi), pdf: self.pdf(wo, wi), delta: false });
                }
            }
        } else {
            // What is left of `uc`, for the layers under the coat: the sheen, then the base.
            let rest = |uc: f32, p: f32| {
                if p > 0.0 { ((uc - p) / (1.0 - p)).clamp(0.0, 1.0 - f32::EPSILON / 2.0) } else { uc }
            };
            let uc = rest(uc, pc);
            let sheen_albedo = self.sheen_albedo(wo.z);
            let ps = self.sheen_probability(wo, sheen_albedo, lost);
            if uc < ps {
                sample_cosine_hemisphere(u)
            } else {
                let uc = rest(uc, ps);
                let p = self.specular_probability(wo, lost);
                if uc < p {
                    if self.ggx.is_smooth() {
                        let f = self.specular_fresnel(wo.z, 0.0) * ((1.0 - coat_albedo) * (1.0 - sheen_albedo)) / wo.z;
                        return Some(BsdfSample {
                            wi: reflect_z(wo),
                            f,
                            pdf: (1.0 - pc) * (1.0 - ps) * p,
                            delta: true,
                        });
                    }
                    reflect(wo, self.ggx.sample_visible_normal(wo, u))
                } else {
                    sample_cosine_hemisphere(u)
                }
            }
        };
        if wi.z <= MIN_COS {
            return None;
        }
        Some(BsdfSample { wi, f: self.eval(wo, wi), pdf: self.pdf(wo, wi), delta: false })
    }

    /// Specular or diffuse.
    #[inline(always)]
    fn chooses_lobe(&self) -> bool {
        true
    }

    /// A smooth surface without a diffuse base (a mirror-like metal), under no coat or a
    /// smooth one, without sheen.
    fn is_delta(&self) -> bool {
        self.ggx.is_smooth()
            && ((1.0 - self.metallic) * self.base).max_element() <= 0.0
            && (self.coat <= 0.0 || self.coat_ggx.is_smooth())
            && self.sheen == Vec3::ZERO
    }

    /// The base colour, seen through the dielectric's 4 % where it is not metal.
    fn denoise_albedo(&self) -> Vec3 {
        let dielectric = Vec3::splat(0.04) + 0.96 * self.base;
        dielectric.lerp(self.base, self.metallic)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A coat normal tilted 20° from the shading normal, off the axes.
    fn tilted() -> Vec3 {
        let (s, c) = 20f32.to_radians().sin_cos();
        Vec3::new(s * 0.8, s * -0.6, c)
    }

    /// Directions above the shading plane, from straight up to grazing, off the axes.
    fn directions() -> Vec<Vec3> {
        let mut out = Vec::new();
        for theta in [0.0f32, 10.0, 35.0, 60.0, 80.0, 89.0] {
            for phi in [0.3f32, 1.9, 3.5, 5.2] {
                let (st, ct) = theta.to_radians().sin_cos();
                out.push(Vec3::new(st * phi.cos(), st * phi.sin(), ct));
            }
        }
        out
    }

    fn coated(roughness: f32, coat_roughness: f32) -> PbrBsdf {
        PbrBsdf::new(Vec3::new(0.8, 0.3, 0.1), 0.0, roughness, 1.5, 1.0, Vec3::ONE)
            .with_sheen(Vec3::new(0.3, 0.2, 0.1), 0.4)
            .with_clearcoat(0.9, coat_roughness)
    }

    #[test]
    fn a_coat_normal_along_the_shading_normal_changes_nothing() {
        for (roughness, coat_roughness) in [(0.6, 0.0), (0.0, 0.0), (0.5, 0.2), (0.0, 0.7)] {
            let plain = coated(roughness, coat_roughness);
            let same = plain.with_coat_normal(Vec3::Z);
            assert_eq!(plain, same);
            for &wo in &directions() {
                for &wi in &directions() {
                    assert_eq!(plain.eval(wo, wi), same.eval(wo, wi));
                    assert_eq!(plain.pdf(wo, wi), same.pdf(wo, wi));
                }
                for k in 0..64 {
                    let u = Vec2::new((k % 8) as f32 / 8.0 + 0.03, (k / 8) as f32 / 8.0 + 0.05);
                    for uc in [0.0, 0.01, 0.2, 0.5, 0.9, 0.999] {
                        assert_eq!(plain.sample(wo, u, uc), same.sample(wo, u, uc));
                    }
                }
            }
        }
        // Without a coat a coat normal is ignored.
        let bare = PbrBsdf::new(Vec3::ONE, 0.0, 0.4, 1.5, 1.0, Vec3::ONE);
        assert_eq!(bare.with_coat_normal(tilted()), bare);
    }

    #[test]
    fn a_smooth_coat_reflects_about_its_own_normal() {
        let n = tilted();
        let bsdf = coated(0.6, 0.0).with_coat_normal(n);
        let mut delta = 0;
        for &wo in directions().iter().filter(|wo| wo.dot(n) > 0.05) {
            let want = reflect(wo, n);
            let s = bsdf.sample(wo, Vec2::new(0.4, 0.7), 0.0).unwrap();
            assert!(s.delta && (s.wi - want).length() < 1e-5, "wo {wo}: {s:?}, want {want}");
            // The weight (f |cos θi| / pdf) is the coat's Fresnel at its own normal over the
            // lobe's probability, wherever the mirror direction leaves (below the shading
            // plane too: the caller keeps it if it is above the geometric surface).
            let fresnel = 0.9 * fresnel_dielectric(wo.dot(n), COAT_IOR);
            let weight = s.f.x * s.wi.z.abs();
            assert!((weight - fresnel).abs() < 1e-5, "wo {wo}: {weight} vs {fresnel}");
            // The layers under it keep what the coat leaves at its own normal.
            let wi = Vec3::new(0.1, 0.5, 0.8).normalize();
            let under = coated(0.6, 0.0);
            let kept = under.eval(wo, wi) / (1.0 - 0.9 * fresnel_dielectric(wo.z, COAT_IOR));
            let expected = kept * (1.0 - fresnel);
            assert!((bsdf.eval(wo, wi) - expected).abs().max_element() < 1e-5 * expected.max_element().max(1.0));
            delta += 1;
        }
        assert!(delta > 10, "{delta} directions checked");
    }

    #[test]
    fn a_rough_coat_lobe_follows_its_own_normal() {
        // A rough coat over a black base: its lobe peaks about the mirror direction of its own
        // normal, far above the shading normal's.
        let n = tilted();
        let bsdf =
            PbrBsdf::new(Vec3::ZERO, 0.0, 0.5, 1.5, 1.0, Vec3::ONE).with_clearcoat(1.0, 0.15).with_coat_normal(n);
        let wo = Vec3::new(-0.3, 0.2, 0.9).normalize();
        let (own, shading) = (reflect(wo, n), reflect_z(wo));
        let (f_own, f_shading) = (bsdf.eval(wo, own).x, bsdf.eval(wo, shading).x);
        assert!(f_own > 20.0 * f_shading, "{f_own} at its mirror direction, {f_shading} at the shading one");
        assert!(bsdf.pdf(wo, own) > 20.0 * bsdf.pdf(wo, shading));
        // Sampled directions gather about its own mirror direction.
        let mut closer = 0;
        for k in 0..256 {
            let u = Vec2::new((k % 16) as f32 / 16.0 + 0.02, (k / 16) as f32 / 16.0 + 0.02);
            if let Some(s) = bsdf.sample(wo, u, 0.0) {
                closer += usize::from(s.wi.dot(own) > s.wi.dot(shading));
                let (f, pdf) = (bsdf.eval(wo, s.wi), bsdf.pdf(wo, s.wi));
                assert!((s.f - f).abs().max_element() <= 1e-4 * f.max_element() && (s.pdf - pdf).abs() <= 1e-4 * pdf);
            }
        }
        assert!(closer > 200, "{closer} of 256 samples nearer the coat's mirror direction");
    }
}

//! Lights: what a scene describes ([`Light`]: point lights and the background), emitting
//! triangles and spheres (area lights: surfaces whose material emits), and [`LightSet`], which
//! chooses one (by its importance at the shading point: among a few groups in `choice`,
//! through a light tree in `tree` for many lights; by power where told) and samples a
//! direction toward it, for next-event estimation; its `pdf_*` methods give the matching
//! densities for multiple importance sampling.
//!
//! Each kind is a file: `point.rs`, `background.rs` (sky and environment; an environment
//! image and its sampling by luminance in `environment.rs`), `triangle.rs` and `sphere.rs`
//! (emitting surfaces), with how it is sampled, its density, its power and its bounds for the
//! choice by importance. Adding a kind: its file, a [`Light`] variant (if a
//! scene describes it) and an [`Emitter`] variant with their arms here, and its `[[lights]]`
//! section (`scene/format.rs`) with the arm that builds it (`scene/toml_file.rs`).

mod background;
mod choice;
mod distribution;
mod emission;
mod environment;
mod point;
mod sphere;
mod tree;
mod triangle;
pub mod visibility;

pub use background::Background;
pub use emission::{Emission, Emitters};
pub use environment::Environment;
pub use point::PointLight;
pub(crate) use sphere::sample_cone;

use crate::geometry::{Geometry, bounds_of};
use crate::hash::Fingerprint;
use crate::settings::LightTreeMode;
use crate::texture::Texture;
use choice::{LOCAL_CHOICE_MAX, LightBounds, LocalChoice};
use glam::{Vec2, Vec3};
use sphere::EmissiveSphere;
use tree::LightTree;
use triangle::EmissiveTriangle;

/// A set whose largest group (an emitting mesh) has more lights than this is chosen through
/// a light tree (as is one of more than [`LOCAL_CHOICE_MAX`] groups).
const TREE_GROUP_MIN: u32 = 16;

/// A light a scene describes, as opposed to a surface whose material emits.
#[derive(Clone, Debug, PartialEq)]
pub enum Light {
    Point(PointLight),
    /// What rays leaving the scene see; a light unless black. A scene has at most one.
    Background(Background),
}

impl Light {
    /// Whether it gives any light.
    pub fn emits(&self) -> bool {
        match self {
            Light::Point(l) => l.emits(),
            Light::Background(b) => !b.is_black(),
        }
    }

    /// Whether BSDF sampling can never find it (so no MIS): a point.
    pub fn is_delta(&self) -> bool {
        matches!(self, Light::Point(_))
    }

    /// Feeds the light to a fingerprint.
    pub fn fingerprint(&self, h: &mut Fingerprint) {
        match self {
            Light::Point(l) => l.fingerprint(h),
            Light::Background(b) => b.fingerprint(h),
        }
    }
}

/// What next-event estimation samples: one light of a [`LightSet`].
#[derive(Clone, Debug, PartialEq)]
enum Emitter {
    Point(PointLight),
    Triangle(EmissiveTriangle),
    Sphere(EmissiveSphere),
    Background,
}

/// A sampled light direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightSample {
    /// Unit direction from the shading point toward the light.
    pub wi: Vec3,
    /// Point on the light (for shadow rays); `None` for the background (infinitely far).
    pub point: Option<Vec3>,
    /// Unit normal of the light's surface at `point` (zero for point lights).
    pub normal: Vec3,
    /// Radiance arriving along `wi` (for point lights: intensity / distance²).
    pub radiance: Vec3,
    /// Solid-angle density including the light choice; for point lights the choice
    /// probability alone.
    pub pdf: f32,
    /// Point lights: the sample cannot be hit by BSDF sampling, so no MIS.
    pub delta: bool,
    /// Which light of the set (filled in by [`LightSet::sample`]).
    pub light: u32,
}

impl LightSample {
    /// The shadow ray from `o` toward this sample, and how far along it to look: toward a
    /// point on a light, stopping just short of it (the light's own surface is not an
    /// occluder), in units of the whole segment; toward the background, without end.
    #[inline(always)]
    pub fn shadow_ray(&self, o: Vec3) -> (crate::geometry::Ray, f32) {
        match self.point {
            Some(q) => {
                let q = if self.delta { q } else { crate::geometry::offset_toward(q, self.normal, o - q) };
                (crate::geometry::Ray::new(o, q - o), 1.0)
            }
            None => (crate::geometry::Ray::new(o, self.wi), f32::INFINITY),
        }
    }
}

/// A point light chosen to emit from (see [`LightSet::choose_point_by_power`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointEmission {
    /// Which light of the set.
    pub light: u32,
    pub position: Vec3,
    pub intensity: Vec3,
    /// The probability of this choice.
    pub prob: f32,
}

/// Which light of the set each primitive of a geometry is.
#[derive(Clone, Debug, PartialEq)]
enum PrimitiveLights {
    /// None of its primitives emits.
    None,
    /// Every primitive emits: primitive i is light base + i.
    Range(u32),
    /// Per primitive (`u32::MAX`: not a light).
    PerPrim(Vec<u32>),
}

/// Lights that the choice by importance takes as one: the emissive triangles of one mesh
/// (a quad light is two triangles; an emissive model may be thousands), or a single sphere,
/// point light or the background. The group is chosen by its importance at the shading
/// point, then a light within it by power.
#[derive(Clone, Debug)]
struct Group {
    /// Its lights are `start..end` of [`LightSet::lights`].
    start: u32,
    end: u32,
    /// The power-proportional probability of all its lights together.
    prob: f32,
}

/// How a light is chosen at one shading point ([`LightSet::choice_at`]), and which side of it
/// the skies light ([`LightChoice::facing`]).
#[derive(Clone, Copy, Debug)]
pub struct LightChoice(How, Vec3);

#[derive(Clone, Copy, Debug)]
enum How {
    /// In proportion to power.
    Power,
    /// Among a few groups by their importance at the point.
    Groups(LocalChoice),
    /// Through the light tree at `p`; the background (if any) is chosen with probability
    /// `1 - tree`.
    Tree { p: Vec3, tree: f32 },
}

impl LightChoice {
    /// In proportion to power, wherever the point.
    pub const BY_POWER: LightChoice = LightChoice(How::Power, Vec3::ZERO);

    /// The same at a point of an opaque surface lit on the side `n` faces (its geometric
    /// normal, turned toward the viewer): the constant and gradient skies are sampled by the
    /// cosine about it (`background.rs`). Without it, or with `n` zero (glass, lit from both
    /// sides), they are sampled over the whole sphere.
    #[inline]
    pub fn facing(self, n: Vec3) -> LightChoice {
        LightChoice(self.0, n)
    }
}

/// All lights of a scene, and how one is chosen.
#[derive(Clone, Debug)]
pub struct LightSet {
    lights: Vec<Emitter>,
    /// What the choice by importance treats as one light (see [`Group`]), and which group
    /// each light is in.
    groups: Vec<Group>,
    group_of: Vec<u32>,
    /// Per group, for the choice by importance at a point (2 to [`LOCAL_CHOICE_MAX`]
    /// groups, no tree); empty otherwise.
    bounds: Vec<LightBounds>,
    /// The light tree over every light but the background, and the background's importance
    /// (the same at every point) that the tree's root is weighed against.
    tree: Option<LightTree>,
    background_importance: f32,
    /// Where next-event estimation's light samples get through, weighing the choice by
    /// importance ([`visibility`]); `None`: importance alone.
    visibility: Option<std::sync::Arc<visibility::Visibility>>,
    /// The power-proportional choice: larger sets, and the fallback where importances are
    /// unusable.
    cdf: Vec<f32>,
    prob: Vec<f32>,
    /// Per geometry of the scene.
    primitive_lights: Vec<PrimitiveLights>,
    background: Background,
    background_index: Option<usize>,
    /// Which random numbers [`LightSet::sample`] uses (see [`LightSet::numbers`]).
    numbers: LightNumbers,
}

/// The random numbers a light sample uses: the choice of a light (more than one light that
/// can be chosen: lights of zero power never are) and a point on it (any such light but a
/// point light). A path draws only these, so the well-spread first dimensions of a sample go
/// to decisions that use them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LightNumbers {
    pub choice: bool,
    pub position: bool,
}

pub(crate) fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

impl LightSet {
    /// The lights of a scene: every primitive of `geometry` whose emission
    /// (`emission(geom, prim)`, possibly a texture) is not black over it (triangles and
    /// spheres; cylinders are not sampled), then the described `lights` in their order, the
    /// background last (unless black).
    ///
    /// With [`LightTreeMode::Auto`], a set of more than [`LOCAL_CHOICE_MAX`] groups, or with
    /// a group of more than [`TREE_GROUP_MIN`] lights, is chosen through a light tree.
    pub fn new<'a>(
        geometry: &[Geometry],
        emission: &dyn Fn(u32, u32) -> &'a Texture,
        lights: &[Light],
        mode: LightTreeMode,
    ) -> LightSet {
        let mut emitters = Vec::new();
        let mut primitive_lights = Vec::new();
        let mut spans: Vec<(u32, u32)> = Vec::new();
        for (gi, g) in geometry.iter().enumerate() {
            let gi = gi as u32;
            let base = emitters.len() as u32;
            let mut per = Vec::new();
            match g {
                Geometry::Mesh(_) | Geometry::Instance(_) => {
                    let m = g.mesh().expect("a mesh has triangles");
                    for i in 0..m.triangle_count() {
                        let t = match emission(gi, i as u32) {
                            Texture::Constant(e) if e.max_element() > 0.0 => EmissiveTriangle::new(g.triangle(i), *e),
                            Texture::Constant(_) => None,
                            e => EmissiveTriangle::textured(m, i, g.triangle(i), e),
                        };
                        let Some(t) = t.filter(|t| t.emission.max_element() > 0.0) else {
                            per.push(u32::MAX);
                            continue;
                        };
                        per.push(emitters.len() as u32);
                        emitters.push(Emitter::Triangle(t));
                    }
                    if emitters.len() as u32 > base {
                        spans.push((base, emitters.len() as u32));
                    }
                }
                Geometry::Spheres(s) => {
                    for (i, sp) in s.iter().enumerate() {
                        let e = emission(gi, i as u32);
                        if e.max().max_element() <= 0.0 {
                            per.push(u32::MAX);
                            continue;
                        }
                        per.push(emitters.len() as u32);
                        spans.push((emitters.len() as u32, emitters.len() as u32 + 1));
                        emitters.push(Emitter::Sphere(EmissiveSphere::new(*sp, e)));
                    }
                }
                Geometry::Cylinders(_) => {}
            }
            primitive_lights.push(if per.iter().all(|&x| x == u32::MAX) {
                PrimitiveLights::None
            } else if per.iter().enumerate().all(|(i, &x)| x == base + i as u32) {
                PrimitiveLights::Range(base)
            } else {
                PrimitiveLights::PerPrim(per)
            });
        }
        let mut background = Background::Black;
        for light in lights {
            match light {
                Light::Point(pl) => {
                    spans.push((emitters.len() as u32, emitters.len() as u32 + 1));
                    emitters.push(Emitter::Point(*pl));
                }
                Light::Background(b) => background = b.clone(),
            }
        }
        let mut background_index = None;
        if !background.is_black() {
            background_index = Some(emitters.len());
            spans.push((emitters.len() as u32, emitters.len() as u32 + 1));
            emitters.push(Emitter::Background);
        }
        let power: Vec<f32> = emitters
            .iter()
            .map(|e| match e {
                Emitter::Point(l) => l.power(),
                Emitter::Triangle(t) => t.power(),
                Emitter::Sphere(s) => s.power(),
                Emitter::Background => {
                    // Over the scene's bounding sphere.
                    let r = 0.5 * bounds_of(geometry).diagonal().length();
                    background.power(if r.is_finite() && r > 0.0 { r } else { 1.0 })
                }
            })
            .collect();
        let total: f32 = power.iter().sum();
        let prob: Vec<f32> = if total > 0.0 && total.is_finite() {
            power.iter().map(|p| p / total).collect()
        } else {
            vec![1.0 / emitters.len().max(1) as f32; emitters.len()]
        };
        let groups: Vec<Group> = spans
            .iter()
            .map(|&(start, end)| Group { start, end, prob: prob[start as usize..end as usize].iter().sum() })
            .collect();
        let mut group_of = vec![0; emitters.len()];
        for (g, &(start, end)) in spans.iter().enumerate() {
            group_of[start as usize..end as usize].fill(g as u32);
        }
        let many = groups.len() > LOCAL_CHOICE_MAX || groups.iter().any(|g| g.end - g.start > TREE_GROUP_MIN);
        let tree = if mode == LightTreeMode::Auto && many {
            LightTree::build(
                emitters.len(),
                emitters.iter().enumerate().filter_map(|(i, e)| {
                    let b = match e {
                        Emitter::Point(l) => l.tree_bounds(),
                        Emitter::Triangle(t) => t.tree_bounds(),
                        Emitter::Sphere(s) => s.tree_bounds(),
                        Emitter::Background => return None,
                    };
                    Some((i as u32, b))
                }),
            )
        } else {
            None
        };
        let background_importance =
            if background.is_black() { 0.0 } else { background.bounds().importance(Vec3::ZERO) };
        let bounds = if tree.is_none() && (2..=LOCAL_CHOICE_MAX).contains(&groups.len()) {
            groups.iter().map(|g| group_bounds(&emitters[g.start as usize..g.end as usize], &background)).collect()
        } else {
            Vec::new()
        };
        let mut acc = 0.0;
        let cdf = prob
            .iter()
            .map(|p| {
                acc += p;
                acc
            })
            .collect();
        // Lights that can be chosen: those of zero power (zero area) never are.
        let chosen = || emitters.iter().zip(&prob).filter(|&(_, &p)| p > 0.0).map(|(e, _)| e);
        let numbers =
            LightNumbers { choice: chosen().count() > 1, position: chosen().any(|e| !matches!(e, Emitter::Point(_))) };
        LightSet {
            numbers,
            lights: emitters,
            groups,
            group_of,
            bounds,
            tree,
            background_importance,
            visibility: None,
            cdf,
            prob,
            primitive_lights,
            background,
            background_index,
        }
    }

    /// The most memory a set of `lights` emitting primitives takes (a textured triangle's
    /// corner coordinates and cell distribution, the choice's tables and a light tree counted
    /// for each), for the memory budget before it is built.
    pub fn bytes_for(lights: u64) -> u64 {
        let per = std::mem::size_of::<Emitter>()
            + std::mem::size_of::<triangle::TriangleTexture>()
            + triangle::CELL_BYTES
            + 4 * 4 // probability, cumulative sum, group, the primitive's light
            + tree::BYTES_PER_LIGHT;
        lights.saturating_mul(per as u64)
    }

    /// The background (black if the scene has none).
    pub fn background(&self) -> &Background {
        &self.background
    }

    pub fn is_empty(&self) -> bool {
        self.lights.is_empty()
    }

    /// Which of [`LightSet::sample`]'s random numbers change its result: with one light the
    /// choice does not, with only point lights the position does not.
    #[inline]
    pub fn numbers(&self) -> LightNumbers {
        self.numbers
    }

    pub fn len(&self) -> usize {
        self.lights.len()
    }

    /// One line for `ember info`: how many lights, in how many groups, and how next-event
    /// estimation chooses among them, e.g. `3 lights in 2 groups: a group chosen by
    /// importance at each shading point, a light within it by power`.
    pub fn describe(&self) -> String {
        let (n, g) = (self.lights.len(), self.groups.len());
        let how = if n <= 1 {
            "nothing to choose".to_string()
        } else if let Some(t) = &self.tree {
            format!("chosen by importance at each shading point through a light tree of depth {}", t.depth())
        } else if !self.bounds.is_empty() {
            "a group chosen by importance at each shading point, a light within it by power".to_string()
        } else if g == 1 {
            "chosen by power".to_string()
        } else {
            format!("chosen by power (more than {LOCAL_CHOICE_MAX} groups)")
        };
        let s = |k: usize| if k == 1 { "" } else { "s" };
        format!("{n} light{} in {g} group{}: {how}", s(n), s(g))
    }

    /// How next-event estimation chooses a light at the shading point `p`. Computed once per
    /// vertex: it serves [`LightSet::sample`] there and, at the next vertex, the densities
    /// MIS weighs a BSDF-sampled ray's find against ([`LightSet::pdf_emitter`],
    /// [`LightSet::pdf_background`]).
    #[inline(always)]
    pub fn choice_at(&self, p: Vec3) -> LightChoice {
        if !self.bounds.is_empty() {
            self.local_choice(p, None)
        } else if self.tree.is_some() {
            self.tree_choice(p)
        } else {
            LightChoice::BY_POWER
        }
    }

    /// Out of line, so that kernels for one light (or many) carry none of its code.
    #[inline(never)]
    fn local_choice(&self, p: Vec3, weights: Option<&[f32; LOCAL_CHOICE_MAX]>) -> LightChoice {
        LightChoice(LocalChoice::at(&self.bounds, p, weights).map_or(How::Power, How::Groups), Vec3::ZERO)
    }

    /// [`LightSet::choice_at`] `p` of a surface lit on the side `n` faces (zero: both), as
    /// [`LightChoice::facing`] `n`; with [`LightSet::with_visibility`] the groups are weighed
    /// by what got through on that side near `p`.
    #[inline(always)]
    pub fn choice_facing(&self, p: Vec3, n: Vec3) -> LightChoice {
        match &self.visibility {
            Some(v) => self.visible_choice(v, p, n),
            None => self.choice_at(p),
        }
        .facing(n)
    }

    /// Out of line, so that kernels without visibility weights carry none of its code.
    #[inline(never)]
    fn visible_choice(&self, v: &visibility::Visibility, p: Vec3, n: Vec3) -> LightChoice {
        self.local_choice(p, v.at(p, n))
    }

    /// Whether next-event estimation chooses among 2 to 8 groups by their importance at the
    /// shading point: what [`LightSet::with_visibility`] can weigh.
    pub fn chooses_by_importance(&self) -> bool {
        !self.bounds.is_empty()
    }

    /// The group light `i` is in.
    #[inline]
    pub fn group_of(&self, i: u32) -> usize {
        self.group_of[i as usize] as usize
    }

    /// The set choosing by importance weighed by `v` (where it chooses by importance).
    pub fn with_visibility(self, v: visibility::Visibility) -> LightSet {
        let visibility = self.chooses_by_importance().then(|| std::sync::Arc::new(v));
        LightSet { visibility, ..self }
    }

    /// The cells where [`LightSet::with_visibility`] weighs some group, if it does.
    pub fn visibility_cells(&self) -> Option<usize> {
        self.visibility.as_ref().map(|v| v.cells())
    }

    /// The tree against the background at `p` (by power where neither can bring light).
    #[inline(never)]
    fn tree_choice(&self, p: Vec3) -> LightChoice {
        let t = self.tree.as_ref().map_or(0.0, |t| t.importance(p));
        let total = t + self.background_importance;
        if !(total > 0.0 && total.is_finite()) {
            return LightChoice::BY_POWER;
        }
        LightChoice(How::Tree { p, tree: t / total }, Vec3::ZERO)
    }

    /// A light of the tree (or the background) chosen at `p`, as [`LightSet::choose`].
    #[inline(never)]
    fn choose_in_tree(&self, p: Vec3, tree: f32, u: f32) -> (usize, f32) {
        match (self.tree.as_ref(), self.background_index) {
            (Some(t), bg) if u < tree || bg.is_none() => {
                let u = if bg.is_some() { (u / tree).min(choice::ONE_BELOW) } else { u };
                t.pick(p, u).map_or((0, 0.0), |(i, prob)| (i, prob * tree))
            }
            (_, Some(bg)) => (bg, 1.0 - tree),
            _ => (0, 0.0),
        }
    }

    /// The probability that [`LightSet::choose_in_tree`] picks light `i`.
    #[inline(never)]
    fn tree_probability(&self, p: Vec3, tree: f32, i: usize) -> f32 {
        if Some(i) == self.background_index {
            return 1.0 - tree;
        }
        self.tree.as_ref().map_or(0.0, |t| tree * t.probability(p, i))
    }

    /// The light that `u` picks, and the probability of that choice.
    #[inline(always)]
    fn choose(&self, choice: &LightChoice, u: f32) -> (usize, f32) {
        let n = self.lights.len();
        if n == 1 {
            return (0, self.prob[0]); // what either choice below gives
        }
        if let How::Tree { p, tree } = choice.0 {
            return self.choose_in_tree(p, tree, u);
        }
        if let How::Groups(c) = &choice.0 {
            let (g, p_group, u) = c.pick(self.groups.len(), u);
            let group = &self.groups[g];
            let (start, end) = (group.start as usize, group.end as usize);
            if end - start == 1 {
                return (start, p_group);
            }
            // Within the group by power, with what is left of `u`.
            let below = if start == 0 { 0.0 } else { self.cdf[start - 1] };
            let target = below + u * group.prob;
            let i = start + distribution::pick_index(&self.cdf[start..end], target);
            return (i, p_group * (self.prob[i] / group.prob));
        }
        let i = distribution::pick_index(&self.cdf, u);
        (i, self.prob[i])
    }

    /// The probability that `choice` picks light `i`.
    #[inline]
    fn choice_probability(&self, choice: &LightChoice, i: usize) -> f32 {
        match &choice.0 {
            How::Tree { p, tree } => self.tree_probability(*p, *tree, i),
            How::Groups(c) => {
                let g = self.group_of[i] as usize;
                let group = &self.groups[g];
                if group.end - group.start == 1 {
                    c.probability(g)
                } else if group.prob > 0.0 {
                    c.probability(g) * (self.prob[i] / group.prob)
                } else {
                    0.0 // a group of zero-area triangles: never chosen
                }
            }
            How::Power => self.prob[i],
        }
    }

    /// Samples a light (as `choice`, made at `p`, picks it) and a direction toward it from
    /// `p`. Inlined into the render kernels, with the rarer sphere and background cases
    /// behind calls.
    #[inline(always)]
    pub fn sample(&self, choice: &LightChoice, p: Vec3, u_choice: f32, u: Vec2) -> Option<LightSample> {
        if self.lights.is_empty() {
            return None;
        }
        let (i, sel) = self.choose(choice, u_choice);
        if sel <= 0.0 {
            return None;
        }
        let sample = match &self.lights[i] {
            Emitter::Point(l) => l.sample(p, sel),
            Emitter::Triangle(t) => t.sample(p, sel, u),
            Emitter::Sphere(s) => s.sample(p, sel, u),
            Emitter::Background => self.background.sample(sel, u, choice.1),
        };
        sample.map(|s| LightSample { light: i as u32, ..s })
    }

    /// A light chosen by power with `u` (the choice [`LightSet::power_probability`] gives),
    /// to emit from if it is a point light (`None` otherwise: the render plan uses this only
    /// where every light is one). Runs once per sample: no pass over the lights.
    #[inline]
    pub fn choose_point_by_power(&self, u: f32) -> Option<PointEmission> {
        if self.lights.is_empty() {
            return None;
        }
        let (i, prob) = self.choose(&LightChoice::BY_POWER, u);
        match &self.lights[i] {
            Emitter::Point(l) if prob > 0.0 => {
                Some(PointEmission { light: i as u32, position: l.position, intensity: l.intensity, prob })
            }
            _ => None,
        }
    }

    /// The probability that [`LightSet::choose_point_by_power`] picks light `i`.
    #[inline]
    pub fn power_probability(&self, i: u32) -> f32 {
        self.prob[i as usize]
    }

    /// The probability that next-event estimation at `p` picks light `i`.
    #[inline]
    pub fn choice_probability_at(&self, p: Vec3, i: u32) -> f32 {
        debug_assert!(self.visibility.is_none(), "light vertices run without visibility weights");
        self.choice_probability(&self.choice_at(p), i as usize)
    }

    /// Which light of the set primitive `prim` of geometry `geom` is, if any.
    #[inline]
    pub fn light_index(&self, geom: u32, prim: u32) -> Option<u32> {
        self.light_of(geom, prim).map(|i| i as u32)
    }

    /// Which light of the set primitive `prim` of geometry `geom` is, if any.
    #[inline]
    fn light_of(&self, geom: u32, prim: u32) -> Option<usize> {
        match self.primitive_lights.get(geom as usize)? {
            PrimitiveLights::Range(base) => Some((base + prim) as usize),
            PrimitiveLights::PerPrim(v) => v.get(prim as usize).filter(|&&i| i != u32::MAX).map(|&i| i as usize),
            PrimitiveLights::None => None,
        }
    }

    /// Density with which `sample` from `p` (with `choice`, made there) picks the point `q`
    /// (normal `n`) on primitive `prim` of geometry `geom`; 0 if that primitive is not a light.
    pub fn pdf_emitter(&self, choice: &LightChoice, geom: u32, prim: u32, p: Vec3, q: Vec3, n: Vec3) -> f32 {
        let Some(i) = self.light_of(geom, prim) else { return 0.0 };
        self.pdf_point(choice, i as u32, p, q, n)
    }

    /// Density with which `sample` from `p` (with `choice`, made there) picks the point `q`
    /// (normal `n`) on light `light` of the set, a surface; 0 for other lights.
    pub fn pdf_point(&self, choice: &LightChoice, light: u32, p: Vec3, q: Vec3, n: Vec3) -> f32 {
        let i = light as usize;
        let sel = self.choice_probability(choice, i);
        match &self.lights[i] {
            Emitter::Triangle(t) => t.pdf(sel, p, q, n),
            Emitter::Sphere(s) => s.pdf(sel, p, q, n),
            _ => 0.0,
        }
    }

    /// Density with which `sample` (with `choice`) picks the unit direction `d` toward the
    /// background.
    pub fn pdf_background(&self, choice: &LightChoice, d: Vec3) -> f32 {
        self.background_index.map_or(0.0, |i| self.background.pdf(self.choice_probability(choice, i), d, choice.1))
    }
}

/// What the importance of a group of lights needs (see [`Group`]).
fn group_bounds(group: &[Emitter], background: &Background) -> LightBounds {
    match group {
        [Emitter::Point(l)] => l.bounds(),
        [Emitter::Sphere(s)] => s.bounds(),
        [Emitter::Background] => background.bounds(),
        // The triangles of one mesh.
        _ => triangle::group_bounds(group.iter().filter_map(|e| match e {
            Emitter::Triangle(t) => Some(t),
            _ => None,
        })),
    }
}

/// Uniform direction on the unit sphere.
#[inline]
pub fn uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (sin_phi, cos_phi) = crate::fastmath::sin_cos_turns(u.y);
    Vec3::new(r * cos_phi, r * sin_phi, z)
}

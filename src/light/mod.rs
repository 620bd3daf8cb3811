//! Lights: point lights, emissive triangles and spheres (area lights), and the background
//! (sky or environment image). [`LightSet`] chooses one (by its importance at the shading
//! point for a few lights, by power for many: `choice`) and samples a direction toward it,
//! for next-event estimation; its `pdf_*` methods give the matching densities for multiple
//! importance sampling.

mod background;
mod choice;

pub use background::Background;
use choice::{LOCAL_CHOICE_MAX, LocalChoice, Reach};

use crate::geometry::{Aabb, Frame, Geometry, Sphere, bounds_of};
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// An isotropic point light; `intensity` is radiant intensity (W/sr) per channel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointLight {
    pub position: Vec3,
    pub intensity: Vec3,
}

#[derive(Clone, Debug, PartialEq)]
enum Light {
    Point(PointLight),
    /// `normal`: the unit normal of the winding order, computed once here, not per sample.
    Triangle {
        p: [Vec3; 3],
        normal: Vec3,
        area: f32,
        emission: Vec3,
    },
    Sphere {
        sphere: Sphere,
        emission: Vec3,
    },
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
}

/// Where to find the light of an emissive primitive.
#[derive(Clone, Debug, PartialEq)]
enum Lookup {
    None,
    /// Light index of primitive i is base + i.
    Range(u32),
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

/// How a light is chosen at one shading point ([`LightSet::choice_at`]): by importance there,
/// or (`None`) by power.
#[derive(Clone, Copy, Debug)]
pub struct LightChoice(Option<LocalChoice>);

impl LightChoice {
    /// In proportion to power, wherever the point.
    pub const BY_POWER: LightChoice = LightChoice(None);
}

/// All lights of a scene, and how one is chosen.
#[derive(Clone, Debug)]
pub struct LightSet {
    lights: Vec<Light>,
    /// What the choice by importance treats as one light (see [`Group`]), and which group
    /// each light is in.
    groups: Vec<Group>,
    group_of: Vec<u32>,
    /// Per group, for the choice by importance at a point (2 to [`LOCAL_CHOICE_MAX`]
    /// groups); empty otherwise.
    reach: Vec<Reach>,
    /// The power-proportional choice: larger sets, and the fallback where importances are
    /// unusable.
    cdf: Vec<f32>,
    prob: Vec<f32>,
    lookup: Vec<Lookup>,
    background: Background,
    background_index: Option<usize>,
}

fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

impl LightSet {
    /// The lights of a scene: every primitive of `geometry` for which `emission(geom, prim)`
    /// is not black (triangles and spheres; cylinders are not sampled), the point lights, and
    /// the background unless it is black.
    pub fn new(
        geometry: &[Geometry],
        emission: &dyn Fn(u32, u32) -> Vec3,
        point_lights: &[PointLight],
        background: &Background,
    ) -> LightSet {
        let mut lights = Vec::new();
        let mut power = Vec::new();
        let mut lookup = Vec::new();
        let mut spans: Vec<(u32, u32)> = Vec::new();
        for (gi, g) in geometry.iter().enumerate() {
            let gi = gi as u32;
            let base = lights.len() as u32;
            let mut per = Vec::new();
            match g {
                Geometry::Mesh(m) => {
                    for i in 0..m.triangle_count() {
                        let e = emission(gi, i as u32);
                        if e.max_element() <= 0.0 {
                            per.push(u32::MAX);
                            continue;
                        }
                        let p = m.triangle(i);
                        let area = 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length();
                        let area = if area.is_finite() { area } else { 0.0 };
                        per.push(lights.len() as u32);
                        power.push(luminance(e) * area * PI);
                        let normal = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
                        lights.push(Light::Triangle { p, normal, area, emission: e });
                    }
                    if lights.len() as u32 > base {
                        spans.push((base, lights.len() as u32));
                    }
                }
                Geometry::Spheres(s) => {
                    for (i, sp) in s.iter().enumerate() {
                        let e = emission(gi, i as u32);
                        if e.max_element() <= 0.0 {
                            per.push(u32::MAX);
                            continue;
                        }
                        per.push(lights.len() as u32);
                        power.push(luminance(e) * 4.0 * PI * sp.radius * sp.radius * PI);
                        spans.push((lights.len() as u32, lights.len() as u32 + 1));
                        lights.push(Light::Sphere { sphere: *sp, emission: e });
                    }
                }
                Geometry::Cylinders(_) => {}
            }
            lookup.push(if per.iter().all(|&x| x == u32::MAX) {
                Lookup::None
            } else if per.iter().enumerate().all(|(i, &x)| x == base + i as u32) {
                Lookup::Range(base)
            } else {
                Lookup::PerPrim(per)
            });
        }
        for pl in point_lights {
            power.push(luminance(pl.intensity) * 4.0 * PI);
            spans.push((lights.len() as u32, lights.len() as u32 + 1));
            lights.push(Light::Point(*pl));
        }
        let mut background_index = None;
        if !background.is_black() {
            let bounds = bounds_of(geometry);
            let r = 0.5 * bounds.diagonal().length();
            let r = if r.is_finite() && r > 0.0 { r } else { 1.0 };
            background_index = Some(lights.len());
            spans.push((lights.len() as u32, lights.len() as u32 + 1));
            power.push(luminance(background.average()).max(1e-6) * 4.0 * PI * PI * r * r);
            lights.push(Light::Background);
        }
        let total: f32 = power.iter().sum();
        let prob: Vec<f32> = if total > 0.0 && total.is_finite() {
            power.iter().map(|p| p / total).collect()
        } else {
            vec![1.0 / lights.len().max(1) as f32; lights.len()]
        };
        let groups: Vec<Group> = spans
            .iter()
            .map(|&(start, end)| Group { start, end, prob: prob[start as usize..end as usize].iter().sum() })
            .collect();
        let mut group_of = vec![0; lights.len()];
        for (g, &(start, end)) in spans.iter().enumerate() {
            group_of[start as usize..end as usize].fill(g as u32);
        }
        let reach = if (2..=LOCAL_CHOICE_MAX).contains(&groups.len()) {
            groups.iter().map(|g| group_reach(&lights[g.start as usize..g.end as usize], background)).collect()
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
        LightSet {
            lights,
            groups,
            group_of,
            reach,
            cdf,
            prob,
            lookup,
            background: background.clone(),
            background_index,
        }
    }

    pub fn is_empty(&self) -> bool {
        self.lights.is_empty()
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
        } else if !self.reach.is_empty() {
            "a group chosen by importance at each shading point, a light within it by power".to_string()
        } else if g == 1 {
            "chosen by power".to_string()
        } else {
            format!("chosen by power (more than {LOCAL_CHOICE_MAX} groups)")
        };
        let s = |k: usize| if k == 1 { "" } else { "s" };
        format!("{n} light{} in {g} group{}: {how}", s(n), s(g))
    }

    /// Whether every light is a point light.
    pub fn all_delta(&self) -> bool {
        self.lights.iter().all(|l| matches!(l, Light::Point(_)))
    }

    /// How next-event estimation chooses a light at the shading point `p`. Computed once per
    /// vertex: it serves [`LightSet::sample`] there and, at the next vertex, the densities
    /// MIS weighs a BSDF-sampled ray's find against ([`LightSet::pdf_emitter`],
    /// [`LightSet::pdf_background`]).
    #[inline(always)]
    pub fn choice_at(&self, p: Vec3) -> LightChoice {
        if !self.reach.is_empty() { self.local_choice(p) } else { LightChoice::BY_POWER }
    }

    /// Out of line, so that kernels for one light (or many) carry none of its code.
    #[inline(never)]
    fn local_choice(&self, p: Vec3) -> LightChoice {
        LightChoice(LocalChoice::at(&self.reach, p))
    }

    /// The light that `u` picks, and the probability of that choice.
    #[inline(always)]
    fn choose(&self, choice: &LightChoice, u: f32) -> (usize, f32) {
        let n = self.lights.len();
        if n == 1 {
            return (0, self.prob[0]); // what either choice below gives
        }
        if let Some(c) = &choice.0 {
            let (g, p_group, u) = c.pick(self.groups.len(), u);
            let group = &self.groups[g];
            let (start, end) = (group.start as usize, group.end as usize);
            if end - start == 1 {
                return (start, p_group);
            }
            // Within the group by power, with what is left of `u`.
            let below = if start == 0 { 0.0 } else { self.cdf[start - 1] };
            let target = below + u * group.prob;
            let i = (start + self.cdf[start..end].partition_point(|&c| c <= target)).min(end - 1);
            return (i, p_group * (self.prob[i] / group.prob));
        }
        let i = self.cdf.partition_point(|&c| c <= u).min(n - 1);
        (i, self.prob[i])
    }

    /// The probability that `choice` picks light `i`.
    #[inline]
    fn choice_probability(&self, choice: &LightChoice, i: usize) -> f32 {
        match &choice.0 {
            Some(c) => {
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
            None => self.prob[i],
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
        match &self.lights[i] {
            Light::Point(l) => {
                let d = l.position - p;
                let d2 = d.length_squared();
                if !(d2 > 0.0) {
                    return None;
                }
                Some(LightSample {
                    wi: d / d2.sqrt(),
                    point: Some(l.position),
                    normal: Vec3::ZERO,
                    radiance: l.intensity / d2,
                    pdf: sel,
                    delta: true,
                })
            }
            Light::Triangle { p: tri, normal: n, area, emission } => {
                if *area <= 0.0 {
                    return None;
                }
                let su = u.x.sqrt();
                let (b0, b1) = (1.0 - su, u.y * su);
                let q = b0 * tri[0] + b1 * tri[1] + (1.0 - b0 - b1) * tri[2];
                let n = *n;
                let d = q - p;
                let d2 = d.length_squared();
                let wi = d / d2.sqrt();
                let cos = n.dot(wi).abs();
                if !(cos > 0.0 && d2 > 0.0) {
                    return None;
                }
                let pdf = sel * d2 / (cos * area);
                pdf.is_finite().then_some(LightSample {
                    wi,
                    point: Some(q),
                    normal: n,
                    radiance: *emission,
                    pdf,
                    delta: false,
                })
            }
            Light::Sphere { sphere, emission } => sample_sphere_light(sphere, *emission, sel, p, u),
            Light::Background => self.sample_background(sel, u),
        }
    }

    #[inline(never)]
    fn sample_background(&self, sel: f32, u: Vec2) -> Option<LightSample> {
        let wi = uniform_sphere(u);
        Some(LightSample {
            wi,
            point: None,
            normal: Vec3::ZERO,
            radiance: self.background.radiance(wi),
            pdf: sel / (4.0 * PI),
            delta: false,
        })
    }

    /// Density with which `sample` from `p` (with `choice`, made there) picks the point `q`
    /// (normal `n`) on primitive `prim` of geometry `geom`; 0 if that primitive is not a light.
    pub fn pdf_emitter(&self, choice: &LightChoice, geom: u32, prim: u32, p: Vec3, q: Vec3, n: Vec3) -> f32 {
        let i = match self.lookup.get(geom as usize) {
            Some(Lookup::Range(base)) => (base + prim) as usize,
            Some(Lookup::PerPrim(v)) => match v.get(prim as usize) {
                Some(&i) if i != u32::MAX => i as usize,
                _ => return 0.0,
            },
            _ => return 0.0,
        };
        let sel = self.choice_probability(choice, i);
        match &self.lights[i] {
            Light::Triangle { area, .. } => {
                let d = q - p;
                let d2 = d.length_squared();
                let cos = n.normalize().dot(d / d2.sqrt()).abs();
                if *area <= 0.0 || cos <= 0.0 { 0.0 } else { sel * d2 / (cos * area) }
            }
            Light::Sphere { sphere, .. } => sel * pdf_sphere(sphere, p, q, n),
            _ => 0.0,
        }
    }

    /// Density with which `sample` (with `choice`) picks a direction toward the background.
    pub fn pdf_background(&self, choice: &LightChoice) -> f32 {
        self.background_index.map_or(0.0, |i| self.choice_probability(choice, i) / (4.0 * PI))
    }
}

/// What the importance of a group of lights needs (see [`Group`]).
fn group_reach(lights: &[Light], background: &Background) -> Reach {
    match lights {
        [Light::Point(pl)] => Reach::point(pl.position, luminance(pl.intensity)),
        [Light::Sphere { sphere, emission }] => Reach::sphere(sphere.center, sphere.radius, luminance(*emission)),
        [Light::Background] => Reach::background(luminance(background.average())),
        _ => {
            // The triangles of one mesh.
            let mut bounds = Aabb::EMPTY;
            let mut scale = 0.0;
            let mut normal: Option<Vec3> = None;
            let mut flat = true;
            for l in lights {
                if let Light::Triangle { p, normal: n, area, emission } = l {
                    if *area <= 0.0 {
                        continue;
                    }
                    bounds = p.iter().fold(bounds, |b, v| b.grow(*v));
                    scale += luminance(*emission) * area;
                    match normal {
                        None => normal = Some(*n),
                        Some(m) => flat &= m.dot(*n).abs() > 0.9999,
                    }
                }
            }
            if !bounds.is_valid() {
                return Reach::surfaces(Vec3::ZERO, 0.0, Vec3::ZERO, 0.0);
            }
            let center = bounds.center();
            let radius = 0.5 * bounds.diagonal().length();
            let normal = if flat { normal.unwrap_or(Vec3::ZERO) } else { Vec3::ZERO };
            Reach::surfaces(center, radius, normal, scale)
        }
    }
}

/// A point seen from `p` on a sphere light chosen with probability `sel`.
#[inline(never)]
fn sample_sphere_light(sphere: &Sphere, emission: Vec3, sel: f32, p: Vec3, u: Vec2) -> Option<LightSample> {
    let (q, n, pdf) = sample_sphere(sphere, p, u)?;
    let wi = (q - p).normalize();
    let pdf = pdf * sel;
    (pdf.is_finite() && pdf > 0.0).then_some(LightSample {
        wi,
        point: Some(q),
        normal: n,
        radiance: emission,
        pdf,
        delta: false,
    })
}

/// Uniform direction on the unit sphere.
#[inline]
pub fn uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (sin_phi, cos_phi) = crate::fastmath::sin_cos_turns(u.y);
    Vec3::new(r * cos_phi, r * sin_phi, z)
}

/// 1 − cosθmax of the cone a sphere subtends from a point at distance² `d2` from its centre
/// (outside), computed as sin²θmax / (1 + cosθmax): no cancellation for small or distant
/// spheres.
fn cone_one_minus_cos(radius: f32, d2: f32) -> f32 {
    let sin2 = (radius * radius / d2).min(1.0);
    let cos = (1.0 - sin2).max(0.0).sqrt();
    sin2 / (1.0 + cos)
}

/// Whether `p` is inside the sphere or on its surface within rounding. A shading point on
/// the sphere itself (a camera inside a glowing sphere) is computed with an error of a few
/// float steps of the coordinates, so it lands outside about half the time; there the cone
/// toward the sphere degenerates to a half-space whose near intersection is `p` itself, and
/// light from the sphere would be lost. Sampling by area is valid from anywhere (only
/// noisier), so it is used within that rounding margin.
fn inside_or_on(s: &Sphere, p: Vec3) -> bool {
    let magnitude = s.center.abs().max_element().max(p.abs().max_element()) + s.radius;
    let r = s.radius + 8.0 * f32::EPSILON * magnitude;
    (s.center - p).length_squared() <= r * r
}

/// Samples a point on a sphere as seen from `p`: uniformly in the subtended cone when outside
/// (solid-angle density 1 / (2π(1 − cosθmax))), uniformly by area when inside or on it.
fn sample_sphere(s: &Sphere, p: Vec3, u: Vec2) -> Option<(Vec3, Vec3, f32)> {
    let to_c = s.center - p;
    let d2 = to_c.length_squared();
    if inside_or_on(s, p) {
        let n = uniform_sphere(u);
        let q = s.center + s.radius * n;
        let d = q - p;
        let dd = d.length_squared();
        let cos = n.dot(d / dd.sqrt()).abs();
        let pdf = dd / (cos * 4.0 * PI * s.radius * s.radius);
        return (cos > 0.0).then_some((q, n, pdf));
    }
    let d = d2.sqrt();
    let one_minus_cos = cone_one_minus_cos(s.radius, d2);
    let cos_t = 1.0 - u.x * one_minus_cos;
    let sin2_t = (1.0 - cos_t * cos_t).max(0.0);
    let phi = 2.0 * PI * u.y;
    // Distance along the sampled direction to the near intersection with the sphere.
    let ds = d * cos_t - (s.radius * s.radius - d2 * sin2_t).max(0.0).sqrt();
    let frame = Frame::from_normal(to_c / d);
    let dir = frame.to_world(Vec3::new(sin2_t.sqrt() * phi.cos(), sin2_t.sqrt() * phi.sin(), cos_t));
    let q = p + ds * dir;
    let n = (q - s.center).normalize();
    Some((q, n, 1.0 / (2.0 * PI * one_minus_cos)))
}

fn pdf_sphere(s: &Sphere, p: Vec3, q: Vec3, n: Vec3) -> f32 {
    let d2 = (s.center - p).length_squared();
    if inside_or_on(s, p) {
        let d = q - p;
        let dd = d.length_squared();
        let cos = n.normalize().dot(d / dd.sqrt()).abs();
        return if cos > 0.0 { dd / (cos * 4.0 * PI * s.radius * s.radius) } else { 0.0 };
    }
    1.0 / (2.0 * PI * cone_one_minus_cos(s.radius, d2))
}

//! Light leaving the lights, for paths traced from them (the caustic light paths of
//! `crate::integrator::caustic`): [`Emitters`] chooses a light that emits from a place (every
//! kind but the background) in proportion to its power, the light's own file a point on it
//! (`emit_point` in `point.rs`, `triangle.rs`, `sphere.rs`), and this file a direction: toward
//! a target where one is given (the paths that matter start toward it), else over all the
//! directions the light sends its light in.

use super::sphere::{cone_one_minus_cos, sample_cone};
use super::{Emitter, LightSet, distribution, uniform_sphere};
use crate::geometry::{Frame, Sphere};
use crate::material::sample_cosine_hemisphere;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Light leaving a light: where, which way, and what the path carries.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Emission {
    pub p: Vec3,
    /// The unit normal of the emitting face at `p`, on the side `d` leaves by (zero for a
    /// point light).
    pub n: Vec3,
    /// Unit direction.
    pub d: Vec3,
    /// Radiance × cos (intensity, for a point light) over the density of the light, the point
    /// and the direction.
    pub weight: Vec3,
    /// Which light of the set.
    pub light: u32,
}

/// A point a light emits from ([`Emitters::sample`] picks the direction).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct EmissionPoint {
    pub p: Vec3,
    /// The unit normal of the surface (zero for a point light, which emits alike every way).
    pub n: Vec3,
    /// Radiance (intensity, for a point light).
    pub le: Vec3,
    /// The inverse of the point's density over the light's surface: its area if uniform (1 for
    /// a point light).
    pub area: f32,
    /// Both faces emit (else the side `n` points to).
    pub two_sided: bool,
}

/// The lights of a [`LightSet`] that light paths start from, chosen by power, and where their
/// paths go.
#[derive(Clone, Debug)]
pub struct Emitters<'a> {
    set: &'a LightSet,
    /// A sphere that every path that matters starts toward: directions are drawn uniformly
    /// within the cone it subtends from the point on the light (from inside it, over all
    /// directions).
    target: Option<Sphere>,
    /// Their indices in the set, and the cumulative distribution of the choice.
    lights: Vec<u32>,
    cdf: Vec<f32>,
    /// The probability of each light of the set (0 for the background and lights of no power).
    prob: Vec<f32>,
    /// Per light of the set, what [`Emitters::surface_density`] gives.
    surface_density: Vec<f32>,
}

impl LightSet {
    /// The lights paths can start from (`None` if none gives light), their paths started
    /// toward `target` if given.
    pub fn emitters(&self, target: Option<Sphere>) -> Option<Emitters<'_>> {
        let power = |e: &Emitter| match e {
            Emitter::Point(l) => l.power(),
            Emitter::Triangle(t) => t.power(),
            Emitter::Sphere(s) => s.power(),
            Emitter::Background => 0.0,
        };
        let lights: Vec<u32> =
            (0..self.lights.len() as u32).filter(|&i| power(&self.lights[i as usize]) > 0.0).collect();
        let total: f64 = lights.iter().map(|&i| power(&self.lights[i as usize]) as f64).sum();
        let cdf = distribution::normalized_cdf(lights.iter().map(|&i| power(&self.lights[i as usize]) as f64), total)?;
        let mut prob = vec![0.0; self.lights.len()];
        for (k, &i) in lights.iter().enumerate() {
            prob[i as usize] = distribution::probability(&cdf, k);
        }
        // A point's density over a light's surface is the same everywhere on it.
        let surface_density = (0..self.lights.len())
            .map(|i| {
                let e = match &self.lights[i] {
                    Emitter::Triangle(t) => t.emit_point(Vec2::splat(0.25)),
                    Emitter::Sphere(s) => s.emit_point(Vec2::splat(0.25)),
                    Emitter::Point(_) | Emitter::Background => None,
                };
                e.map_or(0.0, |e| {
                    let faces = if e.two_sided { 0.5 } else { 1.0 };
                    prob[i] * faces / (PI * e.area)
                })
            })
            .collect();
        Some(Emitters { set: self, target, lights, cdf, prob, surface_density })
    }
}

impl Emitters<'_> {
    /// Light leaving a light chosen with `u_choice`, from a point on it (`u`) in a direction
    /// (`v`); the weight includes the probability of the choice. `None` for a direction the
    /// light sends nothing in.
    pub fn sample(&self, u_choice: f32, u: Vec2, v: Vec2) -> Option<Emission> {
        let i = self.lights[distribution::pick_index(&self.cdf, u_choice)] as usize;
        let e = match &self.set.lights[i] {
            Emitter::Point(l) => Some(l.emit_point()),
            Emitter::Triangle(t) => t.emit_point(u),
            Emitter::Sphere(s) => s.emit_point(u),
            Emitter::Background => None,
        }?;
        let toward = self.target.and_then(|t| {
            let to_c = t.center - e.p;
            let d2 = to_c.length_squared();
            (d2 > t.radius * t.radius).then(|| (to_c / d2.sqrt(), cone_one_minus_cos(t.radius, d2)))
        });
        // The direction, its density and the cosine the light emits with along it.
        let (d, pdf, cos) = match toward {
            Some((axis, one_minus_cos)) => {
                let d = sample_cone(axis, one_minus_cos, v);
                let cos = if e.n == Vec3::ZERO {
                    1.0
                } else if e.two_sided {
                    d.dot(e.n).abs()
                } else {
                    d.dot(e.n)
                };
                (d, 1.0 / (2.0 * PI * one_minus_cos), cos)
            }
            None if e.n == Vec3::ZERO => (uniform_sphere(v), 0.25 / PI, 1.0),
            None => {
                // By the cosine about the normal, on a face chosen at random if both emit.
                let (n, vx, faces) = match (e.two_sided, v.x < 0.5) {
                    (false, _) => (e.n, v.x, 1.0),
                    (true, true) => (e.n, 2.0 * v.x, 0.5),
                    (true, false) => (-e.n, 2.0 * v.x - 1.0, 0.5),
                };
                let local = sample_cosine_hemisphere(Vec2::new(vx.min(super::choice::ONE_BELOW), v.y));
                (Frame::from_normal(n).to_world(local), faces * local.z / PI, local.z)
            }
        };
        if !(cos > 0.0 && pdf > 0.0) {
            return None;
        }
        let weight = e.le * (cos * e.area / (self.prob[i] * pdf));
        let n = if e.n.dot(d) < 0.0 { -e.n } else { e.n };
        (weight.is_finite() && weight.max_element() > 0.0).then_some(Emission { p: e.p, n, d, weight, light: i as u32 })
    }

    /// For light `light` of the set, a surface that emits: the density with which
    /// [`Emitters::sample`] (with no target) starts a path at a point of it along a direction,
    /// over the light's area and the projected solid angle about the point's normal: the
    /// probability of the choice, the point's density (1 / area) and the cosine direction's
    /// (1 / π, halved for a two-sided face). Times the cosine at a surface point y that the
    /// path lands on, over the distance², it is the path's density over y's area, per the
    /// light point's geometric factor cos / distance² (what light vertices weigh). 0 for point
    /// lights and the background.
    #[inline]
    pub fn surface_density(&self, light: u32) -> f32 {
        self.surface_density[light as usize]
    }

    /// Whether light that primitive `prim` of geometry `geom` sheds toward `wo` (from its
    /// point of normal `n`, outward for a sphere) is light [`Emitters::sample`] starts paths
    /// with: a light of some power, and for a sphere its outside.
    pub fn covers(&self, geom: u32, prim: u32, n: Vec3, wo: Vec3) -> bool {
        let Some(i) = self.set.light_of(geom, prim) else { return false };
        self.prob[i] > 0.0 && (!matches!(self.set.lights[i], Emitter::Sphere(_)) || n.dot(wo) > 0.0)
    }
}

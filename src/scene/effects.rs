//! Scene analysis: which light-transport effects a loaded scene actually calls for. The
//! renderer picks a kernel compiled for exactly these effects (see `integrator::kernel`), so
//! code for effects the scene lacks is never run, and the render reports what it decided.
//!
//! Only what the scene *uses* counts: a material defined but bound to no primitive, or a
//! texture on an unused material, does not switch an effect on.
//!
//! Each material kind says what it is ([`MaterialModel`]: its lobes, whether it scatters, its
//! albedo) and each light whether it emits and is a point; this file only gathers the
//! answers. The render plan (`crate::integrator::RenderPlan`) turns them into the kernel, the
//! path depth ([`Effects::depth_limit`]: none or one bounce when nothing can bounce light
//! onward) and, from the brightest material in use ([`Effects::albedo`]), the depth at which
//! Russian roulette starts.

use super::{MaterialBinding, Scene};
use crate::geometry::Geometry;
use crate::light::Background;
use crate::material::MaterialModel;
use std::fmt;

/// The effects present in a scene.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Effects {
    pub triangles: bool,
    pub spheres: bool,
    pub cylinders: bool,
    /// Lambertian surfaces (diffuse, and the base of plastic).
    pub diffuse: bool,
    /// Rough (microfacet) reflection: rough metal, plastic.
    pub glossy: bool,
    /// Perfect mirrors (metal of roughness ~0).
    pub mirror: bool,
    /// Refraction (glass).
    pub glass: bool,
    /// Surfaces that emit.
    pub emissive: bool,
    /// Colours that vary over a surface (image or checker textures).
    pub textures: bool,
    /// Surfaces with holes (glTF's alpha MASK and BLEND): rays test their alpha at each hit.
    pub cutouts: bool,
    /// Emitting surfaces that next-event estimation samples (triangles, spheres).
    pub area_lights: bool,
    pub point_lights: bool,
    /// A constant or gradient sky.
    pub sky: bool,
    /// An environment image.
    pub environment: bool,
    /// A thin-lens camera (aperture > 0).
    pub depth_of_field: bool,
    /// Some surface scatters light (a non-black BSDF).
    pub scattering: bool,
    /// Light can reach the camera after more than one scattering event.
    pub indirect: bool,
    /// Some light exists (emitter, point light or non-black background).
    pub lit: bool,
    /// The largest albedo of a material in use (0 if nothing scatters): the best fraction of
    /// light one bounce can send on ([`MaterialModel::albedo`]).
    pub albedo: f32,
    /// Every point light lies inside the bounds of the surfaces that scatter light: most of
    /// what it emits lands on a surface, which is where paths gain from connecting to light
    /// vertices (`integrator::light_vertex`; the plan also asks that every light be a point).
    pub enclosed_point_lights: bool,
    /// The camera is orthographic (not an effect the report lists: it decides what the render
    /// can trace toward the camera).
    pub orthographic: bool,
    /// Some material in use is a mirror or glass everywhere (not one whose texture makes a
    /// few spots smooth): what makes caustics worth light paths (not listed either).
    pub specular_material: bool,
}

/// How long paths need to be for this scene.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DepthLimit {
    /// Nothing scatters: only emitters and the background are seen (depth 0).
    EmittersOnly,
    /// Light scatters at most once on its way to the camera (depth 1, direct lighting).
    DirectOnly,
    /// Any depth may contribute.
    Unbounded,
}

impl DepthLimit {
    /// The bounce limit this implies, capped by the user's `max_depth`.
    pub fn apply(self, max_depth: u32) -> u32 {
        match self {
            DepthLimit::EmittersOnly => 0,
            DepthLimit::DirectOnly => max_depth.min(1),
            DepthLimit::Unbounded => max_depth,
        }
    }
}

impl Effects {
    /// Analyses `scene`.
    pub fn of(scene: &Scene) -> Effects {
        let mut e = Effects::default();
        // Materials in use, how many primitives scatter light, and whether any of those
        // transmits (light can then scatter inside one primitive more than once).
        let mut used = vec![false; scene.materials.len()];
        let mut scattering_prims = 0usize;
        let mut transmissive_scatterer = false;
        let mut scatterer_bounds = crate::geometry::Aabb::EMPTY;
        for (g, binding) in scene.geometry.iter().zip(&scene.bindings) {
            if g.is_empty() {
                continue;
            }
            match g {
                Geometry::Mesh(_) | Geometry::Instance(_) => {
                    e.triangles = true;
                    e.cutouts |= g.mesh().is_some_and(|m| m.cutout.is_some());
                }
                Geometry::Spheres(_) => e.spheres = true,
                Geometry::Cylinders(_) => e.cylinders = true,
            }
            // Emitting cylinders glow but are not sampled (the light set skips them).
            let samplable = !matches!(g, Geometry::Cylinders(_));
            let scattering_before = scattering_prims;
            let mut count = |mi: u32, prims: usize| {
                used[mi as usize] = true;
                let m = &scene.materials[mi as usize];
                e.area_lights |= samplable && m.is_emissive();
                if m.kind.scatters() {
                    scattering_prims += prims;
                    transmissive_scatterer |= m.kind.lobes().glass;
                }
            };
            match binding {
                MaterialBinding::Uniform(mi) => count(*mi, g.len()),
                MaterialBinding::PerPrim(per) => per.iter().for_each(|&mi| count(mi, 1)),
            }
            if scattering_prims > scattering_before {
                scatterer_bounds = scatterer_bounds.union(&g.bounds());
            }
        }
        for (m, _) in scene.materials.iter().zip(&used).filter(|(_, u)| **u) {
            if m.is_emissive() {
                e.emissive = true;
            }
            e.textures |= !m.textures().is_empty();
            if m.kind.scatters() {
                e.albedo = e.albedo.max(m.kind.albedo());
            }
            let lobes = m.kind.lobes();
            e.diffuse |= lobes.diffuse;
            e.glossy |= lobes.glossy;
            e.mirror |= lobes.mirror;
            e.glass |= lobes.glass;
            e.specular_material |= (lobes.mirror || lobes.glass) && !lobes.diffuse && !lobes.glossy;
        }
        e.point_lights = scene.lights.iter().any(|l| l.is_delta() && l.emits());
        match scene.background() {
            b if b.is_black() => {}
            Background::Image(_) => e.environment = true,
            _ => e.sky = true,
        }
        e.depth_of_field = scene.camera.is_some_and(|c| c.aperture > 0.0);
        e.orthographic = scene.camera.is_some_and(|c| c.ortho_width.is_some());
        e.lit = e.emissive || e.point_lights || e.sky || e.environment;
        e.scattering = scattering_prims > 0;
        // One opaque primitive (a sphere, a capped cylinder, a triangle: all convex) cannot
        // send light to itself seen from outside; two primitives, or one that refracts, can ...
        // ... unless the camera is inside it (then its inner surface sees itself): a camera
        // within the scatterer's bounds, lens included, counts as inside.
        let camera_inside = scene.camera.is_some_and(|c| {
            let r = c.aperture.max(0.0);
            let (lo, hi) = (scatterer_bounds.min - glam::Vec3::splat(r), scatterer_bounds.max + glam::Vec3::splat(r));
            c.position.cmpge(lo).all() && c.position.cmple(hi).all()
        });
        e.enclosed_point_lights = scene.lights.iter().all(|l| match l {
            crate::light::Light::Point(p) if p.emits() => {
                p.position.cmpgt(scatterer_bounds.min).all() && p.position.cmplt(scatterer_bounds.max).all()
            }
            _ => true,
        });
        e.indirect = scattering_prims > 1 || transmissive_scatterer || (scattering_prims == 1 && camera_inside);
        e
    }

    /// How deep paths need to go (before the user's `--max-depth` caps it).
    pub fn depth_limit(&self) -> DepthLimit {
        if !self.scattering {
            DepthLimit::EmittersOnly
        } else if !self.indirect {
            DepthLimit::DirectOnly
        } else {
            DepthLimit::Unbounded
        }
    }

    /// Light sources that next-event estimation can hit by BSDF sampling too (so MIS applies):
    /// area lights, emitting surfaces of any kind, sky and environment.
    pub fn non_delta_lights(&self) -> bool {
        self.emissive || self.sky || self.environment
    }

    /// (name, present) for every effect, in report order.
    pub fn list(&self) -> [(&'static str, bool); 16] {
        [
            ("triangles", self.triangles),
            ("spheres", self.spheres),
            ("cylinders", self.cylinders),
            ("diffuse", self.diffuse),
            ("glossy", self.glossy),
            ("mirror", self.mirror),
            ("glass", self.glass),
            ("emissive", self.emissive),
            ("texture", self.textures),
            ("cut-outs", self.cutouts),
            ("area lights", self.area_lights),
            ("point lights", self.point_lights),
            ("sky", self.sky),
            ("environment", self.environment),
            ("depth of field", self.depth_of_field),
            ("indirect light", self.indirect),
        ]
    }
}

/// `effects: triangles, diffuse, … — off: spheres, …`
impl fmt::Display for Effects {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let on: Vec<&str> = self.list().iter().filter(|(_, p)| *p).map(|(n, _)| *n).collect();
        let off: Vec<&str> = self.list().iter().filter(|(_, p)| !*p).map(|(n, _)| *n).collect();
        write!(f, "effects: {}", if on.is_empty() { "none".to_string() } else { on.join(", ") })?;
        if !off.is_empty() {
            write!(f, " — off: {}", off.join(", "))?;
        }
        if !self.lit {
            write!(f, " (no light: the image is black)")?;
        }
        Ok(())
    }
}

//! Point lights: isotropic, radiant intensity per channel; a delta light (BSDF sampling never
//! finds one, so no MIS).

use super::choice::LightBounds;
use super::{LightSample, luminance};
use crate::hash::Fingerprint;
use glam::Vec3;
use std::f32::consts::PI;

/// An isotropic point light; `intensity` is radiant intensity (W/sr) per channel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointLight {
    pub position: Vec3,
    pub intensity: Vec3,
}

impl PointLight {
    /// Whether it gives any light.
    pub fn emits(&self) -> bool {
        self.intensity.max_element() > 0.0
    }

    /// Luminance of the power it emits (for the choice by power).
    pub(super) fn power(&self) -> f32 {
        luminance(self.intensity) * 4.0 * PI
    }

    pub(super) fn tree_bounds(&self) -> super::tree::Bounds {
        let aabb = crate::geometry::Aabb::from_point(self.position);
        super::tree::Bounds { aabb, phi: luminance(self.intensity), cone: super::tree::Cone::ALL }
    }

    pub(super) fn bounds(&self) -> LightBounds {
        LightBounds::point(self.position, luminance(self.intensity))
    }

    /// The direction to the light from `p`, chosen with probability `sel`.
    #[inline(always)]
    pub(super) fn sample(&self, p: Vec3, sel: f32) -> Option<LightSample> {
        let d = self.position - p;
        let d2 = d.length_squared();
        if !(d2 > 0.0) {
            return None;
        }
        Some(LightSample {
            wi: d / d2.sqrt(),
            point: Some(self.position),
            normal: Vec3::ZERO,
            radiance: self.intensity / d2,
            pdf: sel,
            delta: true,
            light: 0,
        })
    }

    /// Where light leaves the point light, for a path from the light: in every direction alike.
    pub(super) fn emit_point(&self) -> super::emission::EmissionPoint {
        super::emission::EmissionPoint {
            p: self.position,
            n: Vec3::ZERO,
            le: self.intensity,
            area: 1.0,
            two_sided: false,
        }
    }

    pub(super) fn fingerprint(&self, h: &mut Fingerprint) {
        h.str("point");
        h.v3(&[self.position, self.intensity]);
    }
}

//! Which light next-event estimation samples from a shading point.
//!
//! Choosing lights in proportion to their power ignores where the shading point is. In the
//! teapot scene the dim sky, whose power is counted over the whole scene's cross-section,
//! got 65% of the choices, though under the area light it brings a fifth of the light; and
//! cosine-weighted BSDF sampling finds a smooth sky well on its own. So lights are grouped
//! (the emitting triangles of one mesh, or one sphere, point light or background), and when
//! there are 2 to [`LOCAL_CHOICE_MAX`] groups, a group is chosen by its *importance at the
//! point*: an estimate of the light it can bring there, occlusion and the receiver's
//! orientation ignored (in the manner of pbrt-v4's light bounds); then a light within it by
//! power. With one group there is nothing to choose; with more, evaluating every group at
//! every vertex would cost more than it saves, and the power distribution is kept.
//!
//! The importance is luminance × subtended solid angle (radiance × sr), bounded so that it
//! stays finite next to a light:
//!
//! - point light: intensity / d²;
//! - sphere: radiance · πr² / max(d², r²);
//! - a mesh's triangles: Σ radiance · area · cos′ / max(d², r²), with d the distance to the
//!   centre of their box, r the radius of the sphere around that box, and, when they all
//!   face one way (a quad light), cos′ = min(1, cos θ + r/d), a bound on the cosine between
//!   their (two-sided) normal and the direction to the point widened by the angle that
//!   sphere subtends, so an edge-on light still counts (1 when they face several ways);
//! - sky or environment: 2π · its average radiance (the hemisphere above any surface).
//!
//! Whatever the importance, the choice stays unbiased: the density the integrator divides by
//! and the one MIS weighs against are the same [`LocalChoice`], computed once at a shading
//! point and kept by the path for the next vertex.

use glam::Vec3;

/// Light sets of up to this many groups choose by importance at the shading point.
pub(super) const LOCAL_CHOICE_MAX: usize = 8;

/// The largest f32 below 1.
pub(super) const ONE_BELOW: f32 = 1.0 - f32::EPSILON / 2.0;

/// What the importance of one group of lights needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct LightBounds {
    /// Centre of the emitter (of the box around a mesh's emitting triangles).
    center: Vec3,
    /// Radius of a sphere around `center` holding the emitter (0 for a point light).
    radius: f32,
    /// Unit normal of a flat (two-sided) emitter; zero when it emits all around.
    normal: Vec3,
    /// Luminance × area for emitters, luminance of the intensity for point lights, or the
    /// importance itself for the background.
    scale: f32,
    /// The background: the same importance everywhere.
    infinite: bool,
}

impl LightBounds {
    pub(super) fn point(position: Vec3, intensity_lum: f32) -> LightBounds {
        LightBounds { center: position, radius: 0.0, normal: Vec3::ZERO, scale: intensity_lum, infinite: false }
    }

    /// Emitting surfaces within `radius` of `center`, all facing along `normal` (either way:
    /// emitters are two-sided) or, with a zero `normal`, facing every way; `scale` is the sum
    /// of luminance × area over them.
    pub(super) fn surfaces(center: Vec3, radius: f32, normal: Vec3, scale: f32) -> LightBounds {
        LightBounds { center, radius, normal, scale, infinite: false }
    }

    pub(super) fn sphere(center: Vec3, radius: f32, radiance_lum: f32) -> LightBounds {
        LightBounds {
            center,
            radius,
            normal: Vec3::ZERO,
            scale: radiance_lum * std::f32::consts::PI * radius * radius,
            infinite: false,
        }
    }

    pub(super) fn background(average_lum: f32) -> LightBounds {
        LightBounds {
            center: Vec3::ZERO,
            radius: 0.0,
            normal: Vec3::ZERO,
            scale: 2.0 * std::f32::consts::PI * average_lum,
            infinite: true,
        }
    }

    /// The light this emitter can bring to `p` (see the module documentation).
    #[inline]
    pub(super) fn importance(&self, p: Vec3) -> f32 {
        if !(self.scale > 0.0) {
            return 0.0; // a black or zero-sized light (its normal may be NaN)
        }
        if self.infinite {
            return self.scale;
        }
        let to_p = p - self.center;
        let d2 = to_p.length_squared();
        let r2 = self.radius * self.radius;
        if self.normal == Vec3::ZERO || d2 <= r2 {
            return self.scale / d2.max(r2);
        }
        // The cosine between the normal and the direction to p, widened by the angle θb
        // the emitter's sphere subtends: cos(θ − θb) ≤ cos θ + sin θb, capped at 1, with
        // cos θ = |n·(p − c)| / d and sin θb = r / d. One square root and one division.
        let d = d2.sqrt();
        let orient_d = (self.normal.dot(to_p).abs() + self.radius).min(d);
        self.scale * orient_d / (d * d2)
    }
}

/// The importances of a small light set at one point.
#[derive(Clone, Copy, Debug)]
pub(super) struct LocalChoice {
    importance: [f32; LOCAL_CHOICE_MAX],
    total: f32,
}

impl LocalChoice {
    /// `None` when the importances are unusable (all zero, or not finite next to a point
    /// light): the caller then chooses by power. `weights` scale the importances
    /// (`super::visibility`).
    #[inline]
    pub(super) fn at(
        bounds: &[LightBounds],
        p: Vec3,
        weights: Option<&[f32; LOCAL_CHOICE_MAX]>,
    ) -> Option<LocalChoice> {
        debug_assert!(bounds.len() <= LOCAL_CHOICE_MAX);
        let mut importance = [0.0; LOCAL_CHOICE_MAX];
        let mut total = 0.0;
        for (i, (slot, r)) in importance.iter_mut().zip(bounds).enumerate() {
            // × 1 where no weight is given: the same bits as unweighed.
            *slot = r.importance(p) * weights.map_or(1.0, |w| w[i]);
            total += *slot;
        }
        (total > 0.0 && total.is_finite()).then_some(LocalChoice { importance, total })
    }

    /// The entry that `u` in [0, 1) picks among the first `n`, its probability, and where
    /// `u` fell within that entry's share, rescaled to [0, 1): a uniform number that can
    /// choose again within the entry.
    #[inline]
    pub(super) fn pick(&self, n: usize, u: f32) -> (usize, f32, f32) {
        let target = u * self.total;
        let mut acc = 0.0;
        let mut last = 0;
        for (i, &w) in self.importance[..n].iter().enumerate() {
            if w > 0.0 {
                if target < acc + w {
                    return (i, self.probability(i), ((target - acc) / w).clamp(0.0, ONE_BELOW));
                }
                acc += w;
                last = i;
            }
        }
        // u·total rounded up to the sum: the last entry that can be picked.
        (last, self.probability(last), ONE_BELOW)
    }

    #[inline]
    pub(super) fn probability(&self, i: usize) -> f32 {
        self.importance[i] / self.total
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_point_light_falls_off_with_the_square_of_distance() {
        let r = LightBounds::point(Vec3::ZERO, 3.0);
        assert_eq!(r.importance(Vec3::new(0.0, 2.0, 0.0)), 0.75);
        assert_eq!(r.importance(Vec3::new(4.0, 0.0, 0.0)), 3.0 / 16.0);
    }

    #[test]
    fn a_small_flat_light_far_away_weighs_area_times_cosine_over_distance_squared() {
        let (area, radius) = (1e-4, 0.01);
        let r = LightBounds::surfaces(Vec3::ZERO, radius, Vec3::Y, 2.0 * area);
        // 60° off the normal, 10 away, on either side (emitters are two-sided): the cosine
        // bound is cos 60° + r/d.
        for y in [1.0f32, -1.0] {
            let q = 10.0 * Vec3::new(60f32.to_radians().sin(), y * 60f32.to_radians().cos(), 0.0);
            let expected = 2.0 * area * (0.5 + radius / 10.0) / 100.0;
            assert!((r.importance(q) / expected - 1.0).abs() < 1e-4, "{} vs {expected}", r.importance(q));
        }
        // Edge-on it still counts the light's angular size, not zero.
        let edge_on = r.importance(Vec3::new(10.0, 0.0, 0.0));
        assert!((edge_on / (2.0 * area * (radius / 10.0) / 100.0) - 1.0).abs() < 1e-4);
        // Facing every way: no cosine.
        let round = LightBounds::surfaces(Vec3::ZERO, radius, Vec3::ZERO, 2.0 * area);
        assert!((round.importance(Vec3::new(10.0, 0.0, 0.0)) / (2.0 * area / 100.0) - 1.0).abs() < 1e-6);
    }

    #[test]
    fn importance_stays_finite_on_an_emitter() {
        let flat = LightBounds::surfaces(Vec3::new(0.3, 0.0, 0.3), 0.5, Vec3::Y, 0.5);
        let sph = LightBounds::sphere(Vec3::ZERO, 1.0, 1.0);
        for q in [Vec3::ZERO, Vec3::new(0.2, 0.0, 0.2), Vec3::new(1.0, 0.0, 0.0)] {
            assert!(flat.importance(q).is_finite() && flat.importance(q) > 0.0);
            assert!(sph.importance(q).is_finite() && sph.importance(q) > 0.0);
        }
        // A black or zero-sized light has none, even with a NaN normal.
        assert_eq!(LightBounds::surfaces(Vec3::ZERO, 0.0, Vec3::NAN, 0.0).importance(Vec3::ONE), 0.0);
    }

    #[test]
    fn picks_follow_the_importances_and_skip_zero_ones() {
        let reach = [
            LightBounds::point(Vec3::new(0.0, 1.0, 0.0), 1.0), // importance 1 at the origin
            LightBounds::point(Vec3::new(0.0, 1.0, 0.0), 0.0), // 0: never picked
            LightBounds::background(3.0 / (2.0 * std::f32::consts::PI)), // 3
        ];
        let c = LocalChoice::at(&reach, Vec3::ZERO, None).unwrap();
        assert_eq!(c.pick(3, 0.0), (0, 0.25, 0.0));
        let (i, p, rest) = c.pick(3, 0.125);
        assert_eq!((i, p), (0, 0.25));
        assert!((rest - 0.5).abs() < 1e-6, "what is left of u is rescaled: {rest}");
        assert_eq!(c.pick(3, 0.25).0, 2);
        let (i, _, rest) = c.pick(3, 0.999_999_9);
        assert!(i == 2 && rest < 1.0);
        assert!((c.probability(2) - 0.75).abs() < 1e-6);
        assert_eq!(c.probability(1), 0.0);
        // All zero: no local choice.
        assert!(LocalChoice::at(&reach[1..2], Vec3::ZERO, None).is_none());
    }
}

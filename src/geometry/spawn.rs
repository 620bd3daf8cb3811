//! Leaving a surface without hitting it again.
//!
//! The new origin is the hit point moved along the geometric normal by a bound on the hit
//! point's rounding error, then rounded once more away from the surface: pbrt-v4's
//! `OffsetRayOrigin` (Pharr, Jakob, Humphreys, *Physically Based Rendering* 4th ed., §6.8.6).
//! Given the error bound of the computation that produced the point
//! ([`offset_ray_origin_bounded`]) the offset is exactly as large as it must be, at any
//! scale and any distance from the origin.
//!
//! Callers that only have the point ([`offset_ray_origin`], [`offset_toward`]) get the bound
//! [`point_error`]: `POINT_ERROR_ULPS` float steps (2⁻²⁴ each) of the point's largest
//! coordinate magnitude, in every component. That is right for points computed from operands
//! no larger than themselves (barycentric interpolation of a triangle's corners,
//! re-projection onto a sphere) and is scale-invariant: there is no absolute epsilon, so a
//! scene scaled by 1e-4 or 1e4 renders the same. Its limit is a point near the origin on a
//! triangle much larger than the point's distance to the origin, whose error follows the
//! corners, not the point (measured by the `self-intersection` hard case, which also runs at
//! the origin), and a point computed as `o + t·d` from a far-away origin (cylinders, see the
//! `cylinder-seen-from-afar` hard case). Both are fixed by passing the real bound.
//!
//! This replaces the integer-ULP offset of Wächter and Binder (Ray Tracing Gems, ch. 6),
//! whose 256-ULP offsets are 2 units at 1e5 from the origin and whose fixed 1/65536 near the
//! origin is a scene-scale epsilon (`docs/hard-cases.md` has the figures).

use glam::Vec3;

/// Float steps of the largest coordinate assumed as the error of a point given alone. The
/// measured range that works: 16 (the `self-intersection` case at the origin has 1 pixel in
/// 4096 off at 16, 6 at 8) to 32 (`far-1e5` differs in the mean by 0.28% at 16, 0.43% at 32).
pub const POINT_ERROR_ULPS: f32 = 16.0;

/// The error bound assumed for a point given without one: [`POINT_ERROR_ULPS`] float steps
/// (2⁻²⁴) of its largest coordinate magnitude, in every component.
#[inline(always)]
pub fn point_error(p: Vec3) -> Vec3 {
    Vec3::splat(POINT_ERROR_ULPS * f32::EPSILON * 0.5 * p.abs().max_element())
}

/// `p` (known within `err` per component) moved off the surface along `n` (unit geometric
/// normal, pointing to the side the new ray leaves from): by |n|·err along `n`, then each
/// moved component one float further, so that rounding of the sum cannot undo the offset.
#[inline(always)]
pub fn offset_ray_origin_bounded(p: Vec3, err: Vec3, n: Vec3) -> Vec3 {
    let d = n.abs().dot(err);
    let q = p + d * n;
    Vec3::new(step_away(q.x, n.x), step_away(q.y, n.y), step_away(q.z, n.z))
}

/// `x` moved one float in the direction of the sign of `dir` (unchanged if `dir` is ±0):
/// `next_up`/`next_down` on the bit pattern, without branches (this runs for three
/// coordinates of two ray origins per bounce). The magnitude grows by one step when `x` has
/// the sign of `dir` and shrinks otherwise; a zero takes the sign of `dir` first, so it
/// becomes ±the smallest subnormal. For the finite points it is given; an infinite `x` would
/// step to NaN, as would a NaN `dir`.
#[inline(always)]
fn step_away(x: f32, dir: f32) -> f32 {
    const SIGN: u32 = 0x8000_0000;
    let (xb, db) = (x.to_bits(), dir.to_bits());
    let dir_sign = db & SIGN;
    let mag = xb & !SIGN;
    let sign = if mag == 0 { dir_sign } else { xb & SIGN };
    let mag = if sign == dir_sign { mag + 1 } else { mag - 1 };
    if db & !SIGN == 0 { x } else { f32::from_bits(sign | mag) }
}

/// `p` moved off the surface along `n`, with the error bound [`point_error`].
#[inline(always)]
pub fn offset_ray_origin(p: Vec3, n: Vec3) -> Vec3 {
    offset_ray_origin_bounded(p, point_error(p), n)
}

/// `p` (known within `err`) moved off the surface with normal `n` (either orientation) to the
/// side `toward` points to: where a ray leaving in direction `toward` starts.
#[inline(always)]
pub fn offset_toward_bounded(p: Vec3, err: Vec3, n: Vec3, toward: Vec3) -> Vec3 {
    offset_ray_origin_bounded(p, err, if n.dot(toward) > 0.0 { n } else { -n })
}

/// `p` moved off the surface with normal `n` (either orientation) to the side `toward` points
/// to, with the error bound [`point_error`].
#[inline(always)]
pub fn offset_toward(p: Vec3, n: Vec3, toward: Vec3) -> Vec3 {
    offset_toward_bounded(p, point_error(p), n, toward)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offset_is_on_the_normal_side_and_scales_with_the_point() {
        let n = Vec3::new(0.3, -0.5, 0.8).normalize();
        for scale in [1e-20f32, 1e-4, 1.0, 1e4, 1e20] {
            let p = Vec3::new(1.25, -3.5, 2.0) * scale;
            let q = offset_ray_origin(p, n);
            let d = (q - p).dot(n);
            assert!(d > 0.0, "scale {scale}: moved {d} along n");
            // At least the assumed error (16 steps of 3.5·scale), at most a few times it.
            let e = point_error(p).x;
            assert!(d >= e && d < 4.0 * e, "scale {scale}: moved {d}, error bound {e}");
        }
    }

    #[test]
    fn zero_normal_components_leave_coordinates_alone() {
        let p = Vec3::new(3.0, 0.0, -7.0);
        let q = offset_ray_origin(p, Vec3::Y);
        assert_eq!((q.x, q.z), (p.x, p.z));
        assert!(q.y > 0.0);
    }

    #[test]
    fn step_away_is_next_up_or_down() {
        let xs = [0.0f32, -0.0, 1.0, -1.0, 1e-40, -1e-40, 3.5e7, -2.25e-3, f32::MAX, -f32::MAX, f32::MIN_POSITIVE];
        for x in xs {
            assert_eq!(step_away(x, 1.0).to_bits(), x.next_up().to_bits(), "{x} up");
            assert_eq!(step_away(x, -0.5).to_bits(), x.next_down().to_bits(), "{x} down");
            assert_eq!(step_away(x, 0.0).to_bits(), x.to_bits(), "{x} still");
        }
    }

    #[test]
    fn toward_picks_the_side() {
        let p = Vec3::new(1.0, 2.0, 3.0);
        assert!(offset_toward(p, Vec3::Z, -Vec3::Z).z < p.z);
        assert!(offset_toward(p, -Vec3::Z, Vec3::Z).z > p.z);
    }
}

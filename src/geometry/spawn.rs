//! Leaving a surface without hitting it again.
//!
//! Integer-ULP offsetting of Wächter and Binder, "A Fast and Robust Method for Avoiding
//! Self-Intersection" (Ray Tracing Gems, ch. 6): the origin is moved along the geometric
//! normal by a number of units in the last place proportional to its magnitude, so the offset
//! scales with the coordinates' own rounding error and needs no scene-dependent epsilon.

use glam::Vec3;

const ORIGIN: f32 = 1.0 / 32.0;
const FLOAT_SCALE: f32 = 1.0 / 65536.0;
const INT_SCALE: f32 = 256.0;

/// `p` moved off the surface along `n` (unit geometric normal, pointing to the side the new
/// ray leaves from).
#[inline]
pub fn offset_ray_origin(p: Vec3, n: Vec3) -> Vec3 {
    let of = n * INT_SCALE;
    let bump = |p: f32, of: f32| -> f32 {
        let i = of as i32;
        let bits = p.to_bits() as i32;
        f32::from_bits(bits.wrapping_add(if p < 0.0 { -i } else { i }) as u32)
    };
    let pi = Vec3::new(bump(p.x, of.x), bump(p.y, of.y), bump(p.z, of.z));
    Vec3::new(
        if p.x.abs() < ORIGIN { p.x + FLOAT_SCALE * n.x } else { pi.x },
        if p.y.abs() < ORIGIN { p.y + FLOAT_SCALE * n.y } else { pi.y },
        if p.z.abs() < ORIGIN { p.z + FLOAT_SCALE * n.z } else { pi.z },
    )
}

/// `p` moved off the surface with normal `n` (either orientation) to the side `toward`
/// points to: where a ray leaving in direction `toward` starts.
#[inline]
pub fn offset_toward(p: Vec3, n: Vec3, toward: Vec3) -> Vec3 {
    offset_ray_origin(p, if n.dot(toward) > 0.0 { n } else { -n })
}

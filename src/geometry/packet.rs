//! Eight rays side by side, structure-of-arrays: the form packet queries take (Embree's
//! `RTCRay8` stores each coordinate of its 8 rays contiguously), built in place by stages
//! that make rays in batches, such as the camera's.

use super::Ray;
use glam::Vec3;

/// Rays per packet.
pub const LANES: usize = 8;

/// Eight rays: `o[k][i]` and `d[k][i]` are coordinate `k` (x, y, z) of ray `i`'s origin and
/// direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayPacket {
    pub o: [[f32; LANES]; 3],
    pub d: [[f32; LANES]; 3],
    /// Whether the rays travel together (one origin, nearly one direction: a pixel's camera
    /// rays), a hint to the accelerator. Embree then traverses the packet as one; rays that
    /// part (random directions, paths after a bounce) must not be hinted so: on the Cornell
    /// box such packets took 1.5× the time of the same packets unhinted. False unless set.
    pub coherent: bool,
}

impl RayPacket {
    /// Every lane `ray`.
    #[inline]
    pub fn splat(ray: &Ray) -> RayPacket {
        RayPacket {
            o: [[ray.o.x; LANES], [ray.o.y; LANES], [ray.o.z; LANES]],
            d: [[ray.d.x; LANES], [ray.d.y; LANES], [ray.d.z; LANES]],
            coherent: false,
        }
    }

    /// The packet of `rays`, lane `i` ray `i`.
    #[inline]
    pub fn from_rays(rays: &[Ray; LANES]) -> RayPacket {
        let mut p = RayPacket::splat(&rays[0]);
        for (i, r) in rays.iter().enumerate().skip(1) {
            p.set(i, r);
        }
        p
    }

    /// Ray `i`.
    #[inline(always)]
    pub fn ray(&self, i: usize) -> Ray {
        Ray::new(
            Vec3::new(self.o[0][i], self.o[1][i], self.o[2][i]),
            Vec3::new(self.d[0][i], self.d[1][i], self.d[2][i]),
        )
    }

    /// Sets ray `i`.
    #[inline(always)]
    pub fn set(&mut self, i: usize, ray: &Ray) {
        (self.o[0][i], self.o[1][i], self.o[2][i]) = (ray.o.x, ray.o.y, ray.o.z);
        (self.d[0][i], self.d[1][i], self.d[2][i]) = (ray.d.x, ray.d.y, ray.d.z);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lanes_hold_the_rays_they_were_given() {
        let rays: [Ray; LANES] = std::array::from_fn(|i| {
            let f = i as f32;
            Ray::new(Vec3::new(f, -f, 2.0 * f), Vec3::new(1.0, f, -0.5 * f))
        });
        let p = RayPacket::from_rays(&rays);
        for (i, r) in rays.iter().enumerate() {
            assert_eq!(p.ray(i).o, r.o);
            assert_eq!(p.ray(i).d, r.d);
        }
        assert_eq!(p.o[2][3], 6.0);
        assert_eq!(p.d[1][7], 7.0);
    }
}

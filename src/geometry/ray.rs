use glam::Vec3;

/// A ray `o + t d`. The direction need not be normalized; `t` is measured in units of `d`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub o: Vec3,
    pub d: Vec3,
}

impl Ray {
    pub fn new(o: Vec3, d: Vec3) -> Self {
        Ray { o, d }
    }

    /// The point at parameter `t`.
    #[inline]
    pub fn at(&self, t: f32) -> Vec3 {
        self.o + t * self.d
    }
}

/// What a primitive reports about a hit, before the acceleration structure adds ids.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShapeHit {
    pub t: f32,
    /// Surface coordinates: barycentrics (weights of vertices 1 and 2) for triangles,
    /// texture coordinates in [0, 1] for spheres and cylinders.
    pub u: f32,
    pub v: f32,
    /// Geometric normal, not necessarily normalized, pointing out of closed shapes.
    pub ng: Vec3,
}

/// A closest hit reported by an acceleration structure.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    /// Index into the scene's geometry list.
    pub geom: u32,
    /// Primitive index inside that geometry.
    pub prim: u32,
    pub u: f32,
    pub v: f32,
    /// Geometric normal, not necessarily normalized. For triangles `(p1-p0) x (p2-p0)`; for a
    /// placed mesh ([`super::MeshInstance`]) in the mesh's own space, as Embree gives it.
    pub ng: Vec3,
}

impl Hit {
    pub fn from_shape(h: ShapeHit, geom: u32, prim: u32) -> Self {
        Hit { t: h.t, geom, prim, u: h.u, v: h.v, ng: h.ng }
    }
}

/// `n` corrected, if rounding put it on the wrong side, to face against `d` at a hit where the
/// ray enters a closed surface (`entering`), or along `d` where it leaves. At a near-tangent
/// hit the normal computed from the rounded hit point can point either way; a normal facing
/// the wrong way makes the surface look as if seen from inside. The correction removes the
/// component along the ray and leaves a tiny one (2⁻²⁰ of |n|) on the right side, so it only
/// ever turns the normal by a rounding-level angle.
#[inline]
pub(crate) fn face_ray(n: Vec3, d: Vec3, entering: bool) -> Vec3 {
    let dh = d.normalize_or_zero();
    let c = n.dot(dh);
    let tau = n.length() * (1.0 / 1_048_576.0);
    if entering && c > -tau {
        n - (c + tau) * dh
    } else if !entering && c < tau {
        n - (c - tau) * dh
    } else {
        n
    }
}

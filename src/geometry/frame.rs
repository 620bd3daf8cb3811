use glam::Vec3;

/// An orthonormal frame (t, b, n) around a unit normal n.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    pub t: Vec3,
    pub b: Vec3,
    pub n: Vec3,
}

impl Frame {
    /// Branchless construction of Duff et al., "Building an Orthonormal Basis, Revisited"
    /// (JCGT 2017). `n` must be unit length.
    pub fn from_normal(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let t = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let bb = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { t, b: bb, n }
    }

    /// World → local (x along t, y along b, z along n).
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.t), v.dot(self.b), v.dot(self.n))
    }

    /// Local → world.
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        v.x * self.t + v.y * self.b + v.z * self.n
    }
}

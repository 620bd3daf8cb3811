//! FNV-1a, 64 bit: a small hash that is the same across builds, Rust versions and platforms
//! (std's `DefaultHasher` promises none of that), for fingerprints and checksums written to
//! files.

/// A running FNV-1a hash.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Fnv1a(u64);

impl Default for Fnv1a {
    fn default() -> Self {
        Fnv1a(0xcbf2_9ce4_8422_2325)
    }
}

impl Fnv1a {
    pub fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3);
        }
    }

    pub fn finish(self) -> u64 {
        self.0
    }
}

/// A hash of values (fingerprints of scenes and their parts): [`Fnv1a`] fed with each value's
/// little-endian bytes, slices prefixed by their length.
#[derive(Clone, Copy, Debug, Default)]
pub struct Fingerprint(Fnv1a);

impl Fingerprint {
    pub fn bytes(&mut self, b: &[u8]) {
        self.0.write(b);
    }
    pub fn u32(&mut self, x: u32) {
        self.bytes(&x.to_le_bytes());
    }
    pub fn f32s(&mut self, v: &[f32]) {
        self.u32(v.len() as u32);
        for x in v {
            self.bytes(&x.to_bits().to_le_bytes());
        }
    }
    pub fn v3(&mut self, v: &[glam::Vec3]) {
        self.u32(v.len() as u32);
        v.iter().for_each(|p| self.f32s(&p.to_array()));
    }
    pub fn v2(&mut self, v: &[glam::Vec2]) {
        self.u32(v.len() as u32);
        v.iter().for_each(|p| self.f32s(&p.to_array()));
    }
    pub fn str(&mut self, s: &str) {
        self.u32(s.len() as u32);
        self.bytes(s.as_bytes());
    }
    pub fn finish(self) -> u64 {
        self.0.finish()
    }
}

/// The FNV-1a hash of `bytes`.
pub fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h = Fnv1a::default();
    h.write(bytes);
    h.finish()
}

#[cfg(test)]
mod tests {
    #[test]
    fn matches_the_published_test_vectors() {
        assert_eq!(super::fnv1a(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(super::fnv1a(b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(super::fnv1a(b"foobar"), 0x8594_4171_f739_67e8);
    }
}

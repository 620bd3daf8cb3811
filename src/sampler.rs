//! Deterministic random numbers.
//!
//! Every stream is a pure function of a key (seed, pixel, sample index, …), so a render does
//! not depend on thread count or tile order: the same key always gives the same numbers.

/// Mixes 64 bits (SplitMix64 finaliser; Steele, Lea, Flood 2014).
#[inline]
pub fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A small, fast generator (PCG-XSH-RR 64/32, O'Neill 2014), seeded from a hashed key.
#[derive(Clone, Debug)]
pub struct Rng {
    state: u64,
    inc: u64,
}

impl Rng {
    const MUL: u64 = 6364136223846793005;

    /// A stream identified by `key` and `stream`; distinct keys give independent-looking streams.
    pub fn new(key: u64, stream: u64) -> Self {
        Rng::from_hashed_key(mix64(key), stream)
    }

    /// [`Rng::new`] given `mix64(key)`, for many streams of one key.
    #[inline]
    fn from_hashed_key(hashed_key: u64, stream: u64) -> Self {
        let mut r = Rng { state: 0, inc: (mix64(stream ^ 0x9e37_79b9_7f4a_7c15) << 1) | 1 };
        r.next_u32();
        r.state = r.state.wrapping_add(hashed_key);
        r.next_u32();
        r
    }

    /// A stream for one (seed, pixel, sample) triple.
    pub fn for_sample(seed: u64, pixel: u64, sample: u64) -> Self {
        PixelStreams::new(seed, pixel).sample(sample)
    }

    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(Self::MUL).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// Uniform in [0, 1), never 1.
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    /// Two uniforms in [0, 1).
    #[inline]
    pub fn next_2d(&mut self) -> glam::Vec2 {
        glam::Vec2::new(self.next_f32(), self.next_f32())
    }
}

/// The streams of one pixel: [`Rng::for_sample`] with the pixel's part of the key hashed once.
#[derive(Clone, Copy, Debug)]
pub struct PixelStreams(u64);

impl PixelStreams {
    #[inline]
    pub fn new(seed: u64, pixel: u64) -> Self {
        PixelStreams(mix64(mix64(seed.wrapping_mul(0x2545_f491_4f6c_dd1d) ^ pixel)))
    }

    /// The stream of sample `sample` of the pixel: `Rng::for_sample(seed, pixel, sample)`.
    #[inline]
    pub fn sample(self, sample: u64) -> Rng {
        Rng::from_hashed_key(self.0, sample)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uniform_mean_and_range() {
        let mut r = Rng::new(1, 2);
        let n = 100_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let x = r.next_f32();
            assert!((0.0..1.0).contains(&x));
            sum += x as f64;
        }
        // Mean of U(0,1) has standard error 1/sqrt(12 n) ≈ 0.0009; allow 5 sigma.
        assert!((sum / n as f64 - 0.5).abs() < 0.0046, "mean {}", sum / n as f64);
    }

    #[test]
    fn pixel_streams_are_the_per_sample_streams() {
        // The key of (seed, pixel), hashed once per pixel, gives the streams it always gave.
        for (seed, pixel, sample) in [(0u64, 0u64, 0u64), (7, 12_345, 3), (u64::MAX, 1 << 40, 1 << 33)] {
            let mut a = PixelStreams::new(seed, pixel).sample(sample);
            let mut b = Rng::new(mix64(seed.wrapping_mul(0x2545_f491_4f6c_dd1d) ^ pixel), sample);
            assert!((0..8).all(|_| a.next_u32() == b.next_u32()));
        }
    }

    #[test]
    fn streams_are_deterministic_and_distinct() {
        let a: Vec<u32> = (0..4).map(|_| 0).scan(Rng::for_sample(7, 3, 1), |r, _| Some(r.next_u32())).collect();
        let b: Vec<u32> = (0..4).map(|_| 0).scan(Rng::for_sample(7, 3, 1), |r, _| Some(r.next_u32())).collect();
        let c: Vec<u32> = (0..4).map(|_| 0).scan(Rng::for_sample(7, 3, 2), |r, _| Some(r.next_u32())).collect();
        assert_eq!(a, b);
        assert_ne!(a, c);
    }
}

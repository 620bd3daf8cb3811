//! Deterministic random numbers.
//!
//! Every stream is a pure function of a key (seed, pixel, sample index, …), so a render does
//! not depend on thread count or tile order: the same key always gives the same numbers.
//!
//! A render's samples draw from a [`SampleStream`] of the [`SamplerKind`] asked for:
//! independent numbers (PCG, [`Rng`]), or an Owen-scrambled Sobol sequence (Burley 2020; the
//! numbers of the `sobol_burley` crate, computed here at half its cost: `SobolSet`), whose
//! samples of one pixel fill the space of the path's decisions more evenly than independent
//! ones and so give less noise at equal spp. The Sobol stream is "padded" as Burley and
//! Blender Cycles do: its numbers come four at a time, from the first four dimensions of a
//! Sobol sequence scrambled by a seed of their own (the pixel's and the set's), so that each
//! set of four is well stratified in 4D and the sets are independent of each other. A pair
//! ([`SampleStream::next_2d`]) never straddles two sets. Sample indices from 2^16 on (the
//! crate's limit) draw independent numbers.

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

/// Where a render's samples get their numbers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SamplerKind {
    /// Independent uniform numbers (PCG streams).
    Independent,
    /// An Owen-scrambled Sobol sequence per pixel, padded by sets of four dimensions.
    #[default]
    Sobol,
}

impl SamplerKind {
    pub const ALL: [SamplerKind; 2] = [SamplerKind::Independent, SamplerKind::Sobol];

    /// The name on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            SamplerKind::Independent => "independent",
            SamplerKind::Sobol => "sobol",
        }
    }
}

crate::choice::named_choice!(SamplerKind, "sampler");

/// The numbers of one sample: see the module documentation.
#[derive(Clone, Debug)]
pub enum SampleStream<'a> {
    Independent(Rng),
    Sobol(SobolStream<'a>),
}

impl<'a> SampleStream<'a> {
    /// Uniform in [0, 1), never 1.
    #[inline(always)]
    pub fn next_f32(&mut self) -> f32 {
        match self {
            SampleStream::Independent(r) => r.next_f32(),
            SampleStream::Sobol(s) if s.used < 4 => s.take(1),
            SampleStream::Sobol(_) => self.refilled().next_f32(),
        }
    }

    /// Two uniforms in [0, 1), from one set of four dimensions (Sobol).
    #[inline(always)]
    pub fn next_2d(&mut self) -> glam::Vec2 {
        match self {
            SampleStream::Independent(r) => r.next_2d(),
            SampleStream::Sobol(s) if s.used < 3 => {
                let x = s.take(2);
                glam::Vec2::new(x, s.numbers[s.used as usize - 1])
            }
            SampleStream::Sobol(_) => self.refilled().next_2d(),
        }
    }

    /// The stream with the Sobol set used up replaced: by the next set, or, from
    /// [`SobolStream::SETS`] on, by independent numbers for the rest of the sample.
    #[inline(never)]
    fn refilled(&mut self) -> &mut SampleStream<'a> {
        if let SampleStream::Sobol(s) = self {
            if s.set < SobolStream::SETS {
                s.refill();
            } else {
                *self = SampleStream::Independent(s.pixel.streams.sample(s.rev_index.reverse_bits() as u64));
            }
        }
        self
    }
}

/// One sample of a pixel's padded Owen-scrambled Sobol sequence.
#[derive(Clone, Debug)]
pub struct SobolStream<'a> {
    /// The sample index, bit-reversed (the scrambles work on reversed bits).
    rev_index: u32,
    /// The pixel's sets' scrambles, hashed once per pixel ([`SobolPixel`]).
    pixel: &'a SobolPixel,
    /// The next set of four.
    set: u32,
    /// The current set's numbers, and how many of them are used.
    numbers: [f32; 4],
    used: u8,
}

impl SobolStream<'_> {
    /// The most samples a pixel's sequence has (the crate's limit).
    pub const MAX_SAMPLES: u64 = 1 << 16;

    /// Sets of four drawn from the Sobol sequence; the sample's later numbers are independent.
    /// A path's first decisions (the pixel and lens position, then light and BSDF sampling at
    /// the first bounces) gain most from stratification; deeper ones, whose contributions are
    /// products of many factors, gain less, and a set costs about 100 instructions against 20
    /// for four independent numbers. A bounce draws only the numbers it uses (a light's choice
    /// and position, `crate::light::LightNumbers`; a lobe number, `Bsdf::chooses_lobe`): from
    /// two (a diffuse bounce, one point light: the four sets cover eight bounces) to six. Measured (`ember converge
    /// --variants samplers`, 64x64, relMSE at 256 spp): every set Sobol gave cornell-area
    /// 5.37e-3 and teapot 3.16e-4; 5 sets 5.47e-3 and 2.97e-4; 3 sets 5.77e-3 and 3.19e-4
    /// (independent: 6.90e-3 and 8.64e-4).
    pub const SETS: u32 = 5;

    #[inline]
    fn refill(&mut self) {
        self.numbers = self.pixel.sets[self.set as usize].sample(self.rev_index);
        self.set += 1;
        self.used = 0;
    }

    /// The next `n` numbers of the current set (there are): the first of them.
    #[inline(always)]
    fn take(&mut self, n: u8) -> f32 {
        self.used += n;
        self.numbers[(self.used - n) as usize]
    }
}

/// The streams of one pixel, of a [`SamplerKind`].
#[derive(Clone, Debug)]
pub enum PixelSampler {
    Independent(PixelStreams),
    Sobol(SobolPixel),
}

impl PixelSampler {
    #[inline]
    pub fn new(kind: SamplerKind, seed: u64, pixel: u64) -> Self {
        let streams = PixelStreams::new(seed, pixel);
        match kind {
            SamplerKind::Independent => PixelSampler::Independent(streams),
            SamplerKind::Sobol => PixelSampler::Sobol(SobolPixel::new(streams)),
        }
    }

    /// The numbers of sample `sample` of the pixel.
    #[inline]
    pub fn sample(&self, sample: u64) -> SampleStream<'_> {
        match self {
            PixelSampler::Sobol(pixel) if sample < SobolStream::MAX_SAMPLES => SampleStream::Sobol(SobolStream {
                rev_index: (sample as u32).reverse_bits(),
                pixel,
                set: 0,
                numbers: [0.0; 4],
                used: 4,
            }),
            PixelSampler::Sobol(pixel) => SampleStream::Independent(pixel.streams.sample(sample)),
            PixelSampler::Independent(streams) => SampleStream::Independent(streams.sample(sample)),
        }
    }

    /// Sample `sample`'s first four numbers, the ones a camera ray draws (two pairs: the film
    /// and the lens position), and its stream after them: the same numbers as four
    /// [`SampleStream::next_f32`] calls on [`PixelSampler::sample`], without the per-call
    /// bookkeeping (the first Sobol set is computed directly, not through a refill).
    #[inline]
    pub fn sample_after_first_four(&self, sample: u64) -> ([f32; 4], SampleStream<'_>) {
        match self {
            PixelSampler::Sobol(pixel) if sample < SobolStream::MAX_SAMPLES => {
                let rev_index = (sample as u32).reverse_bits();
                let numbers = pixel.sets[0].sample(rev_index);
                (numbers, SampleStream::Sobol(SobolStream { rev_index, pixel, set: 1, numbers, used: 4 }))
            }
            _ => {
                let mut s = self.sample(sample);
                let numbers = [s.next_f32(), s.next_f32(), s.next_f32(), s.next_f32()];
                (numbers, s)
            }
        }
    }
}

/// A pixel's Sobol sets: the scrambles of each set of four dimensions, hashed once per pixel
/// from the pixel's key and the set (every sample of the pixel uses the same ones), and its
/// independent streams for the numbers after the last set.
#[derive(Clone, Debug)]
pub struct SobolPixel {
    streams: PixelStreams,
    sets: [SobolSet; SobolStream::SETS as usize],
}

impl SobolPixel {
    fn new(streams: PixelStreams) -> Self {
        let sets = std::array::from_fn(|set| SobolSet::new(mix64(streams.0 ^ set as u64) as u32));
        SobolPixel { streams, sets }
    }
}

/// One set of four dimensions of an Owen-scrambled Sobol sequence, seeded: the numbers of
/// `sobol_burley::sample_4d(index, 0, seed)` bit for bit (Burley 2020, "Practical Hash-based
/// Owen Scrambling"), at about half the instructions: the seed's hashes are computed once
/// ([`SobolSet::new`]) rather than per sample, and the Sobol points come from tables of the
/// index's 4-bit digits rather than a loop over its bits.
///
/// The steps: the sample index is shuffled by an Owen scramble of its bits (a nested uniform
/// scramble, so each seed gives another, equally well stratified sequence), the shuffled index
/// gives the first four dimensions of the Sobol sequence (Joe and Kuo's direction numbers,
/// from the crate), and each dimension is Owen-scrambled by a hash of the seed and itself. The
/// scrambles work on bit-reversed integers, the form the crate's direction vectors are in.
#[derive(Clone, Copy, Debug)]
struct SobolSet {
    index_scramble: u32,
    scrambles: [u32; 4],
}

impl SobolSet {
    /// As `sobol_burley::sample_4d` derives them from its seed, for dimension set 0.
    fn new(seed: u32) -> Self {
        use sobol_burley::parts::{Int4, hash, hash_int4};
        let s = seed.wrapping_mul(0x9c8f_2d3b);
        let lanes: Int4 = [s ^ 0x912f_69ba, s ^ 0x174f_18ab, s ^ 0x691e_72ca, s ^ 0xb40c_c1b8].into();
        SobolSet { index_scramble: hash(seed ^ 0x79c6_8e4a), scrambles: hash_int4(lanes).into() }
    }

    /// The four numbers of the sample whose bit-reversed index is `rev_index` (< 2^16).
    #[inline]
    fn sample(&self, rev_index: u32) -> [f32; 4] {
        use sobol_burley::parts::{Int4, owen_scramble_int4_rev, owen_scramble_rev};
        let shuffled = owen_scramble_rev(rev_index, self.index_scramble) >> 16;
        let t = &*SOBOL_DIGITS;
        let digit = |k: usize| -> Int4 { t[k][(shuffled >> (4 * k)) as usize & 15].into() };
        let sobol = digit(0) ^ digit(1) ^ digit(2) ^ digit(3);
        owen_scramble_int4_rev(sobol, self.scrambles.into()).reverse_bits().to_f32_norm()
    }
}

/// The first four Sobol dimensions (bit-reversed, as `sobol_burley::parts::sobol_int4_rev`
/// gives them) of every 4-bit digit of a 16-bit reversed index: `SOBOL_DIGITS[k][d]` is the
/// point of the index whose only nonzero digit is `d` at digit `k` (bits 16 + 4k .. 20 + 4k).
/// A Sobol point is linear in its index's bits over GF(2), so the point of any index is the
/// XOR of its four digits' points. 1 KiB: stays in the L1 cache beside Embree's nodes.
static SOBOL_DIGITS: std::sync::LazyLock<[[[u32; 4]; 16]; 4]> = std::sync::LazyLock::new(|| {
    std::array::from_fn(|k| {
        std::array::from_fn(|d| sobol_burley::parts::sobol_int4_rev((d as u32) << (16 + 4 * k), 0).into())
    })
});

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
    fn sobol_samples_of_a_pixel_are_stratified_and_pairs_stay_together() {
        // 64 samples of the first pair: one in each cell of an 8 x 8 grid (a (0,2)-net in
        // base 2 is stratified in every elementary interval of area 1/64).
        let pixel = PixelSampler::new(SamplerKind::Sobol, 3, 1234);
        let mut cells = [0u32; 64];
        for i in 0..64 {
            let mut s = pixel.sample(i);
            let p = s.next_2d();
            assert!((0.0..1.0).contains(&p.x) && (0.0..1.0).contains(&p.y));
            cells[(p.x * 8.0) as usize * 8 + (p.y * 8.0) as usize] += 1;
        }
        assert!(cells.iter().all(|&c| c == 1), "{cells:?}");
        // After three single numbers, a pair starts a new set of four: its numbers are the
        // first two of that set.
        let mut a = pixel.sample(5);
        let (_, _, _) = (a.next_f32(), a.next_f32(), a.next_f32());
        let pair = a.next_2d();
        let mut b = pixel.sample(5);
        let _ = (b.next_2d(), b.next_2d());
        assert_eq!(pair, b.next_2d());
        // Another pixel: another scramble.
        let other = PixelSampler::new(SamplerKind::Sobol, 3, 1235);
        let mut c = other.sample(5);
        assert_ne!(c.next_2d(), pixel.sample(5).next_2d());
        // The independent kind is the PCG stream itself.
        let independent = PixelSampler::new(SamplerKind::Independent, 3, 1234);
        let mut d = independent.sample(5);
        let mut e = PixelStreams::new(3, 1234).sample(5);
        assert!((0..8).all(|_| d.next_f32() == e.next_f32()));
        // Past 2^16 samples, independent numbers.
        assert!(matches!(pixel.sample(1 << 16), SampleStream::Independent(_)));
    }

    #[test]
    fn first_four_numbers_and_the_stream_after_them_are_the_streams() {
        for kind in SamplerKind::ALL {
            let pixel = PixelSampler::new(kind, 5, 4321);
            for sample in [0u64, 1, 7, 12_345, (1 << 16) - 1, 1 << 16, 1 << 20] {
                let mut whole = pixel.sample(sample);
                let (four, mut rest) = pixel.sample_after_first_four(sample);
                let expected = [whole.next_f32(), whole.next_f32(), whole.next_f32(), whole.next_f32()];
                assert_eq!(four.map(f32::to_bits), expected.map(f32::to_bits), "{kind} sample {sample}");
                for _ in 0..30 {
                    assert_eq!(rest.next_f32().to_bits(), whole.next_f32().to_bits(), "{kind} sample {sample}");
                }
            }
        }
    }

    #[test]
    fn sobol_sets_are_the_crates_sample_4d_bit_for_bit() {
        // Every index of a few seeds, and scattered indices of many: the digit tables and the
        // hashes computed once give exactly the crate's numbers.
        for seed in [0u32, 1, 0xdead_beef, u32::MAX] {
            let set = SobolSet::new(seed);
            for index in 0..(1u32 << 16) {
                let ours = set.sample(index.reverse_bits());
                assert_eq!(ours.map(f32::to_bits), sobol_burley::sample_4d(index, 0, seed).map(f32::to_bits));
            }
        }
        let mut rng = Rng::new(11, 0);
        for _ in 0..100_000 {
            let (seed, index) = (rng.next_u32(), rng.next_u32() >> 16);
            let ours = SobolSet::new(seed).sample(index.reverse_bits());
            assert_eq!(ours.map(f32::to_bits), sobol_burley::sample_4d(index, 0, seed).map(f32::to_bits));
        }
        // And a pixel's stream is those sets in order, seeded by the pixel's key and the set.
        let streams = PixelStreams::new(3, 99);
        let pixel = PixelSampler::new(SamplerKind::Sobol, 3, 99);
        let mut s = pixel.sample(77);
        for set in 0..SobolStream::SETS as u64 {
            let expected = sobol_burley::sample_4d(77, 0, mix64(streams.0 ^ set) as u32);
            assert_eq!([s.next_f32(), s.next_f32(), s.next_f32(), s.next_f32()], expected);
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

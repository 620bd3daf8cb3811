//! Trigonometry for sampling, where libm's correctly rounded `sincosf` (a call, range
//! reduction for any argument) is more than a random angle needs.

use std::f32::consts::FRAC_PI_2;

/// `(sin 2πt, cos 2πt)` for a fraction of a turn `t` in [0, 1] (a random number), within
/// 4e-7 of the exact values (tested below against f64). Octant reduction is exact here: `t`
/// is split into the nearest quarter turn `q` and a remainder in [−1/8, 1/8] turn, whose sine
/// and cosine come from short Taylor polynomials (error below (π/4)⁹/9! ≈ 3e-7); the quarter
/// turn is then a swap of the two with signs.
#[inline(always)]
pub fn sin_cos_turns(t: f32) -> (f32, f32) {
    let t4 = 4.0 * t;
    // The nearest quarter turn, rounded through an integer conversion (a call to `roundf`
    // on baseline x86-64): `t4 + 0.5` is not negative, so truncation rounds it down.
    let q = (t4 + 0.5) as i32;
    let x = (t4 - q as f32) * FRAC_PI_2;
    let x2 = x * x;
    let s = x * (1.0 + x2 * (-1.0 / 6.0 + x2 * (1.0 / 120.0 + x2 * (-1.0 / 5040.0))));
    let c = 1.0 + x2 * (-0.5 + x2 * (1.0 / 24.0 + x2 * (-1.0 / 720.0 + x2 * (1.0 / 40320.0))));
    // Quarter turn q: (s, c), (c, −s), (−s, −c), (−c, s). Selected without a branch: the
    // quadrant of a random angle is unpredictable, and a jump table mispredicts 3 times in 4.
    // Bit masks, not `if`: the compiler turns a two-way select into a branch too.
    let (sb, cb) = (s.to_bits(), c.to_bits());
    let odd = 0u32.wrapping_sub(q as u32 & 1); // all ones for odd quarter turns
    let flip = ((q as u32) & 2) << 30; // the sign bit for the second half turn
    let a = (sb & !odd) | (cb & odd);
    let b = (cb & !odd) | ((sb ^ 0x8000_0000) & odd);
    (f32::from_bits(a ^ flip), f32::from_bits(b ^ flip))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_f64_sin_cos_over_a_turn() {
        let mut worst = 0.0f64;
        let n = 1 << 20;
        for i in 0..=n {
            let t = i as f32 / n as f32;
            let (s, c) = sin_cos_turns(t);
            let (es, ec) = (std::f64::consts::TAU * t as f64).sin_cos();
            worst = worst.max((s as f64 - es).abs()).max((c as f64 - ec).abs());
        }
        assert!(worst < 4e-7, "worst error {worst}");
    }

    #[test]
    fn quarter_turns_are_exact() {
        assert_eq!(sin_cos_turns(0.0), (0.0, 1.0));
        assert_eq!(sin_cos_turns(0.25), (1.0, -0.0));
        assert_eq!(sin_cos_turns(0.5), (-0.0, -1.0));
        assert_eq!(sin_cos_turns(0.75), (-1.0, 0.0));
    }
}

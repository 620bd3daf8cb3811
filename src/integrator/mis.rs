//! Multiple importance sampling's weights (Veach 1997, ch. 9): the share of a path that each
//! strategy able to make it counts, from the densities with which they make it.

/// The power heuristic (β = 2): the weight of a strategy of density `a` against two others of
/// densities `b` and `c`. A strategy that cannot make the path has density 0: against one
/// other strategy, `power_heuristic(a, b, 0.0)` (the same bits as the two-strategy formula).
#[inline]
pub(super) fn power_heuristic(a: f32, b: f32, c: f32) -> f32 {
    let a2 = a * a;
    let sum = a2 + b * b + c * c;
    if sum > 0.0 { a2 / sum } else { 0.0 }
}

/// The balance heuristic: the weight of a strategy of density `a` against one of density `b`.
#[inline]
pub(super) fn balance_heuristic(a: f32, b: f32) -> f32 {
    if a + b > 0.0 { a / (a + b) } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_three_weights_of_a_path_sum_to_one() {
        for (a, b, c) in [(1.0, 2.0, 3.0), (0.5, 0.0, 7.0), (1e-15, 2e-15, 1e-15), (3.0, 4.0, 0.0)] {
            let sum = power_heuristic(a, b, c) + power_heuristic(b, c, a) + power_heuristic(c, a, b);
            assert!((sum - 1.0).abs() < 1e-6, "{a} {b} {c}: {sum}");
        }
        assert_eq!(power_heuristic(3.0, 4.0, 0.0), 9.0 / 25.0);
        assert_eq!(power_heuristic(0.0, 0.0, 0.0), 0.0);
    }

    #[test]
    fn against_one_other_strategy_the_weight_is_the_two_strategy_formula_bit_for_bit() {
        let two = |a: f32, b: f32| {
            let (a2, b2) = (a * a, b * b);
            if a2 + b2 > 0.0 { a2 / (a2 + b2) } else { 0.0 }
        };
        for (a, b) in [(3.0, 4.0), (0.1, 7.5e3), (1e-20, 3e-21), (f32::MIN_POSITIVE, 0.0), (0.0, 2.0), (0.0, 0.0)] {
            assert_eq!(power_heuristic(a, b, 0.0).to_bits(), two(a, b).to_bits(), "{a} {b}");
        }
    }
}

//! The exact two-sided sign test, as McNemar's test of paired yes/no outcomes.
//!
//! Two methods judged on the same samples agree on most; only the samples where exactly one
//! of them succeeds (`b` where the first does, `c` where the second does) say which is
//! better. If both were equally good, each such sample would be the first's with
//! probability ½, so `b` is Binomial(`b + c`, ½), and the two-sided p-value is the chance of
//! a split at least as uneven: `min(1, 2 · P(X ≤ min(b, c)))`. Exact, not the χ²
//! approximation, because the discordant counts of an augment run are often a handful.
//!
//! The binomial terms are summed relative to the largest, the lower tail's last
//! (`min(b, c) ≤ n/2`), whose logarithm is carried: `2^-n` alone underflows past
//! `n = 1074`.

/// Exact two-sided McNemar p-value for `b` samples only the first method passes and `c`
/// only the second does; 1 when there are none.
pub fn mcnemar_exact_p(b: u64, c: u64) -> f64 {
    let n = b + c;
    let k = b.min(c);
    if n == 0 || 2 * k == n {
        return 1.0;
    }
    // `log_term` = ln C(n, i) − n ln 2; `tail` = Σ_{j ≤ i} C(n, j) / C(n, i), rescaled at
    // each step to the newest (largest) term.
    let mut log_term = -(n as f64) * std::f64::consts::LN_2;
    let mut tail = 1.0;
    for i in 0..k {
        let step = ((n - i) as f64).ln() - ((i + 1) as f64).ln();
        log_term += step;
        tail = tail * (-step).exp() + 1.0;
    }
    (2.0 * tail * log_term.exp()).min(1.0)
}

/// A p-value for a table or a terminal: two significant digits (two decimals from 0.1 up),
/// scientific notation below 0.001 (`0.13`, `0.013`, `0.0020`, `1.3e-8`), `< 1e-300` for
/// a p-value past the range of f64.
pub fn format_p(p: f64) -> String {
    match p {
        0.0 => "< 1e-300".into(),
        p if p >= 0.1 => format!("{p:.2}"),
        p if p >= 0.01 => format!("{p:.3}"),
        p if p >= 0.001 => format!("{p:.4}"),
        p => format!("{p:.1e}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Reference values: exact rational sums of binomial coefficients (Python `math.comb`
    /// and `fractions`), rounded to f64.
    #[test]
    fn matches_exact_binomial_sums() {
        let cases = [
            (7, 15, 0.13380050659179688),
            (5, 10, 0.3017578125),
            (0, 5, 0.0625),
            (1, 14, 0.0009765625),
            (27, 8, 0.001878225477412343),
            (30, 12, 0.007915897334896727),
            (48, 7, 1.3087586125948292e-08),
            (100, 140, 0.011664092317677663),
            (5000, 5200, 0.04878796312682245),
            (10_000, 10_300, 0.03585235973615882),
        ];
        for (b, c, p) in cases {
            let got = mcnemar_exact_p(b, c);
            assert!(
                ((got - p) / p).abs() < 1e-9,
                "b {b}, c {c}: {got} against {p}"
            );
            assert_eq!(got, mcnemar_exact_p(c, b), "symmetric in b and c");
        }
    }

    #[test]
    fn even_or_empty_splits_say_nothing() {
        for (b, c) in [(0, 0), (3, 3), (1, 0), (0, 1)] {
            assert_eq!(mcnemar_exact_p(b, c), 1.0, "b {b}, c {c}");
        }
        // Exactly 1 too, up to the rounding of the log-space sum.
        assert!((mcnemar_exact_p(6, 7) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn p_values_print_with_their_magnitude() {
        assert_eq!(format_p(1.0), "1.00");
        assert_eq!(format_p(0.13380050659179688), "0.13");
        assert_eq!(format_p(0.012939453125), "0.013");
        assert_eq!(format_p(0.001878225477412343), "0.0019");
        assert_eq!(format_p(1.3087586125948292e-08), "1.3e-8");
        assert_eq!(format_p(0.0), "< 1e-300");
    }

    /// `2^-2000` is below the smallest f64: the p-value rounds to 0, never to NaN.
    #[test]
    fn a_split_past_f64_range_is_zero() {
        assert_eq!(mcnemar_exact_p(0, 2000), 0.0);
        assert_eq!(mcnemar_exact_p(2000, 0), 0.0);
    }
}

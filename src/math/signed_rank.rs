//! The Wilcoxon signed-rank test of paired differences, exact under ties.
//!
//! Two methods judged on the same samples give each sample a figure (here a pass fraction);
//! the test asks whether the differences lean one way more than chance explains. Zero
//! differences are left out (Wilcoxon's rule); the rest are ranked by size with tied sizes
//! sharing their mean rank, and `W+` is the sum of the ranks of the positive differences.
//! Under the null each difference is as likely positive as negative, so `W+`'s
//! distribution is that of a sum of the ranks with independent fair signs: computed
//! exactly by dynamic programming over the doubled (integral) ranks, which keeps ties exact
//! where the normal approximation's tie correction would be rough. The two-sided p-value is
//! `min(1, 2 · min(P(W+ ≤ w), P(W+ ≥ w)))`.
//!
//! Pass fractions of an ensemble of 8 take 9 values, so ties are the rule, not the exception.

/// Most non-zero differences the exact distribution is computed for (its table grows as
/// `n³`); past it the normal approximation with the tie correction is used.
pub const EXACT_MAX: usize = 600;

/// The test's figures.
#[derive(Clone, Debug, PartialEq)]
pub struct SignedRank {
    /// Non-zero differences.
    pub n: usize,
    /// Positive and negative differences.
    pub positive: usize,
    pub negative: usize,
    /// Sum of the ranks of the positive differences.
    pub w_plus: f64,
    /// Two-sided p-value (1 with no non-zero difference).
    pub p: f64,
}

/// The signed-rank test of `differences` (NaNs are left out with the zeros).
pub fn signed_rank(differences: &[f64]) -> SignedRank {
    let mut d: Vec<f64> = differences
        .iter()
        .copied()
        .filter(|x| x.is_finite() && *x != 0.0)
        .collect();
    let n = d.len();
    let positive = d.iter().filter(|x| **x > 0.0).count();
    if n == 0 {
        return SignedRank {
            n,
            positive,
            negative: 0,
            w_plus: 0.0,
            p: 1.0,
        };
    }
    let (doubled, w2) = doubled_ranks(&mut d);
    let p = if n <= EXACT_MAX {
        exact_p(&doubled, w2)
    } else {
        normal_p(&doubled, w2)
    };
    SignedRank {
        n,
        positive,
        negative: n - positive,
        w_plus: w2 as f64 / 2.0,
        p,
    }
}

/// The doubled mid-ranks of the non-zero differences `d` (sorted here by size) and the
/// doubled `W+`: a tie group over positions i..j (0-based) has rank (i + j + 2) / 2.
fn doubled_ranks(d: &mut [f64]) -> (Vec<u64>, u64) {
    d.sort_by(|a, b| a.abs().total_cmp(&b.abs()));
    let n = d.len();
    let mut doubled = vec![0u64; n];
    let mut i = 0;
    while i < n {
        let mut j = i;
        while j + 1 < n && d[j + 1].abs() == d[i].abs() {
            j += 1;
        }
        for r in &mut doubled[i..=j] {
            *r = (i + j + 2) as u64;
        }
        i = j + 1;
    }
    let w2 = d
        .iter()
        .zip(&doubled)
        .filter(|(x, _)| **x > 0.0)
        .map(|(_, r)| r)
        .sum();
    (doubled, w2)
}

/// Exact two-sided p of the doubled statistic `w2` over doubled ranks `ranks`.
fn exact_p(ranks: &[u64], w2: u64) -> f64 {
    let total: u64 = ranks.iter().sum();
    // prob[s]: the chance that the positive ranks sum to s (doubled).
    let mut prob = vec![0.0f64; total as usize + 1];
    prob[0] = 1.0;
    let mut reach = 0usize;
    for &r in ranks {
        let r = r as usize;
        for s in (0..=reach).rev() {
            let q = prob[s] * 0.5;
            prob[s] = q;
            prob[s + r] += q;
        }
        reach += r;
    }
    let w = w2 as usize;
    let lower: f64 = prob[..=w].iter().sum();
    let upper: f64 = prob[w..].iter().sum();
    (2.0 * lower.min(upper)).min(1.0)
}

/// Normal approximation with the tie correction, continuity-corrected.
fn normal_p(ranks: &[u64], w2: u64) -> f64 {
    let r: Vec<f64> = ranks.iter().map(|&x| x as f64 / 2.0).collect();
    let mean = r.iter().sum::<f64>() / 2.0;
    let var = r.iter().map(|x| x * x).sum::<f64>() / 4.0;
    let z = ((w2 as f64 / 2.0 - mean).abs() - 0.5).max(0.0) / var.sqrt();
    (2.0 * upper_normal_tail(z)).min(1.0)
}

/// `P(Z > z)` of a standard normal (Abramowitz and Stegun 7.1.26 on erfc, |error| < 1.5e-7).
fn upper_normal_tail(z: f64) -> f64 {
    let x = z / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.327_591_1 * x);
    let poly = t
        * (0.254_829_592
            + t * (-0.284_496_736
                + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
    0.5 * poly * (-x * x).exp()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_cases_match_the_enumerated_distribution() {
        // Ranks 1..5, all positive: W+ = 15, the one largest of 32 sign patterns: p = 2/32.
        let r = signed_rank(&[1.0, 2.0, 3.0, 4.0, 5.0]);
        assert_eq!((r.n, r.positive, r.w_plus), (5, 5, 15.0));
        assert!((r.p - 2.0 / 32.0).abs() < 1e-12, "{}", r.p);
        // Symmetric: p = 1.
        assert_eq!(signed_rank(&[1.0, -1.0]).p, 1.0);
        // Zeros left out.
        assert_eq!(signed_rank(&[0.0, 0.0]).p, 1.0);
    }

    #[test]
    fn ties_share_their_mean_rank() {
        // |d| = 1, 1, 2: ranks 1.5, 1.5, 3; W+ = 1.5 + 3 = 4.5 when the second is negative.
        let r = signed_rank(&[0.5, -0.5, 0.75].map(|x| x * 2.0));
        assert_eq!(r.w_plus, 4.5);
        // The eight equally likely sign patterns give W+ in {0, 1.5, 1.5, 3, 3, 4.5, 4.5, 6}:
        // P(W+ >= 4.5) = 3/8, so p = 6/8.
        assert!((r.p - 0.75).abs() < 1e-12, "{}", r.p);
    }

    #[test]
    fn the_normal_approximation_agrees_with_the_exact_test_on_many_pairs() {
        let mut d: Vec<f64> = (0..200)
            .map(|i| ((i * 37 % 11) as f64 - 4.0) / 8.0)
            .filter(|x| *x != 0.0)
            .collect();
        let exact = signed_rank(&d).p;
        let (ranks, w2) = doubled_ranks(&mut d);
        let approx = normal_p(&ranks, w2);
        assert!(
            (approx - exact).abs() < 0.01,
            "exact {exact} against normal {approx}"
        );
    }
}

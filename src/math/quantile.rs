//! Quantiles of sorted samples.

/// The `q` quantile (0..1) of `sorted` (ascending), linear between order statistics;
/// `None` when there are no samples.
pub fn quantile_sorted(sorted: &[f64], q: f64) -> Option<f64> {
    let last = sorted.len().checked_sub(1)?;
    let pos = q.clamp(0.0, 1.0) * last as f64;
    let lo = pos.floor() as usize;
    let hi = (lo + 1).min(last);
    Some(sorted[lo] + (sorted[hi] - sorted[lo]) * (pos - lo as f64))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_interpolate_between_order_statistics() {
        assert_eq!(quantile_sorted(&[0.0, 10.0], 0.25), Some(2.5));
        assert_eq!(quantile_sorted(&[1.0, 2.0, 4.0], 0.5), Some(2.0));
        assert_eq!(quantile_sorted(&[3.0], 0.9), Some(3.0));
        assert_eq!(quantile_sorted(&[1.0, 5.0], 2.0), Some(5.0));
        assert_eq!(quantile_sorted(&[], 0.5), None);
    }
}

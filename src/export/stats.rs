//! Per-feature statistics of a dataset, as LeRobot's `meta/stats.json` holds them.
//!
//! For a feature of shape `(n,)` over `N` frames: `min`, `max`, `mean`, `std` (population,
//! `sqrt(E[x²] − E[x]²)` clamped at 0, as LeRobot computes it), each a list of `n` values,
//! `count = [N]`, and the quantiles `q01`, `q10`, `q50`, `q90`, `q99` (LeRobot's default
//! list). LeRobot estimates quantiles from 5000-bin histograms; we compute them exactly
//! (linear interpolation between order statistics, numpy's default), which its estimate
//! approximates. Scalar features (`timestamp`, the indices) are lists of one value.

use serde_json::{Map, Value, json};

use crate::math::quantile::quantile_sorted;

/// The quantiles LeRobot writes, with their keys.
pub const QUANTILES: [(f64, &str); 5] = [
    (0.01, "q01"),
    (0.10, "q10"),
    (0.50, "q50"),
    (0.90, "q90"),
    (0.99, "q99"),
];

/// The statistics of a feature, in LeRobot's order.
pub const STATS: [&str; 10] = [
    "min", "max", "mean", "std", "count", "q01", "q10", "q50", "q90", "q99",
];

/// Statistics of `rows` (every row of the same length `n`), as a JSON object.
pub fn feature_stats(rows: &[&[f64]]) -> Value {
    let n = rows.first().map_or(0, |r| r.len());
    let count = rows.len();
    let mut out = Map::new();
    let mut mins = Vec::with_capacity(n);
    let mut maxs = Vec::with_capacity(n);
    let mut means = Vec::with_capacity(n);
    let mut stds = Vec::with_capacity(n);
    let mut quants = vec![Vec::with_capacity(n); QUANTILES.len()];
    let mut column = Vec::with_capacity(count);
    for j in 0..n {
        column.clear();
        column.extend(rows.iter().map(|r| r[j]));
        let mean = column.iter().sum::<f64>() / count.max(1) as f64;
        let mean_sq = column.iter().map(|v| v * v).sum::<f64>() / count.max(1) as f64;
        means.push(mean);
        stds.push((mean_sq - mean * mean).max(0.0).sqrt());
        column.sort_by(f64::total_cmp);
        mins.push(column.first().copied().unwrap_or(0.0));
        maxs.push(column.last().copied().unwrap_or(0.0));
        for (k, (q, _)) in QUANTILES.iter().enumerate() {
            quants[k].push(quantile_sorted(&column, *q).unwrap_or(0.0));
        }
    }
    out.insert("min".into(), json!(mins));
    out.insert("max".into(), json!(maxs));
    out.insert("mean".into(), json!(means));
    out.insert("std".into(), json!(stds));
    out.insert("count".into(), json!([count]));
    for (k, (_, key)) in QUANTILES.iter().enumerate() {
        out.insert((*key).into(), json!(quants[k]));
    }
    Value::Object(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stats_of_a_known_column() {
        let data: Vec<[f64; 2]> = (0..=100).map(|i| [i as f64, 2.0]).collect();
        let rows: Vec<&[f64]> = data.iter().map(|r| &r[..]).collect();
        let s = feature_stats(&rows);
        assert_eq!(s["min"], json!([0.0, 2.0]));
        assert_eq!(s["max"], json!([100.0, 2.0]));
        assert_eq!(s["mean"], json!([50.0, 2.0]));
        assert_eq!(s["count"], json!([101]));
        assert_eq!(s["q10"], json!([10.0, 2.0]));
        assert_eq!(s["q50"], json!([50.0, 2.0]));
        assert_eq!(s["q99"], json!([99.0, 2.0]));
        // Population std of 0..=100: sqrt((101² − 1) / 12).
        let std = s["std"][0].as_f64().unwrap();
        assert!((std - ((101.0f64 * 101.0 - 1.0) / 12.0).sqrt()).abs() < 1e-9);
        assert_eq!(s["std"][1], json!(0.0));
    }
}

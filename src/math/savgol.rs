//! Savitzky-Golay smoothing, numerically matching `scipy.signal.savgol_filter` (mode='interp').
//!
//! A Savitzky-Golay filter replaces each sample by the value (or a derivative) at one
//! position of the least-squares polynomial of order `polyorder` fitted to a window of
//! `window` samples. Because the fit is linear in the data, the result is a dot product with
//! fixed coefficients c: with sample offsets x_i = i − pos (i = 0..window) and the
//! Vandermonde matrix A_{j,i} = x_i^j (j = 0..=polyorder), c is the minimum-norm solution of
//! A c = k!·e_k for derivative order k (the polynomial's k-th derivative at x = 0 is
//! Σ_i c_i y_i). This is exactly scipy's `savgol_coeffs(.., use='dot')`.
//!
//! We solve it through a QR factorization of Aᵀ = QR (full column rank because the x_i are
//! distinct and window > polyorder): c = Q R⁻ᵀ (k! e_k). The offsets are divided by the
//! half-width h first, which leaves c unchanged (the equations are only rescaled row by row)
//! but keeps the powers x^j of order one, so the conditioning does not grow like h^polyorder.
//!
//! Edges follow scipy's default mode='interp': the first and last `window / 2` outputs are
//! the polynomial fitted to the first (last) `window` samples, evaluated at their positions,
//! i.e. the same dot product with an off-center `pos`. Tests compare against reference
//! numbers produced by scipy (`tests/data/savgol_reference.json`, generator script inside).

use nalgebra::{DMatrix, DVector, Vector3};

/// Why Savitzky-Golay coefficients or a filtered signal could not be computed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SavgolError {
    /// The window does not exceed the polynomial order, so the fit is not determined.
    #[error("window {window} must be greater than polyorder {polyorder}")]
    WindowTooSmall { window: usize, polyorder: usize },
    /// The filter needs a centered window.
    #[error("window {window} must be odd (try {})", window + 1)]
    EvenWindow { window: usize },
    /// The evaluation position lies outside the window.
    #[error("pos {pos} must lie inside the window 0..{window}")]
    PosOutsideWindow { pos: usize, window: usize },
    /// An input sample is NaN or infinite.
    #[error("sample {index} is {value}; the signal must be finite")]
    NonFinite { index: usize, value: f64 },
    /// The least-squares system could not be solved (should not happen for valid sizes).
    #[error(
        "the Savitzky-Golay least-squares fit is singular (window {window}, polyorder {polyorder})"
    )]
    Singular { window: usize, polyorder: usize },
}

/// Coefficients c (length `window`) such that Σ_i c_i y_i is the `deriv`-th derivative, at
/// sample `pos` of the window, of the order-`polyorder` least-squares polynomial through the
/// window samples y_0..y_{window-1}.
///
/// Same as `scipy.signal.savgol_coeffs(window, polyorder, deriv, pos=pos, use='dot')` with
/// unit sample spacing: divide a derivative by Δt^deriv for physical units. `deriv >
/// polyorder` gives zeros, as in scipy. Any `window > polyorder` is accepted here (even
/// windows too); only the filter requires an odd window.
pub fn savgol_coeffs(
    window: usize,
    polyorder: usize,
    deriv: usize,
    pos: usize,
) -> Result<Vec<f64>, SavgolError> {
    if window <= polyorder {
        return Err(SavgolError::WindowTooSmall { window, polyorder });
    }
    if pos >= window {
        return Err(SavgolError::PosOutsideWindow { pos, window });
    }
    if deriv > polyorder {
        return Ok(vec![0.0; window]);
    }
    let cols = polyorder + 1;
    let h = pos.max(window - 1 - pos).max(1) as f64;
    // Aᵀ: one row per sample, columns 1, x, x², … in scaled offsets x = (i − pos)/h.
    let at = DMatrix::from_fn(window, cols, |i, j| {
        ((i as f64 - pos as f64) / h).powi(j as i32)
    });
    let qr = at.qr();
    // In scaled units the k-th derivative picks up a factor h^-k: y[k] = k!/h^k.
    let mut rhs = DVector::zeros(cols);
    rhs[deriv] = (1..=deriv).map(|v| v as f64 / h).product::<f64>();
    let z = qr
        .r()
        .transpose()
        .solve_lower_triangular(&rhs)
        .filter(|z| z.iter().all(|v| v.is_finite()))
        .ok_or(SavgolError::Singular { window, polyorder })?;
    Ok((qr.q() * z).iter().copied().collect())
}

/// Smooths `data` with a Savitzky-Golay filter like `scipy.signal.savgol_filter(data,
/// window, polyorder)` (deriv 0, mode='interp').
///
/// `window` must be odd and greater than `polyorder`. Short signals, where scipy raises an
/// error, are handled instead: if `data.len() < window` the window shrinks to the largest odd
/// length ≤ `data.len()`; if that is not greater than `polyorder` no polynomial can be
/// fitted and the data are returned unchanged. (A window of exactly polyorder + 1 samples
/// interpolates them, so it also returns the data unchanged.) Non-finite samples are an error.
pub fn savgol_filter(
    data: &[f64],
    window: usize,
    polyorder: usize,
) -> Result<Vec<f64>, SavgolError> {
    if window <= polyorder {
        return Err(SavgolError::WindowTooSmall { window, polyorder });
    }
    if window.is_multiple_of(2) {
        return Err(SavgolError::EvenWindow { window });
    }
    if let Some(index) = data.iter().position(|v| !v.is_finite()) {
        return Err(SavgolError::NonFinite {
            index,
            value: data[index],
        });
    }
    let n = data.len();
    let w = if n >= window {
        window
    } else if n % 2 == 1 {
        n
    } else {
        n.saturating_sub(1)
    };
    if w <= polyorder {
        return Ok(data.to_vec());
    }
    let half = w / 2;
    let dot = |c: &[f64], x: &[f64]| c.iter().zip(x).map(|(a, b)| a * b).sum::<f64>();
    let mut out = vec![0.0; n];
    let center = savgol_coeffs(w, polyorder, 0, half)?;
    for i in half..n - half {
        out[i] = dot(&center, &data[i - half..=i + half]);
    }
    // mode='interp': the edge windows' polynomials evaluated off-center.
    for i in 0..half {
        out[i] = dot(&savgol_coeffs(w, polyorder, 0, i)?, &data[..w]);
        let pos = w - 1 - i;
        out[n - w + pos] = dot(&savgol_coeffs(w, polyorder, 0, pos)?, &data[n - w..]);
    }
    Ok(out)
}

/// [`savgol_filter`] applied to each coordinate of a 3-D signal (e.g. a wrist translation).
pub fn savgol_filter3(
    data: &[Vector3<f64>],
    window: usize,
    polyorder: usize,
) -> Result<Vec<Vector3<f64>>, SavgolError> {
    let mut out = vec![Vector3::zeros(); data.len()];
    for c in 0..3 {
        let column: Vec<f64> = data.iter().map(|v| v[c]).collect();
        for (o, v) in out
            .iter_mut()
            .zip(savgol_filter(&column, window, polyorder)?)
        {
            o[c] = v;
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use serde::Deserialize;

    /// Reference numbers from scipy 1.17.1; the generator script is stored in the file.
    const REFERENCE: &str = include_str!("../../tests/data/savgol_reference.json");

    #[derive(Deserialize)]
    struct Reference {
        filter_cases: Vec<FilterCase>,
        coeff_cases: Vec<CoeffCase>,
    }

    #[derive(Deserialize)]
    struct FilterCase {
        name: String,
        window: usize,
        polyorder: usize,
        input: Vec<f64>,
        output: Vec<f64>,
    }

    #[derive(Deserialize)]
    struct CoeffCase {
        window: usize,
        polyorder: usize,
        deriv: usize,
        pos: usize,
        coeffs: Vec<f64>,
    }

    fn reference() -> Reference {
        serde_json::from_str(REFERENCE).expect("tests/data/savgol_reference.json parses")
    }

    #[test]
    fn filter_matches_scipy() {
        let cases = reference().filter_cases;
        assert!(cases.len() >= 10);
        let mut worst: f64 = 0.0;
        for case in cases {
            let got = savgol_filter(&case.input, case.window, case.polyorder).unwrap();
            assert_eq!(got.len(), case.output.len(), "{}", case.name);
            for (i, (g, want)) in got.iter().zip(&case.output).enumerate() {
                let err = (g - want).abs();
                worst = worst.max(err);
                assert!(
                    err < 1e-9,
                    "{}: sample {i}: {g} vs scipy {want} (|Δ| = {err:e})",
                    case.name
                );
            }
        }
        println!("largest deviation from scipy: {worst:e}");
    }

    #[test]
    fn coeffs_match_scipy() {
        for case in reference().coeff_cases {
            let got = savgol_coeffs(case.window, case.polyorder, case.deriv, case.pos).unwrap();
            for (g, want) in got.iter().zip(&case.coeffs) {
                assert!(
                    (g - want).abs() < 1e-9,
                    "w {} p {} d {} pos {}: {g} vs scipy {want}",
                    case.window,
                    case.polyorder,
                    case.deriv,
                    case.pos
                );
            }
        }
    }

    #[test]
    fn classic_five_point_quadratic() {
        // Savitzky & Golay (1964), table I: (-3, 12, 17, 12, -3) / 35.
        let c = savgol_coeffs(5, 2, 0, 2).unwrap();
        for (g, w) in c.iter().zip([-3.0, 12.0, 17.0, 12.0, -3.0]) {
            assert!((g - w / 35.0).abs() < 1e-14);
        }
        assert_eq!(savgol_coeffs(5, 2, 3, 2).unwrap(), vec![0.0; 5]);
    }

    #[test]
    fn short_and_degenerate_signals() {
        let x = [1.0, 4.0, 2.0];
        // Window 7 shrinks to 3 = polyorder + 1: an interpolating fit, data unchanged.
        let y = savgol_filter(&x, 7, 2).unwrap();
        assert!(
            y.iter().zip(&x).all(|(a, b)| (a - b).abs() < 1e-12),
            "{y:?}"
        );
        // Shrinking to 3 ≤ polyorder 3 is impossible: returned unchanged.
        assert_eq!(savgol_filter(&x, 7, 3).unwrap(), x.to_vec());
        assert_eq!(savgol_filter(&[5.0, 6.0], 5, 2).unwrap(), vec![5.0, 6.0]);
        assert!(savgol_filter(&[], 5, 2).unwrap().is_empty());
    }

    #[test]
    fn rejects_bad_arguments() {
        assert_eq!(
            savgol_filter(&[0.0; 9], 6, 2),
            Err(SavgolError::EvenWindow { window: 6 })
        );
        assert_eq!(
            savgol_filter(&[0.0; 9], 3, 3),
            Err(SavgolError::WindowTooSmall {
                window: 3,
                polyorder: 3
            })
        );
        assert!(matches!(
            savgol_filter(&[0.0, f64::NAN, 0.0], 3, 1),
            Err(SavgolError::NonFinite { index: 1, .. })
        ));
        assert_eq!(
            savgol_coeffs(5, 2, 0, 5),
            Err(SavgolError::PosOutsideWindow { pos: 5, window: 5 })
        );
    }

    #[test]
    fn filter3_filters_each_coordinate() {
        let pts: Vec<Vector3<f64>> = (0..30)
            .map(|i| Vector3::new(i as f64, (i as f64).sin(), (i * i % 7) as f64))
            .collect();
        let y = savgol_filter3(&pts, 7, 2).unwrap();
        let z: Vec<f64> = pts.iter().map(|p| p.z).collect();
        let zf = savgol_filter(&z, 7, 2).unwrap();
        for i in 0..30 {
            assert!((y[i].x - i as f64).abs() < 1e-9, "a line is preserved");
            assert_eq!(y[i].z, zf[i]);
        }
    }

    proptest! {
        /// A polynomial of degree ≤ polyorder passes through the filter unchanged, edges included.
        #[test]
        fn prop_preserves_polynomials(
            coeffs in prop::collection::vec(-2.0f64..2.0, 5),
            half in 1usize..10,
            polyorder in 0usize..5,
            n in 1usize..80,
        ) {
            let window = 2 * half + 1;
            prop_assume!(window > polyorder);
            let x: Vec<f64> = (0..n)
                .map(|i| {
                    let t = i as f64 / 10.0;
                    coeffs[..=polyorder].iter().rev().fold(0.0, |acc, c| acc * t + c)
                })
                .collect();
            let y = savgol_filter(&x, window, polyorder).unwrap();
            for (a, b) in y.iter().zip(&x) {
                prop_assert!((a - b).abs() < 1e-8 * b.abs().max(1.0), "{} vs {}", a, b);
            }
        }
    }
}

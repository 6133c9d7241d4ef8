//! Global B-spline interpolation in any dimension (Piegl & Tiller, *The NURBS Book*, 2nd ed.).
//!
//! Given n+1 points Q_k ∈ ℝ^d and strictly increasing parameters ū_0 < … < ū_n, find the
//! degree-p curve C(u) = Σ_{i=0}^{n} N_{i,p}(u) P_i with C(ū_k) = Q_k (algorithm A9.1):
//!
//! 1. knots by averaging (eq. 9.8): u_0 = … = u_p = ū_0, u_{m-p} = … = u_m = ū_n with
//!    m = n+p+1, and u_{j+p} = (1/p) Σ_{i=j}^{j+p-1} ū_i for j = 1..=n-p. Interior knots are
//!    strictly increasing whenever the ū are, so the curve is C^{p-1} (C² for cubics);
//! 2. the collocation system A P = Q with A_{k,i} = N_{i,p}(ū_k). Averaged knots satisfy the
//!    Schoenberg–Whitney condition, so A is nonsingular; it is banded (row k is nonzero only in
//!    columns span(ū_k)-p ..= span(ū_k), all within k-p ..= k+p) and totally positive, so
//!    Gaussian elimination *without pivoting* is stable (de Boor & Pinkus 1977). The band LU
//!    costs O(n·p²) time and O(n·p) memory; no dense n×n matrix is ever formed.
//!
//! Evaluation uses the Cox–de Boor recurrence in triangular form (A2.1 span search, A2.2 basis
//! functions, A2.3 basis derivatives) followed by A3.1/A3.2, with fixed-size stack buffers: no
//! allocation per call. Degrees up to [`MAX_DEGREE`] are supported.

use nalgebra::Vector3;

/// Highest supported degree; bounds the stack buffers used by evaluation.
pub const MAX_DEGREE: usize = 7;

/// Floor on a chord in [`chord_length_params`], as a fraction of the mean chord length.
///
/// Coincident consecutive points (an object held still for a few frames) would otherwise get
/// equal parameters, which interpolation cannot accept. With this floor they get a parameter
/// step of 0.1 % of the mean chord: strictly increasing, yet small enough not to distort the
/// parameterization of the moving part.
pub const MIN_CHORD_FRACTION: f64 = 1e-3;

/// Why an interpolation or a parameterization could not be computed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BSplineError {
    /// There is nothing to interpolate.
    #[error("no points to interpolate; at least one point is needed")]
    Empty,
    /// The dimension is zero.
    #[error("the point dimension is 0; it must be at least 1")]
    ZeroDim,
    /// The flat point buffer does not hold `params × dim` values.
    #[error("points hold {values} values, expected {params} parameters × dim {dim}")]
    Shape {
        values: usize,
        params: usize,
        dim: usize,
    },
    /// The requested degree is 0 or above [`MAX_DEGREE`].
    #[error("degree {degree} is not supported; use 1 ..= {MAX_DEGREE} (3 for a C² cubic)")]
    Degree { degree: usize },
    /// A parameter is NaN or infinite.
    #[error("parameter {index} is {value}; parameters must be finite")]
    NonFiniteParam { index: usize, value: f64 },
    /// Parameters are not strictly increasing.
    #[error(
        "parameter {index} is {value}, not greater than parameter {} ({prev}); parameters must be strictly increasing",
        index - 1
    )]
    NotIncreasing { index: usize, prev: f64, value: f64 },
    /// A point coordinate is NaN or infinite.
    #[error("point {index}, coordinate {coord} is {value}; points must be finite")]
    NonFinitePoint {
        index: usize,
        coord: usize,
        value: f64,
    },
    /// The total chord length overflowed.
    #[error("the total chord length is not finite; the points are too far apart")]
    ChordOverflow,
    /// The collocation solve met a zero pivot or produced a non-finite control point.
    #[error(
        "the collocation system is numerically singular at row {row}; parameters are too close"
    )]
    Singular { row: usize },
}

/// A non-rational B-spline curve in ℝ^d with a clamped knot vector.
///
/// Control points are stored flat, row-major (`n_ctrl × dim`).
#[derive(Debug, Clone, PartialEq)]
pub struct BSpline {
    degree: usize,
    dim: usize,
    knots: Vec<f64>,
    ctrl: Vec<f64>,
}

/// Normalized chord-length parameters of `points` (flat, row-major `n × dim`) in [0, 1].
///
/// ū_0 = 0, ū_k = ū_{k-1} + |Q_k − Q_{k-1}| / L, ū_n = 1 (eq. 9.5), where each chord is
/// floored at [`MIN_CHORD_FRACTION`] × (mean chord) so the result is strictly increasing
/// even when consecutive points coincide. If all points coincide (L = 0) the parameters fall
/// back to uniform, k/n. One point gives `[0.0]`, no point gives `[]`.
pub fn chord_length_params(points: &[f64], dim: usize) -> Result<Vec<f64>, BSplineError> {
    if dim == 0 {
        return Err(BSplineError::ZeroDim);
    }
    if !points.len().is_multiple_of(dim) {
        return Err(BSplineError::Shape {
            values: points.len(),
            params: points.len() / dim,
            dim,
        });
    }
    check_points(points, dim)?;
    let n = points.len() / dim;
    if n <= 1 {
        return Ok(vec![0.0; n]);
    }
    let chords: Vec<f64> = points
        .chunks_exact(dim)
        .zip(points.chunks_exact(dim).skip(1))
        .map(|(a, b)| {
            a.iter()
                .zip(b)
                .map(|(x, y)| (y - x) * (y - x))
                .sum::<f64>()
                .sqrt()
        })
        .collect();
    let total: f64 = chords.iter().sum();
    if !total.is_finite() {
        return Err(BSplineError::ChordOverflow);
    }
    let floor = MIN_CHORD_FRACTION * total / (n - 1) as f64;
    if floor <= 0.0 {
        // All points coincide (or the spread underflows): uniform parameters.
        return Ok((0..n).map(|k| k as f64 / (n - 1) as f64).collect());
    }
    let floored_total: f64 = chords.iter().map(|&c| c.max(floor)).sum();
    let mut params = Vec::with_capacity(n);
    let mut acc = 0.0;
    params.push(0.0);
    for &c in &chords[..n - 2] {
        acc += c.max(floor);
        params.push(acc / floored_total);
    }
    params.push(1.0);
    Ok(params)
}

/// [`chord_length_params`] for 3-D points.
pub fn chord_length_params3(points: &[Vector3<f64>]) -> Result<Vec<f64>, BSplineError> {
    chord_length_params(&flatten3(points), 3)
}

impl BSpline {
    /// Interpolates `points` (flat, row-major `n × dim`) at `params` with a degree-`degree`
    /// B-spline (A9.1; see the module docs for the math).
    ///
    /// `params` must be finite and strictly increasing; they need not lie in [0, 1]. With too
    /// few points the degree is lowered to n−1: two points give a line, three a parabola, one
    /// point a constant (degree 0). Errors are returned for empty input, a shape mismatch,
    /// non-finite values, non-increasing parameters and an unsupported degree.
    pub fn interpolate(
        params: &[f64],
        points: &[f64],
        dim: usize,
        degree: usize,
    ) -> Result<BSpline, BSplineError> {
        validate(params, points, dim, degree)?;
        let n = params.len();
        let p = degree.min(n - 1);
        if p == 0 {
            return Ok(BSpline {
                degree: 0,
                dim,
                knots: vec![params[0], params[0]],
                ctrl: points.to_vec(),
            });
        }
        let knots = averaged_knots(params, p);
        let mut spline = BSpline {
            degree: p,
            dim,
            knots,
            ctrl: points.to_vec(),
        };
        let mut band = BandMatrix::zeros(n, p, p);
        let mut basis = [0.0; MAX_DEGREE + 1];
        for (k, &u) in params.iter().enumerate() {
            let span = spline.find_span(u);
            spline.basis_funs(span, u, &mut basis);
            for (j, &b) in basis[..=p].iter().enumerate() {
                // Cannot fail for averaged knots (Schoenberg–Whitney); checked, not assumed.
                if !band.set(k, span - p + j, b) && b != 0.0 {
                    return Err(BSplineError::Singular { row: k });
                }
            }
        }
        band.factor_lu()?;
        band.solve_in_place(&mut spline.ctrl, dim);
        if let Some(pos) = spline.ctrl.iter().position(|v| !v.is_finite()) {
            return Err(BSplineError::Singular { row: pos / dim });
        }
        Ok(spline)
    }

    /// [`BSpline::interpolate`] for 3-D points.
    pub fn interpolate3(
        params: &[f64],
        points: &[Vector3<f64>],
        degree: usize,
    ) -> Result<BSpline, BSplineError> {
        BSpline::interpolate(params, &flatten3(points), 3, degree)
    }

    /// Degree actually used (lowered for short inputs).
    pub fn degree(&self) -> usize {
        self.degree
    }

    /// Dimension d of the points.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// The clamped knot vector (length n_ctrl + p + 1).
    pub fn knots(&self) -> &[f64] {
        &self.knots
    }

    /// Control points, flat row-major (`n_ctrl × dim`).
    pub fn control_points(&self) -> &[f64] {
        &self.ctrl
    }

    /// Parameter domain [ū_0, ū_n].
    pub fn domain(&self) -> (f64, f64) {
        (self.knots[0], self.knots[self.knots.len() - 1])
    }

    /// Writes C(u) into `out` (length `dim`).
    ///
    /// `u` outside the domain is clamped to it; a NaN `u` writes NaN (NaN in, NaN out).
    ///
    /// # Panics
    /// If `out.len() != self.dim()` (a programming error, not an input error).
    pub fn eval(&self, u: f64, out: &mut [f64]) {
        self.eval_derivative(u, 0, out);
    }

    /// Writes the k-th derivative C^(k)(u) with respect to u into `out` (length `dim`).
    ///
    /// k = 0 is the point itself; k > degree gives zero. The *parameter* is clamped, so outside
    /// the domain the derivatives are those at the nearest end (not zero). At an interior knot
    /// the right-hand piece is used; for k ≤ p−1 both sides agree (C^{p-1}).
    ///
    /// # Panics
    /// If `out.len() != self.dim()`.
    pub fn eval_derivative(&self, u: f64, k: usize, out: &mut [f64]) {
        assert_eq!(
            out.len(),
            self.dim,
            "output length must equal the spline dimension"
        );
        if u.is_nan() {
            out.fill(f64::NAN);
            return;
        }
        let (lo, hi) = self.domain();
        let u = u.clamp(lo, hi);
        self.eval_in_span(self.find_span(u), u, k, out);
    }

    /// C(u) for a 3-D spline.
    ///
    /// # Panics
    /// If `self.dim() != 3`.
    pub fn eval3(&self, u: f64) -> Vector3<f64> {
        self.eval_derivative3(u, 0)
    }

    /// C^(k)(u) for a 3-D spline.
    ///
    /// # Panics
    /// If `self.dim() != 3`.
    pub fn eval_derivative3(&self, u: f64, k: usize) -> Vector3<f64> {
        let mut out = [0.0; 3];
        self.eval_derivative(u, k, &mut out);
        Vector3::from(out)
    }

    /// Evaluates the polynomial piece of knot span `span` at `u` (A3.2 for one order `k`).
    ///
    /// `u` may be either end of the span, which lets tests take one-sided limits at knots.
    fn eval_in_span(&self, span: usize, u: f64, k: usize, out: &mut [f64]) {
        let p = self.degree;
        let d = self.dim;
        if k > p {
            out.fill(0.0);
            return;
        }
        if p == 0 {
            out.copy_from_slice(&self.ctrl[..d]);
            return;
        }
        let mut ders = [[0.0; MAX_DEGREE + 1]; MAX_DEGREE + 1];
        if k == 0 {
            // Plain points need only A2.2, about half the work of A2.3.
            self.basis_funs(span, u, &mut ders[0]);
        } else {
            self.ders_basis_funs(span, u, k, &mut ders);
        }
        out.fill(0.0);
        for (j, &w) in ders[k][..=p].iter().enumerate() {
            let row = &self.ctrl[(span - p + j) * d..(span - p + j + 1) * d];
            for (o, &c) in out.iter_mut().zip(row) {
                *o += w * c;
            }
        }
    }

    /// Knot span index s with u_s ≤ u < u_{s+1}, s ∈ [p, n_ctrl−1] (A2.1, binary search).
    ///
    /// `u` must lie in the domain; the right end maps to the last span.
    fn find_span(&self, u: f64) -> usize {
        let p = self.degree;
        let last = self.ctrl.len() / self.dim - 1;
        if u >= self.knots[last + 1] {
            return last;
        }
        if u <= self.knots[p] {
            return p;
        }
        let (mut low, mut high) = (p, last + 1);
        let mut mid = (low + high) / 2;
        while u < self.knots[mid] || u >= self.knots[mid + 1] {
            if u < self.knots[mid] {
                high = mid;
            } else {
                low = mid;
            }
            mid = (low + high) / 2;
        }
        mid
    }

    /// Nonzero basis functions N_{span-p..=span, p}(u) into `n[..=p]` (A2.2).
    fn basis_funs(&self, span: usize, u: f64, n: &mut [f64; MAX_DEGREE + 1]) {
        let p = self.degree;
        let mut left = [0.0; MAX_DEGREE + 1];
        let mut right = [0.0; MAX_DEGREE + 1];
        n[0] = 1.0;
        for j in 1..=p {
            left[j] = u - self.knots[span + 1 - j];
            right[j] = self.knots[span + j] - u;
            let mut saved = 0.0;
            for r in 0..j {
                let temp = n[r] / (right[r + 1] + left[j - r]);
                n[r] = saved + right[r + 1] * temp;
                saved = left[j - r] * temp;
            }
            n[j] = saved;
        }
    }

    /// Basis functions and their derivatives up to order `nd` ≤ p (A2.3):
    /// `ders[k][j]` = N^(k)_{span-p+j, p}(u).
    fn ders_basis_funs(
        &self,
        span: usize,
        u: f64,
        nd: usize,
        ders: &mut [[f64; MAX_DEGREE + 1]; MAX_DEGREE + 1],
    ) {
        let p = self.degree;
        let knots = &self.knots;
        // ndu[j][r]: basis functions (upper triangle incl. diagonal) and knot differences (lower).
        let mut ndu = [[0.0; MAX_DEGREE + 1]; MAX_DEGREE + 1];
        let mut left = [0.0; MAX_DEGREE + 1];
        let mut right = [0.0; MAX_DEGREE + 1];
        ndu[0][0] = 1.0;
        for j in 1..=p {
            left[j] = u - knots[span + 1 - j];
            right[j] = knots[span + j] - u;
            let mut saved = 0.0;
            for r in 0..j {
                ndu[j][r] = right[r + 1] + left[j - r];
                let temp = ndu[r][j - 1] / ndu[j][r];
                ndu[r][j] = saved + right[r + 1] * temp;
                saved = left[j - r] * temp;
            }
            ndu[j][j] = saved;
        }
        for j in 0..=p {
            ders[0][j] = ndu[j][p];
        }
        let mut a = [[0.0; MAX_DEGREE + 1]; 2];
        for r in 0..=p {
            let (mut s1, mut s2) = (0usize, 1usize);
            a[0][0] = 1.0;
            for k in 1..=nd {
                let mut d = 0.0;
                let rk = r as isize - k as isize;
                let pk = p - k;
                if r >= k {
                    a[s2][0] = a[s1][0] / ndu[pk + 1][r - k];
                    d = a[s2][0] * ndu[r - k][pk];
                }
                let j1 = if rk >= -1 { 1 } else { (-rk) as usize };
                let j2 = if r as isize - 1 <= pk as isize {
                    k - 1
                } else {
                    p - r
                };
                for j in j1..=j2 {
                    let idx = (rk + j as isize) as usize;
                    a[s2][j] = (a[s1][j] - a[s1][j - 1]) / ndu[pk + 1][idx];
                    d += a[s2][j] * ndu[idx][pk];
                }
                if r <= pk {
                    a[s2][k] = -a[s1][k - 1] / ndu[pk + 1][r];
                    d += a[s2][k] * ndu[r][pk];
                }
                ders[k][r] = d;
                std::mem::swap(&mut s1, &mut s2);
            }
        }
        let mut factor = p as f64;
        for k in 1..=nd {
            for j in 0..=p {
                ders[k][j] *= factor;
            }
            factor *= (p - k) as f64;
        }
    }
}

/// Knots by averaging (eq. 9.8) for n = params.len() points and degree p ≥ 1.
fn averaged_knots(params: &[f64], p: usize) -> Vec<f64> {
    let n = params.len();
    let (first, last) = (params[0], params[n - 1]);
    let mut knots = Vec::with_capacity(n + p + 1);
    knots.extend(std::iter::repeat_n(first, p + 1));
    // Running window sum: O(n) rather than O(n·p).
    let mut sum: f64 = params[1..p].iter().sum();
    for j in 1..n - p {
        sum += params[j + p - 1];
        knots.push(sum / p as f64);
        sum -= params[j];
    }
    knots.extend(std::iter::repeat_n(last, p + 1));
    knots
}

fn validate(params: &[f64], points: &[f64], dim: usize, degree: usize) -> Result<(), BSplineError> {
    if dim == 0 {
        return Err(BSplineError::ZeroDim);
    }
    if params.is_empty() {
        return Err(BSplineError::Empty);
    }
    if degree == 0 || degree > MAX_DEGREE {
        return Err(BSplineError::Degree { degree });
    }
    if points.len() != params.len() * dim {
        return Err(BSplineError::Shape {
            values: points.len(),
            params: params.len(),
            dim,
        });
    }
    for (index, &value) in params.iter().enumerate() {
        if !value.is_finite() {
            return Err(BSplineError::NonFiniteParam { index, value });
        }
        if index > 0 && value <= params[index - 1] {
            return Err(BSplineError::NotIncreasing {
                index,
                prev: params[index - 1],
                value,
            });
        }
    }
    check_points(points, dim)
}

fn check_points(points: &[f64], dim: usize) -> Result<(), BSplineError> {
    match points.iter().position(|v| !v.is_finite()) {
        Some(i) => Err(BSplineError::NonFinitePoint {
            index: i / dim,
            coord: i % dim,
            value: points[i],
        }),
        None => Ok(()),
    }
}

fn flatten3(points: &[Vector3<f64>]) -> Vec<f64> {
    points.iter().flat_map(|v| [v.x, v.y, v.z]).collect()
}

/// Square band matrix with `kl` sub- and `ku` super-diagonals, row-major band storage:
/// entry (i, j) lives at `data[i * (kl + ku + 1) + (j + kl - i)]`.
#[derive(Debug)]
struct BandMatrix {
    n: usize,
    kl: usize,
    ku: usize,
    data: Vec<f64>,
}

impl BandMatrix {
    fn zeros(n: usize, kl: usize, ku: usize) -> Self {
        BandMatrix {
            n,
            kl,
            ku,
            data: vec![0.0; n * (kl + ku + 1)],
        }
    }

    fn idx(&self, i: usize, j: usize) -> usize {
        i * (self.kl + self.ku + 1) + (j + self.kl - i)
    }

    /// Sets (i, j); returns false (and stores nothing) if (i, j) is outside the band.
    fn set(&mut self, i: usize, j: usize, v: f64) -> bool {
        if j + self.kl < i || j > i + self.ku || j >= self.n {
            return false;
        }
        let k = self.idx(i, j);
        self.data[k] = v;
        true
    }

    /// In-place LU without pivoting (Golub & Van Loan, Alg. 4.3.1): L unit lower with `kl`
    /// sub-diagonals, U upper with `ku` super-diagonals. O(n·kl·ku).
    fn factor_lu(&mut self) -> Result<(), BSplineError> {
        let n = self.n;
        for k in 0..n {
            let pivot = self.data[self.idx(k, k)];
            if !pivot.is_finite() || pivot.abs() < f64::MIN_POSITIVE {
                return Err(BSplineError::Singular { row: k });
            }
            for i in k + 1..=(k + self.kl).min(n - 1) {
                let ik = self.idx(i, k);
                let l = self.data[ik] / pivot;
                self.data[ik] = l;
                if l == 0.0 {
                    continue;
                }
                for j in k + 1..=(k + self.ku).min(n - 1) {
                    let (ij, kj) = (self.idx(i, j), self.idx(k, j));
                    self.data[ij] -= l * self.data[kj];
                }
            }
        }
        Ok(())
    }

    /// Solves L U X = B for a row-major `n × d` right-hand side, in place.
    fn solve_in_place(&self, b: &mut [f64], d: usize) {
        let n = self.n;
        for i in 0..n {
            for k in i.saturating_sub(self.kl)..i {
                let l = self.data[self.idx(i, k)];
                for c in 0..d {
                    b[i * d + c] -= l * b[k * d + c];
                }
            }
        }
        for i in (0..n).rev() {
            for j in i + 1..=(i + self.ku).min(n - 1) {
                let u = self.data[self.idx(i, j)];
                for c in 0..d {
                    b[i * d + c] -= u * b[j * d + c];
                }
            }
            let diag = self.data[self.idx(i, i)];
            for c in 0..d {
                b[i * d + c] /= diag;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn fit(params: &[f64], pts: &[f64], dim: usize) -> BSpline {
        BSpline::interpolate(params, pts, dim, 3).expect("interpolation")
    }

    fn max_pass_error(s: &BSpline, params: &[f64], pts: &[f64]) -> f64 {
        let d = s.dim();
        let mut out = vec![0.0; d];
        let mut err: f64 = 0.0;
        for (k, &u) in params.iter().enumerate() {
            s.eval(u, &mut out);
            for c in 0..d {
                err = err.max((out[c] - pts[k * d + c]).abs());
            }
        }
        err
    }

    /// Max relative jump of derivative `k` across interior knots, via one-sided evaluation.
    fn max_jump(s: &BSpline, k: usize) -> f64 {
        let p = s.degree();
        let d = s.dim();
        let (mut left, mut right) = (vec![0.0; d], vec![0.0; d]);
        let mut worst: f64 = 0.0;
        let n_ctrl = s.control_points().len() / d;
        for span in p + 1..n_ctrl {
            let u = s.knots()[span];
            s.eval_in_span(span - 1, u, k, &mut left);
            s.eval_in_span(span, u, k, &mut right);
            for c in 0..d {
                let scale = left[c].abs().max(right[c].abs()).max(1.0);
                worst = worst.max((left[c] - right[c]).abs() / scale);
            }
        }
        worst
    }

    #[test]
    fn passes_through_points_in_5d() {
        let n = 40;
        let dim = 5;
        let params: Vec<f64> = (0..n).map(|i| (i as f64).powf(1.3)).collect();
        let pts: Vec<f64> = (0..n * dim).map(|i| ((i * 37 % 11) as f64).sin()).collect();
        let s = fit(&params, &pts, dim);
        assert_eq!(s.degree(), 3);
        assert_eq!(s.knots().len(), n + 4);
        let err = max_pass_error(&s, &params, &pts);
        assert!(err < 1e-9, "max interpolation error {err:e}");
    }

    #[test]
    fn is_c2_at_interior_knots() {
        let params: Vec<f64> = (0..30)
            .map(|i| i as f64 + 0.3 * ((i * 7) as f64).sin())
            .collect();
        let pts: Vec<f64> = (0..90).map(|i| ((i * 13 % 17) as f64) * 0.1).collect();
        let s = fit(&params, &pts, 3);
        for k in 0..=2 {
            let jump = max_jump(&s, k);
            assert!(jump < 1e-9, "derivative {k} jumps by {jump:e} (relative)");
        }
        // The third derivative of a cubic generally does jump: the check is not vacuous.
        assert!(max_jump(&s, 3) > 1e-3);
    }

    #[test]
    fn reproduces_a_cubic_polynomial() {
        let f = |u: f64| [1.0 - 2.0 * u + 0.5 * u * u * u, 3.0 * u * u - u * u * u];
        let df = |u: f64| [-2.0 + 1.5 * u * u, 6.0 * u - 3.0 * u * u];
        let d2f = |u: f64| [3.0 * u, 6.0 - 6.0 * u];
        let params: Vec<f64> = (0..12)
            .map(|i| -1.0 + 0.25 * i as f64 + 0.01 * (i * i) as f64)
            .collect();
        let pts: Vec<f64> = params.iter().flat_map(|&u| f(u)).collect();
        let s = fit(&params, &pts, 2);
        let mut out = [0.0; 2];
        let (lo, hi) = s.domain();
        for i in 0..=100 {
            let u = lo + (hi - lo) * i as f64 / 100.0;
            for (k, want) in [(0, f(u)), (1, df(u)), (2, d2f(u))] {
                s.eval_derivative(u, k, &mut out);
                for c in 0..2 {
                    let err = (out[c] - want[c]).abs();
                    assert!(
                        err < 1e-9,
                        "u = {u}, derivative {k}: {} vs {}",
                        out[c],
                        want[c]
                    );
                }
            }
        }
    }

    #[test]
    fn short_inputs_lower_the_degree() {
        let s = fit(&[2.0], &[1.0, 2.0], 2);
        assert_eq!(s.degree(), 0);
        let mut out = [0.0; 2];
        s.eval(-5.0, &mut out);
        assert_eq!(out, [1.0, 2.0]);
        s.eval_derivative(2.0, 1, &mut out);
        assert_eq!(out, [0.0, 0.0]);

        let s = fit(&[0.0, 2.0], &[0.0, 4.0], 1);
        assert_eq!(s.degree(), 1);
        s.eval(0.5, &mut out[..1]);
        assert!((out[0] - 1.0).abs() < 1e-12);

        let s = fit(&[0.0, 1.0, 2.0], &[0.0, 1.0, 4.0], 1);
        assert_eq!(s.degree(), 2);
        s.eval(1.5, &mut out[..1]);
        assert!(
            (out[0] - 2.25).abs() < 1e-12,
            "u² reproduced, got {}",
            out[0]
        );
    }

    #[test]
    fn clamps_outside_the_domain() {
        let params = [0.0, 0.3, 0.6, 1.0, 1.5];
        let pts = [0.0, 1.0, 0.0, -1.0, 2.0];
        let s = fit(&params, &pts, 1);
        let mut out = [0.0];
        s.eval(-3.0, &mut out);
        assert!((out[0] - 0.0).abs() < 1e-12);
        s.eval(9.0, &mut out);
        assert!((out[0] - 2.0).abs() < 1e-12);
        s.eval(f64::NAN, &mut out);
        assert!(out[0].is_nan());
    }

    #[test]
    fn rejects_bad_input() {
        use BSplineError as E;
        assert_eq!(BSpline::interpolate(&[], &[], 3, 3), Err(E::Empty));
        assert_eq!(BSpline::interpolate(&[0.0], &[0.0], 0, 3), Err(E::ZeroDim));
        assert_eq!(
            BSpline::interpolate(&[0.0], &[0.0], 1, 0),
            Err(E::Degree { degree: 0 })
        );
        assert!(matches!(
            BSpline::interpolate(&[0.0, 1.0], &[0.0], 1, 3),
            Err(E::Shape { .. })
        ));
        assert!(matches!(
            BSpline::interpolate(&[0.0, f64::NAN], &[0.0, 1.0], 1, 3),
            Err(E::NonFiniteParam { index: 1, .. })
        ));
        assert!(matches!(
            BSpline::interpolate(&[0.0, 1.0, 1.0], &[0.0, 1.0, 2.0], 1, 3),
            Err(E::NotIncreasing { index: 2, .. })
        ));
        assert!(matches!(
            BSpline::interpolate(&[0.0, 1.0], &[0.0, 0.0, 1.0, f64::INFINITY], 2, 3),
            Err(E::NonFinitePoint {
                index: 1,
                coord: 1,
                ..
            })
        ));
    }

    #[test]
    fn chord_length_params_are_normalized_and_handle_coincident_points() {
        let p = chord_length_params(&[0.0, 0.0, 3.0, 4.0, 3.0, 4.0, 3.0, 8.0], 2).unwrap();
        assert_eq!(p.len(), 4);
        assert_eq!((p[0], p[3]), (0.0, 1.0));
        assert!(p.windows(2).all(|w| w[1] > w[0]), "{p:?}");
        // Chords 5, 0 (floored to 0.003), 4.
        assert!((p[1] - 5.0 / 9.003).abs() < 1e-12);
        let same = chord_length_params(&[1.0; 9], 3).unwrap();
        assert_eq!(same, vec![0.0, 0.5, 1.0]);
        assert_eq!(chord_length_params(&[7.0, 7.0], 2).unwrap(), vec![0.0]);
        assert!(chord_length_params(&[], 2).unwrap().is_empty());
        assert!(chord_length_params(&[0.0, f64::NAN], 1).is_err());
        assert_eq!(
            chord_length_params(&[0.0, 1e308, -1e308], 1),
            Err(BSplineError::ChordOverflow)
        );
    }

    #[test]
    fn interpolate3_and_eval3_agree_with_the_flat_api() {
        let pts: Vec<Vector3<f64>> = (0..20)
            .map(|i| Vector3::new((i as f64).cos(), (i as f64).sin(), 0.1 * i as f64))
            .collect();
        let params = chord_length_params3(&pts).unwrap();
        let s = BSpline::interpolate3(&params, &pts, 3).unwrap();
        for (u, q) in params.iter().zip(&pts) {
            assert!((s.eval3(*u) - q).norm() < 1e-9);
        }
        let v = s.eval_derivative3(0.4, 1);
        let h = 1e-6;
        let fd = (s.eval3(0.4 + h) - s.eval3(0.4 - h)) / (2.0 * h);
        assert!((v - fd).norm() < 1e-5 * v.norm().max(1.0), "{v} vs {fd}");
    }

    /// Not a timing assertion: 50 000 points would need 20 GB as a dense system.
    #[test]
    fn large_inputs_are_linear_in_memory() {
        let n = 50_000;
        let params: Vec<f64> = (0..n).map(|i| i as f64 * 0.01).collect();
        let pts: Vec<f64> = params.iter().flat_map(|&u| [u.sin(), u.cos(), u]).collect();
        let s = fit(&params, &pts, 3);
        let mut out = [0.0; 3];
        for k in (0..n).step_by(997) {
            s.eval(params[k], &mut out);
            for c in 0..3 {
                assert!((out[c] - pts[3 * k + c]).abs() < 1e-9);
            }
        }
    }

    /// `cargo test --release --lib bspline::tests::timing -- --ignored --nocapture`
    #[test]
    #[ignore = "timing report, run in release"]
    fn timing_5000_points() {
        let n = 5000;
        let params: Vec<f64> = (0..n)
            .map(|i| i as f64 + 0.5 * ((i * 7) as f64).sin())
            .collect();
        let pts: Vec<f64> = (0..3 * n).map(|i| ((i * 31 % 101) as f64).sin()).collect();
        let start = std::time::Instant::now();
        let reps = 100;
        for _ in 0..reps {
            std::hint::black_box(fit(&params, &pts, 3));
        }
        let fit_ms = start.elapsed().as_secs_f64() * 1e3 / reps as f64;
        let s = fit(&params, &pts, 3);
        let mut out = [0.0; 3];
        let start = std::time::Instant::now();
        for i in 0..1_000_000 {
            s.eval(i as f64 * 0.005, &mut out);
            std::hint::black_box(&out);
        }
        let eval_ns = start.elapsed().as_secs_f64() * 1e3;
        println!("5000-point cubic fit in 3-D: {fit_ms:.3} ms; eval: {eval_ns:.1} ns/call");
    }

    fn strictly_increasing(n: usize) -> impl Strategy<Value = Vec<f64>> {
        prop::collection::vec(1e-3f64..10.0, n).prop_map(|steps| {
            let mut acc = -5.0;
            steps
                .iter()
                .map(|s| {
                    acc += s;
                    acc
                })
                .collect()
        })
    }

    fn case() -> impl Strategy<Value = (Vec<f64>, Vec<f64>, usize, usize)> {
        (1usize..60, 1usize..5, 1usize..=5).prop_flat_map(|(n, dim, degree)| {
            (
                strictly_increasing(n),
                prop::collection::vec(-100.0f64..100.0, n * dim),
                Just(dim),
                Just(degree),
            )
        })
    }

    proptest! {
        #[test]
        fn prop_interpolates_and_is_smooth((params, pts, dim, degree) in case()) {
            let s = BSpline::interpolate(&params, &pts, dim, degree).unwrap();
            prop_assert_eq!(s.degree(), degree.min(params.len() - 1));
            // Relative to the larger of the points and the control points: the elimination
            // is backward stable, but where neighbouring steps differ 1e4-fold a degree-5
            // interpolant swings far past its points (proptest found control points of
            // 1.8e16 for points of 77), and the error it passes the points with scales with
            // that swing, not with the points.
            let scale = pts
                .iter()
                .chain(s.control_points())
                .fold(1.0f64, |m, v| m.max(v.abs()));
            let err = max_pass_error(&s, &params, &pts);
            prop_assert!(err < 1e-9 * scale, "interpolation error {:e}", err);
            if s.degree() >= 1 {
                for k in 0..s.degree() {
                    let jump = max_jump(&s, k);
                    prop_assert!(jump < 1e-6, "derivative {} jumps by {:e}", k, jump);
                }
            }
        }

        #[test]
        fn prop_chord_params_are_strictly_increasing(
            pts in prop::collection::vec(prop::sample::select(vec![0.0, 1.0, -2.5]), 2..60)
        ) {
            let params = chord_length_params(&pts, 1).unwrap();
            prop_assert_eq!(params.len(), pts.len());
            prop_assert_eq!(params[0], 0.0);
            prop_assert_eq!(*params.last().unwrap(), 1.0);
            prop_assert!(params.windows(2).all(|w| w[1] > w[0]), "{:?}", params);
            prop_assert!(BSpline::interpolate(&params, &pts, 1, 3).is_ok());
        }
    }
}

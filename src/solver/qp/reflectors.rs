//! Householder QR of a tall matrix M (n rows) column by column, the same reflections applied to
//! a second matrix J from the right, both in panels of [`PANEL`] reflections in compact WY
//! form:
//!
//! ```text
//!     Hₖ = I − βₖ vₖ vₖᵀ   (vₖ zero above row k),      Hₛ Hₛ₊₁ ⋯ Hₛ₊ₚ₋₁ = I − V T Vᵀ
//! ```
//! with V = [vₛ … vₛ₊ₚ₋₁] (nonzero in rows `s..` only) and T (p×p) upper triangular,
//! `Tⱼⱼ = βⱼ`, `T[..j, j] = −βⱼ T[..j, ..j] V[:, ..j]ᵀ vⱼ` (Schreiber & Van Loan, SIAM J. Sci.
//! Stat. Comput. 10, 1989). When a panel is complete, `J ← J − ((J V) T) Vᵀ` and M's later
//! columns `M ← M − V (Tᵀ (Vᵀ M))` are matrix products (nalgebra's, on the `matrixmultiply`
//! kernels) over rows / columns `s..` only, instead of one rank-one update of all of J per
//! reflection. Inside the open panel, a column of M gets the panel's reflections one by one
//! before it is tested and reduced, so which columns are reduced can be decided column by
//! column (a QR without pivoting that skips columns, in their order).
//!
//! Reflection k maps the part `x = M[k.., c]` of the column it reduces (norm σ > 0) to `α e₀`:
//! `α = −sign(x₀) σ` (so that `v = x − α e₀` does not cancel) and `β = 2 / vᵀv =
//! 1 / (σ (σ + |x₀|))`.

use nalgebra::DMatrix;

/// Reflections per panel: enough for the products to run at the kernels' speed, few enough that
/// the panel's own columns (reflected one by one) stay a small part of the work.
const PANEL: usize = 16;

/// The reflections of a column-by-column Householder QR: those of the open panel (see the
/// module header), after `start` reflections already applied to M's later columns and to J.
#[derive(Debug, Clone)]
pub(super) struct Reflectors {
    /// Rows of M and columns of J.
    n: usize,
    /// Reflections before the open panel: the panel's rows are `start..n`.
    start: usize,
    /// The open panel's vectors, column-major, `n − start` rows each (vₖ zero in the panel's
    /// rows before `k − start`).
    v: Vec<f64>,
    /// βₖ of the open panel's reflections.
    beta: Vec<f64>,
}

impl Reflectors {
    /// No reflection yet, for M with `n` rows and J with `n` columns.
    pub(super) fn new(n: usize) -> Self {
        Reflectors {
            n,
            start: 0,
            v: Vec::new(),
            beta: Vec::new(),
        }
    }

    /// The number k of reflections so far.
    pub(super) fn len(&self) -> usize {
        self.start + self.beta.len()
    }

    /// Applies the open panel's reflections, in order, to column `c` of `m` (which has had the
    /// closed panels' already): afterwards `m[.., c]` is `Hₖ₋₁ ⋯ H₀` times the column as it
    /// was first.
    pub(super) fn bring_up_to_date(&self, m: &mut DMatrix<f64>, c: usize) {
        let (n, rows) = (self.n, self.n - self.start);
        let column = &mut m.as_mut_slice()[c * n + self.start..(c + 1) * n];
        for (r, (v, &beta)) in self.v.chunks_exact(rows).zip(&self.beta).enumerate() {
            let (v, x) = (&v[r..], &mut column[r..]);
            let coefficient = -beta * dot(v, x);
            for (xi, &vi) in x.iter_mut().zip(v) {
                *xi += coefficient * vi;
            }
        }
    }

    /// Appends reflection k (k = [`Reflectors::len`]) that maps `m[k.., c]` (norm `sigma` >
    /// 0; the column brought up to date) to `α e₀`, stores α in `m[k, c]` and zeros below it,
    /// and returns α. A complete panel is applied to m's columns `c + 1..` and to `j`.
    pub(super) fn reduce(
        &mut self,
        m: &mut DMatrix<f64>,
        c: usize,
        sigma: f64,
        j: &mut DMatrix<f64>,
    ) -> f64 {
        let (n, k) = (self.n, self.len());
        debug_assert_eq!((m.nrows(), j.ncols()), (n, n));
        let column = &mut m.as_mut_slice()[c * n + k..(c + 1) * n];
        let head = column[0];
        let alpha = if head > 0.0 { -sigma } else { sigma };
        self.beta.push(1.0 / (sigma * (sigma + head.abs())));
        self.v.resize(self.v.len() + (k - self.start), 0.0);
        self.v.extend_from_slice(column);
        let last = self.v.len() - column.len();
        self.v[last] -= alpha;
        column[0] = alpha;
        column[1..].fill(0.0);
        if self.beta.len() == PANEL {
            self.close_panel(m, c + 1, j);
        }
        alpha
    }

    /// Applies the open panel to J (`J ← J Hₛ ⋯ Hₖ₋₁`); the reflections are then complete.
    pub(super) fn finish(self, j: &mut DMatrix<f64>) {
        if !self.beta.is_empty() {
            self.apply_right(&self.compact_form(), j);
        }
    }

    /// Applies the complete open panel to m's columns `first..` and to J, and opens an empty
    /// one.
    fn close_panel(&mut self, m: &mut DMatrix<f64>, first: usize, j: &mut DMatrix<f64>) {
        let panel = self.compact_form();
        self.apply_right(&panel, j);
        let (s, later) = (self.start, m.ncols() - first);
        if later > 0 {
            // M ← Qᵀ M = M − V (Tᵀ (Vᵀ M)) on rows s.. of the later columns.
            let (v, vt, t) = &panel;
            let mut m2 = m.view_mut((s, first), (self.n - s, later));
            let tt_vt_m = t.transpose() * (vt * &m2);
            m2.gemm(-1.0, v, &tt_vt_m, 1.0);
        }
        self.start += self.beta.len();
        self.v.clear();
        self.beta.clear();
    }

    /// `J ← J Q = J − ((J V) T) Vᵀ` on J's columns `s..`, Q the open panel's `(V, Vᵀ, T)`.
    fn apply_right(
        &self,
        (v, vt, t): &(DMatrix<f64>, DMatrix<f64>, DMatrix<f64>),
        j: &mut DMatrix<f64>,
    ) {
        let mut j2 = j.columns_mut(self.start, self.n - self.start);
        let jvt = &j2 * v * t;
        j2.gemm(-1.0, &jvt, vt, 1.0);
    }

    /// The open panel's V (rows `s..`), Vᵀ and T.
    fn compact_form(&self) -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
        let v = DMatrix::from_column_slice(self.n - self.start, self.beta.len(), &self.v);
        let vt = v.transpose();
        let t = self.triangular_factor(&v, &vt);
        (v, vt, t)
    }

    /// T of the open panel's compact WY form (module header) from its V and Vᵀ: the column
    /// recurrence on the Gram matrix VᵀV.
    fn triangular_factor(&self, v: &DMatrix<f64>, vt: &DMatrix<f64>) -> DMatrix<f64> {
        let p = self.beta.len();
        let gram = vt * v;
        let mut t = DMatrix::zeros(p, p);
        for (j, &beta) in self.beta.iter().enumerate() {
            t[(j, j)] = beta;
            for i in 0..j {
                let s: f64 = (i..j).map(|l| t[(i, l)] * gram[(l, j)]).sum();
                t[(i, j)] = -beta * s;
            }
        }
        t
    }
}

/// `aᵀb` over slices of equal length, in four partial sums (so that the loop vectorizes).
fn dot(a: &[f64], b: &[f64]) -> f64 {
    let mut partial = [0.0; 4];
    let (a4, b4) = (a.chunks_exact(4), b.chunks_exact(4));
    let tail: f64 = (a4.remainder().iter().zip(b4.remainder()))
        .map(|(x, y)| x * y)
        .sum();
    for (x, y) in a4.zip(b4) {
        for l in 0..4 {
            partial[l] += x[l] * y[l];
        }
    }
    (partial[0] + partial[2]) + (partial[1] + partial[3]) + tail
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn the_panels_are_the_reflections_one_after_the_other() {
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        // Panels: none complete, exactly one, several and an open one.
        for (n, cols) in [(1, 1), (5, 3), (16, 16), (40, 37)] {
            let m = DMatrix::from_fn(n, cols, |_, _| rng.random_range(-1.0..1.0));
            let j0 = DMatrix::from_fn(n, n, |_, _| rng.random_range(-1.0..1.0));
            let (mut reduced, mut j) = (m.clone(), j0.clone());
            let mut reflectors = Reflectors::new(n);
            // One reflection at a time of a copy of M and J, by nalgebra's products.
            let (mut m_reference, mut j_reference) = (m.clone(), j0);
            for c in 0..cols.min(n) {
                reflectors.bring_up_to_date(&mut reduced, c);
                let sigma = reduced.view((c, c), (n - c, 1)).norm();
                let alpha = reflectors.reduce(&mut reduced, c, sigma, &mut j);
                let x = m_reference.view((c, c), (n - c, 1)).into_owned();
                let mut v = DMatrix::zeros(n, 1);
                v.view_mut((c, 0), (n - c, 1)).copy_from(&x);
                v[(c, 0)] -= alpha;
                let beta = 1.0 / (sigma * (sigma + x[0].abs()));
                let vtm = v.transpose() * &m_reference;
                m_reference.gemm(-beta, &v, &vtm, 1.0);
                let jv = &j_reference * &v;
                j_reference.gemm(-beta, &jv, &v.transpose(), 1.0);
                assert!((alpha - m_reference[(c, c)]).abs() < 1e-13);
            }
            reflectors.finish(&mut j);
            assert!((&j - &j_reference).amax() < 1e-13, "{n} × {cols}");
            // The reduced M is R: Qᵀ M with Q = H₀ ⋯ Hₖ₋₁, zero below the diagonal.
            assert!((&reduced - &m_reference).amax() < 1e-13, "{n} × {cols}");
            for c in 0..cols.min(n) {
                assert!(
                    reduced
                        .view((c + 1, c), (n - c - 1, 1))
                        .iter()
                        .all(|&x| x == 0.0)
                );
            }
            // α opposite in sign to the head it replaces (no cancellation in v).
            assert!(reduced[(0, 0)] * m[(0, 0)] < 0.0);
        }
    }

    #[test]
    fn the_partial_sums_dot_is_the_dot_product() {
        for len in [0, 1, 3, 4, 5, 17] {
            let a: Vec<f64> = (0..len).map(|i| (i as f64 * 0.7).sin()).collect();
            let b: Vec<f64> = (0..len).map(|i| (i as f64 * 1.3).cos()).collect();
            let exact: f64 = a.iter().zip(&b).map(|(x, y)| x * y).sum();
            assert!((dot(&a, &b) - exact).abs() < 1e-14);
        }
    }
}

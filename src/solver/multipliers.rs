//! Initial Lagrange multipliers: the least-squares solution of `∇f + Jᵀλ = 0` over the
//! equality rows and the inequality rows active or violated at the start (others 0), as IPOPT
//! initializes them (Wächter & Biegler 2006, §3.6). They are discarded (all 0) when larger than
//! [`MAX_INITIAL_MULTIPLIER`] or when the normal equations are singular; inequality
//! multipliers of the wrong sign (the convention of `Solution`: λ ≤ 0 at a lower bound) are
//! set to 0. They give an exact Hessian its constraint curvature from the first iteration on.
//! All quantities are those of the scaled problem.
//!
//! The QP multipliers of void rows (every Jacobian entry at most [`VOID_ROW`] in magnitude) are
//! set to 0 by [`clear_void_rows`]: any value satisfies stationarity on such a row, and 0 is the
//! least-norm choice. The QP solvers do not make that choice: the sparse method's KKT
//! equilibration scales a row of entries 1e-27 (a truss joint whose members all went idle, the
//! balance row across their plane) up to unit norm and returns multipliers of 1e27, which then
//! weight that row's constraint curvature in the exact Hessian and its penalty in the merit.
//!
//! Small problems form the normal equations `J Jᵀ λ = −J ∇f` densely; when `rows × n` exceeds
//! [`DENSE_ENTRIES`] the equivalent augmented system is factored sparse instead (J stays
//! sparse; no rows×n matrix and no J Jᵀ).

use nalgebra::{DMatrix, DVector};
use nalgebra_sparse::CsrMatrix;

use super::kkt::{KktSolver, Regularization};

/// Largest initial least-squares multiplier kept (IPOPT's `constr_mult_init_max`).
pub const MAX_INITIAL_MULTIPLIER: f64 = 1e3;

/// Largest Jacobian entry (scaled problem, whose rows start with gradients of O(1)) of a row
/// that counts as void: rounding of terms that are zero (a force that is exactly 0 times a
/// direction), ten orders below any row the problem means.
pub const VOID_ROW: f64 = 1e-12;

/// Sets to 0 the multipliers of the void rows of `jac` (see the module header).
pub fn clear_void_rows(jac: &CsrMatrix<f64>, lambda: &mut [f64]) {
    for (row, l) in jac.row_iter().zip(lambda.iter_mut()) {
        if row.values().iter().all(|v| v.abs() <= VOID_ROW) {
            *l = 0.0;
        }
    }
}

/// Largest `rows × n` for which J is formed densely.
const DENSE_ENTRIES: usize = 4_000_000;

/// First-order data at one point.
pub struct LinearizedPoint<'a> {
    /// Objective gradient (length n).
    pub grad: &'a [f64],
    /// Jacobian pattern rows.
    pub jac_rows: &'a [usize],
    /// Jacobian pattern columns.
    pub jac_cols: &'a [usize],
    /// Jacobian values in pattern order.
    pub jac: &'a [f64],
    /// Constraint values (length m).
    pub c: &'a [f64],
    /// Constraint bounds.
    pub cl: &'a [f64],
    /// Constraint bounds.
    pub cu: &'a [f64],
}

/// The least-squares multiplier estimate (length m).
pub fn least_squares(p: &LinearizedPoint) -> Vec<f64> {
    let (n, m) = (p.grad.len(), p.c.len());
    let mut lambda = vec![0.0; m];
    let rows: Vec<usize> = (0..m)
        .filter(|&i| p.cl[i] == p.cu[i] || p.c[i] <= p.cl[i] || p.c[i] >= p.cu[i])
        .collect();
    if rows.is_empty() || rows.len() > n {
        return lambda;
    }
    let mut position = vec![usize::MAX; m];
    for (k, &i) in rows.iter().enumerate() {
        position[i] = k;
    }
    let estimate = if rows.len() * n <= DENSE_ENTRIES {
        dense_estimate(p, &position, rows.len())
    } else {
        sparse_estimate(p, &position, rows.len())
    };
    let Some(estimate) = estimate else {
        return lambda;
    };
    if estimate.amax() > MAX_INITIAL_MULTIPLIER || !estimate.iter().all(|v| v.is_finite()) {
        return lambda;
    }
    for (k, &i) in rows.iter().enumerate() {
        let (c, l, u) = (p.c[i], p.cl[i], p.cu[i]);
        let v = estimate[k];
        let sign_ok = l == u || (c <= l && v <= 0.0) || (c >= u && v >= 0.0);
        lambda[i] = if sign_ok { v } else { 0.0 };
    }
    lambda
}

/// The least-squares estimate on the selected rows (`position[i]` = index among them) with
/// dense normal equations regularized by `1e-12·max diag`; None if singular.
fn dense_estimate(p: &LinearizedPoint, position: &[usize], count: usize) -> Option<DVector<f64>> {
    let n = p.grad.len();
    let mut j: DMatrix<f64> = DMatrix::zeros(count, n);
    for (k, (&r, &c)) in p.jac_rows.iter().zip(p.jac_cols).enumerate() {
        if position[r] != usize::MAX {
            j[(position[r], c)] += p.jac[k];
        }
    }
    let g = DVector::from_column_slice(p.grad);
    let mut normal: DMatrix<f64> = &j * j.transpose();
    let scale = normal.diagonal().amax().max(1e-300);
    for k in 0..count {
        normal[(k, k)] += 1e-12 * scale;
    }
    Some(normal.cholesky()?.solve(&(-(&j * g))))
}

/// As [`dense_estimate`] with sparse J, through the augmented system
/// ```text
///     [ I   Jᵀ ] [r]   [−∇f]
///     [ J  −εI ] [λ] = [ 0 ]       (r = −∇f − Jᵀλ, J r = 0 ⇔ J Jᵀ λ = −J ∇f)
/// ```
/// which is quasi-definite, so the fill-reducing (AMD) LDLᵀ of [`KktSolver`] is stable and
/// J Jᵀ is never formed: dense rows of J (a mean over all vertices, a volume) would fill it,
/// and a Cholesky factorization of it without ordering took minutes at 10⁴ rows.
fn sparse_estimate(p: &LinearizedPoint, position: &[usize], count: usize) -> Option<DVector<f64>> {
    let n = p.grad.len();
    let (mut rows, mut cols, mut values) = (Vec::new(), Vec::new(), Vec::new());
    for (k, (&r, &c)) in p.jac_rows.iter().zip(p.jac_cols).enumerate() {
        if position[r] != usize::MAX {
            rows.push(n + position[r]);
            cols.push(c);
            values.push(p.jac[k]);
        }
    }
    let (mut kkt, positions) = KktSolver::from_lower_triplets(n, count, &rows, &cols).ok()?;
    for (&at, &v) in positions.iter().zip(&values) {
        kkt.values_mut()[at] += v;
    }
    for j in 0..n {
        let at = kkt.diagonal_position(j);
        kkt.values_mut()[at] = 1.0;
    }
    kkt.factor(Regularization::default()).ok()?;
    let mut rhs: Vec<f64> = p.grad.iter().map(|g| -g).collect();
    rhs.resize(n + count, 0.0);
    kkt.solve_refined(&mut rhs, REFINEMENT_STEPS, 1e-14).ok()?;
    Some(DVector::from_column_slice(&rhs[n..]))
}

/// Refinement steps of the augmented-system solve.
const REFINEMENT_STEPS: usize = 10;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn void_rows_lose_their_multipliers() {
        use nalgebra_sparse::CooMatrix;
        // Row 0 is a real row, row 1 has only rounding-level entries, row 2 is empty.
        let coo = CooMatrix::try_from_triplets(
            3,
            2,
            vec![0, 0, 1, 1],
            vec![0, 1, 0, 1],
            vec![1.0, -2e-13, 5e-27, -3e-13],
        )
        .unwrap();
        let jac = CsrMatrix::from(&coo);
        let mut lambda = vec![2.0, 5e27, -7.0];
        clear_void_rows(&jac, &mut lambda);
        assert_eq!(lambda, vec![2.0, 0.0, 0.0]);
    }

    #[test]
    fn recovers_the_multipliers_of_a_kkt_point() {
        // min x₀ + x₁ s.t. x₀² + x₁² = 2 at (−1, −1): ∇f + λ∇c = (1, 1) + λ(−2, −2) = 0.
        let lambda = least_squares(&LinearizedPoint {
            grad: &[1.0, 1.0],
            jac_rows: &[0, 0],
            jac_cols: &[0, 1],
            jac: &[-2.0, -2.0],
            c: &[2.0],
            cl: &[2.0],
            cu: &[2.0],
        });
        assert!((lambda[0] - 0.5).abs() < 1e-12);
    }

    #[test]
    fn sparse_and_dense_normal_equations_agree() {
        // 300 rows over 20,000 variables (above DENSE_ENTRIES): row i touches x_i, x_{i+1}.
        let (m, n) = (300, 20_000);
        let (mut rows, mut cols, mut jac) = (vec![], vec![], vec![]);
        for i in 0..m {
            for (c, v) in [(i, 1.0 + 0.01 * i as f64), (i + 1, -0.5)] {
                rows.push(i);
                cols.push(c);
                jac.push(v);
            }
        }
        let grad: Vec<f64> = (0..n).map(|j| (0.1 * j as f64).sin()).collect();
        let zeros = vec![0.0; m];
        let point = LinearizedPoint {
            grad: &grad,
            jac_rows: &rows,
            jac_cols: &cols,
            jac: &jac,
            c: &zeros,
            cl: &zeros,
            cu: &zeros,
        };
        assert!(m * n > DENSE_ENTRIES);
        let position: Vec<usize> = (0..m).collect();
        let sparse = sparse_estimate(&point, &position, m).unwrap();
        let dense = dense_estimate(&point, &position, m).unwrap();
        assert!((&sparse - &dense).amax() < 1e-10 * (1.0 + dense.amax()));
        assert_eq!(least_squares(&point), sparse.as_slice());
    }

    #[test]
    fn inactive_and_wrong_sign_inequalities_get_zero() {
        // Row 0 inactive (c inside its bounds); row 1 at its lower bound, where the estimate
        // λ = +1 from (−1, 0) + λ(1, 0) = 0 has the wrong sign for a lower bound.
        let lambda = least_squares(&LinearizedPoint {
            grad: &[-1.0, 0.0],
            jac_rows: &[0, 1],
            jac_cols: &[0, 0],
            jac: &[1.0, 1.0],
            c: &[0.5, 0.0],
            cl: &[0.0, 0.0],
            cu: &[1.0, f64::INFINITY],
        });
        assert_eq!(lambda, vec![0.0, 0.0]);
        // With the opposite gradient the estimate λ = −1 has the right sign and is kept.
        let lambda = least_squares(&LinearizedPoint {
            grad: &[1.0, 0.0],
            jac_rows: &[0, 1],
            jac_cols: &[0, 0],
            jac: &[1.0, 1.0],
            c: &[0.5, 0.0],
            cl: &[0.0, 0.0],
            cu: &[1.0, f64::INFINITY],
        });
        assert_eq!(lambda[0], 0.0);
        assert!((lambda[1] + 1.0).abs() < 1e-9, "{lambda:?}");
    }
}

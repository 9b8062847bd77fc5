//! Initial Lagrange multipliers: the least-squares solution of `∇f + Jᵀλ = 0` over the
//! equality rows and the inequality rows active or violated at the start (others 0), as IPOPT
//! initializes them (Wächter & Biegler 2006, §3.6). They are discarded (all 0) when larger than
//! [`MAX_INITIAL_MULTIPLIER`] or when the normal equations are singular; inequality
//! multipliers of the wrong sign (the convention of `Solution`: λ ≤ 0 at a lower bound) are
//! set to 0. They give an exact Hessian its constraint curvature from the first iteration on.
//! All quantities are those of the scaled problem.

use nalgebra::{DMatrix, DVector};

/// Largest initial least-squares multiplier kept (IPOPT's `constr_mult_init_max`).
pub const MAX_INITIAL_MULTIPLIER: f64 = 1e3;

/// Largest number of rows for which the dense normal equations are formed.
const MAX_ROWS: usize = 2000;

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
    if rows.is_empty() || rows.len() > n || rows.len() > MAX_ROWS {
        return lambda;
    }
    let mut position = vec![usize::MAX; m];
    for (k, &i) in rows.iter().enumerate() {
        position[i] = k;
    }
    let mut j: DMatrix<f64> = DMatrix::zeros(rows.len(), n);
    for (k, (&r, &c)) in p.jac_rows.iter().zip(p.jac_cols).enumerate() {
        if position[r] != usize::MAX {
            j[(position[r], c)] += p.jac[k];
        }
    }
    let g = DVector::from_column_slice(p.grad);
    let mut normal: DMatrix<f64> = &j * j.transpose();
    let scale = normal.diagonal().amax().max(1e-300);
    for k in 0..rows.len() {
        normal[(k, k)] += 1e-12 * scale;
    }
    let Some(chol) = normal.cholesky() else {
        return lambda;
    };
    let estimate = chol.solve(&(-(&j * g)));
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

#[cfg(test)]
mod tests {
    use super::*;

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
